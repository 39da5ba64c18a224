"""The light dose model (``otgym.physics.light_dose``): a cell in a trap's focus sees the
focus intensity 2 P / (pi w0^2); intensity is linear in power; a cell carried by the
transport scene's robots, whose traps sit on their handles, sees at least
2 e a^2 / (N w0^2) times less than a cell held directly (a: its surface's distance from
the nearest trap; the bound holds for any Gaussian beam width, see the module)."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from otgym import physics as ph
from otgym.physics import light_dose as ld
from otgym.sim import scene as sc

intensity_of = jax.jit(ld.cell_intensity_mw_per_um2, static_argnums=0)


def test_a_cell_in_the_focus_sees_the_focus_intensity():
    beam = ld.TrapBeam(power_mw=20.0, waist_um=0.6)
    intensity = intensity_of(beam, jnp.array([[10.0, 5.0]]), jnp.array([10.0, 5.0]), 4.0)
    assert float(intensity) == pytest.approx(2 * 20.0 / (math.pi * 0.36), rel=1e-6)
    # one trap off: nothing
    off = intensity_of(beam, jnp.array([[10.0, 5.0]]), jnp.array([10.0, 5.0]), 4.0, jnp.array([False]))
    assert float(off) == 0.0


def test_intensity_is_linear_in_power_and_falls_with_distance():
    traps = jnp.array([[0.0, 0.0], [5.0, 1.0]])
    cells = jnp.array([[4.5, 0.0], [6.0, 0.0], [0.0, 9.0]])
    low = intensity_of(ld.TrapBeam(5.0, 0.6), traps[None], cells, 3.0)
    high = intensity_of(ld.TrapBeam(15.0, 0.6), traps[None], cells, 3.0)
    np.testing.assert_allclose(np.asarray(high), 3 * np.asarray(low), rtol=1e-5)
    assert np.all(np.diff(np.asarray(low)) < 0)  # the cells lie farther and farther from the traps


def test_the_trap_laws_beams():
    paper = ld.TrapBeam.of_trap_law(ph.TrapLaw.paper())
    assert paper.power_mw == pytest.approx(0.455 / 0.2)
    assert paper.waist_um == pytest.approx(2 * 0.446)
    gaussian = ld.TrapBeam.of_trap_law(ph.TrapLaw("gaussian", stiffness_pn_per_um=50.0, waist_um=0.6))
    assert (gaussian.power_mw, gaussian.waist_um) == (pytest.approx(250.0), 0.6)
    with pytest.raises(ValueError, match="power_mw"):
        ld.TrapBeam(0.0, 0.6)


def _carried_traps(cell_radius_um: float):
    """The four handle traps of the transport scene's two robots gripping a cell at the
    origin (the scene's own geometry, without a chip)."""
    return jnp.asarray(sc.grip_geometry_um(sc.SceneConfig(cell_radius_um=cell_radius_um))[0], jnp.float32)


@pytest.mark.parametrize("cell_radius_um", [3.0, 5.0])
def test_a_carried_cell_gets_far_less_light_than_a_trapped_one(cell_radius_um):
    beam = ld.TrapBeam.of_trap_law(ph.TrapLaw.paper())
    traps = _carried_traps(cell_radius_um)
    cell = jnp.zeros(2)
    surface_gap = float(jnp.min(jnp.linalg.norm(traps - cell, axis=-1))) - cell_radius_um
    assert surface_gap > 2.0  # the handles are well clear of the cell
    carried = float(intensity_of(beam, traps, cell, cell_radius_um))
    held = float(intensity_of(beam, cell[None], cell, cell_radius_um))
    bound = ld.dose_bound_ratio(surface_gap, len(traps), beam.waist_um)
    assert bound > 10.0
    assert carried > 0.0 and held / carried >= bound
    # the same light at the same power over the same time: the dose ratio is the intensity ratio
    assert held * 7.0 / (carried * 7.0) >= bound
