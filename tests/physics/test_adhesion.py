"""Adhesion from the literature: Hamaker constants per material pair, Gregory's
retardation, and what they mean for a user: robots can let go of a cell, and a trap
pulls its handle off a wall.

The two behaviour tests each run a negative control with the previous single constant
(polystyrene-polystyrene, 9.5e-21 J, non-retarded, for every pair), under which the
cell and the handle stick: so the tests would fail if adhesion were that strong."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from flax import struct

from otgym import physics as ph
from otgym.physics.adhesion import vdw_force_pn
from otgym.physics.interactions import sphere_pair_forces
from tests.physics.helpers import batch_state, run_batch

STICKY = ph.Adhesion(
    hamaker_across_water_j=(("polymer", 9.5e-21), ("cell", 9.5e-21), ("glass", 9.5e-21)),
    retardation_wavelength_um=math.inf,
)
"""The constants before issue 10: polystyrene for every pair, no retardation."""
N_ENV = 8


def test_hamaker_constants_follow_the_table_and_the_combining_rule():
    adhesion = ph.Adhesion()
    assert adhesion.hamaker_pn_um("polymer", "polymer") == pytest.approx(9e-3)
    assert adhesion.hamaker_pn_um("cell", "cell") == pytest.approx(1e-3)
    assert adhesion.hamaker_pn_um("polymer", "cell") == pytest.approx(3e-3)
    assert adhesion.hamaker_pn_um("glass", "polymer") == pytest.approx(math.sqrt(9 * 13) * 1e-3)
    with pytest.raises(ValueError, match="material"):
        adhesion.hamaker_pn_um("polymer", "steel")
    with pytest.raises(ValueError, match="min_gap_um"):
        ph.Adhesion(min_gap_um=0.0)
    with pytest.raises(ValueError, match="material"):
        ph.custom_body("x", [(0, 0)], [1.0], material="steel")


def test_model_gives_each_pair_and_each_wall_contact_its_materials_constant():
    model = ph.build_model([ph.two_handle_robot("robot"), ph.cell("cell"), ph.bead("bead")], ph.PhysicsConfig())
    adhesion = ph.Adhesion()
    kinds = np.asarray(model.sphere_body)
    materials = ["polymer", "cell", "polymer"]
    for pair, (a, b) in enumerate(zip(model.pair_a, model.pair_b)):
        expected = adhesion.hamaker_pn_um(materials[kinds[a]], materials[kinds[b]])
        assert float(model.pair_hamaker_pn_um[pair]) == pytest.approx(expected, rel=1e-6)
    for sphere, body in enumerate(kinds):
        expected = adhesion.hamaker_pn_um(materials[body], "glass")
        assert float(model.wall_hamaker_pn_um[sphere]) == pytest.approx(expected, rel=1e-6)


def test_retarded_force_is_minus_gradient_of_gregorys_energy_and_weaker_than_hamaker():
    hamaker, radius, wavelength = 3e-3, 0.8, 0.1

    def energy(gap):  # Gregory 1981: V = -A R / (6 D (1 + 14 D / lambda))
        return -hamaker * radius / (6 * gap * (1 + 14 * gap / wavelength))

    for gap in (0.06, 0.1, 0.3):
        derivative = (energy(gap + 1e-5) - energy(gap - 1e-5)) / 2e-5
        force = float(vdw_force_pn(hamaker, radius, np.float32(gap), 0.05, wavelength))
        assert force == pytest.approx(derivative, rel=1e-4)
        assert force < hamaker * radius / (6 * gap**2)
    # the pair force uses it with the reduced radius a b / (a + b)
    a, b = 1.0, 4.0
    on_a_x = sphere_pair_forces(jnp.array(a + b + 0.1), jnp.array(0.0), a, b, 1.0, hamaker, 0.05, wavelength)[0]
    assert float(on_a_x) == pytest.approx(
        float(vdw_force_pn(hamaker, a * b / (a + b), 0.1, 0.05, wavelength)), rel=1e-5
    )


def _gripped_cell_model(adhesion):
    """Robot A below a cell, robot B (turned by pi) above it, grippers 0.05 um from it."""
    bodies = [ph.two_handle_robot("a"), ph.cell("cell"), ph.two_handle_robot("b")]
    config = ph.PhysicsConfig(dt_s=1e-4, substeps=1000, trap_law=ph.TrapLaw("gaussian", 50.0, 0.6), adhesion=adhesion)
    model = ph.build_model(bodies, config)
    offsets = np.asarray(model.sphere_offset_um)
    gripper = offsets[ph.TWO_HANDLE_GRIPPER_SPHERES[0]]
    reach = 4.0 + 1.0 + 0.05
    cell_y = gripper[1] + math.sqrt(reach**2 - gripper[0] ** 2)
    return model, [[0.0, 0.0, 0.0], [0.0, cell_y, 0.0], [0.0, 2 * cell_y, math.pi]]


def _cell_gap_after_release(adhesion, seed):
    """Gap (E, robots) between the cell and each robot's nearest sphere after the robots
    back away from it: 0.5 s held, 1 s apart at 2 um/s each, 1 s still (room temperature)."""
    model, pose = _gripped_cell_model(adhesion)
    state = batch_state(model, pose, N_ENV)
    key = jax.random.PRNGKey(seed)
    still = ph.Controls.zeros(model, N_ENV)
    state, _ = run_batch(model, state, still, key, n_steps=5)
    away = np.zeros((N_ENV, model.n_traps, 2), np.float32)
    away[:, :2, 1], away[:, 2:, 1] = -2.0, 2.0  # traps 0, 1 hold robot a; 2, 3 robot b
    state, _ = run_batch(model, state, still.replace(trap_velocity_um_s=jnp.asarray(away)), key, n_steps=10)
    state, _ = run_batch(model, state, still, key, n_steps=10)
    xy = np.asarray(ph.sphere_positions_um(model, state.pose))
    radius = np.asarray(model.sphere_radius_um)
    body = np.asarray(model.sphere_body)
    cell = np.flatnonzero(body == 1)[0]
    gaps = np.linalg.norm(xy - xy[:, cell : cell + 1], axis=-1) - radius - radius[cell]
    return np.stack([gaps[:, body == robot].min(axis=1) for robot in (0, 2)], axis=1)


@pytest.mark.slow
def test_robots_can_let_go_of_a_cell():
    """After backing 2 um away, each robot is clear of the cell in all 8 runs: the cell
    diffuses (0.55 um rms over the 2.5 s) between robots 4 um apart, and a stuck cell
    sits within 0.01 um of its robot, so "clear" is more than 0.1 um (twice the minimum
    gap; the least seen over 2 x 8 runs of seeds 1 and 5 was 0.25 um). With the old
    constants the cell rides along on one robot in nearly every run (15 of 2 x 8 runs
    of seeds 1 and 5; one escaped), so the control asks for at least 6 of 8: the
    released test above would fail for them."""
    released = _cell_gap_after_release(ph.Adhesion(), seed=1)
    assert released.min() > 0.1, released
    stuck = _cell_gap_after_release(STICKY, seed=1)
    assert np.sum(stuck.min(axis=1) < 0.1) >= 6, stuck


@struct.dataclass
class FloorWall:
    """A straight wall along y = 0, the fluid above it."""

    def distance_and_normal(self, xy_um):
        normal = jnp.zeros_like(xy_um).at[..., 1].set(1.0)
        return xy_um[..., 1], normal


def _handle_gap_after_pull(adhesion, seed):
    """A 1.25 um polymer sphere held by the paper's trap law touches a glass wall (gap
    0.05 um); its trap jumps 0.5 um away from the wall (a pull of 0.24 pN, below the law's
    0.30 pN maximum). Returns the sphere's wall gaps (E,) after 2 s."""
    config = ph.PhysicsConfig(
        dt_s=1e-3, substeps=100, viscosity_pa_s=1.0e-3, trap_law=ph.TrapLaw.paper(), adhesion=adhesion
    )
    model = ph.build_model([ph.bead("handle", radius_um=1.25)], config, walls=FloorWall())
    start_y = 1.25 + 0.05
    state = batch_state(model, [[0.0, start_y, 0.0]], N_ENV, trap_xy=[[0.0, start_y + 0.5]])
    state, _ = run_batch(model, state, ph.Controls.zeros(model, N_ENV), jax.random.PRNGKey(seed), n_steps=20)
    return np.asarray(state.pose[:, 0, 1]) - 1.25


def test_a_trap_pulls_its_handle_off_a_wall():
    """Glass-polymer adhesion (0.21 pN at the 50 nm minimum gap) is below the paper trap's
    pull, so in all 8 runs the handle leaves the wall and settles at its trap: 0.55 um
    out with a thermal spread of sqrt(kT / K) = 0.095 um, so 0.2 um is 3.7 sd below;
    with the old constants (0.79 pN) every handle stays within 0.05 um of the wall."""
    freed = _handle_gap_after_pull(ph.Adhesion(), seed=2)
    assert freed.min() > 0.2, freed
    stuck = _handle_gap_after_pull(STICKY, seed=2)
    assert stuck.max() < 0.15, stuck
