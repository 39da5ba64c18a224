"""The light dose a cell receives from the optical traps: the trapping laser's intensity
on the cell, integrated over time.

Beam model. Each trap is a focused TEM00 Gaussian beam of power ``power_mw`` at the
sample and waist (1/e^2 intensity radius at the focus) ``waist_um``, with its focus in
the focal plane. In the paraxial approximation its intensity at lateral distance r from
its axis and height z above the focal plane is

    I(r, z) = 2 P / (pi w(z)^2) exp(-2 r^2 / w(z)^2),   w(z) = w0 sqrt(1 + (z / zR)^2),

with Rayleigh range zR = pi w0^2 n / lambda (Siegman, *Lasers*, 1986, ch. 17; as used for
optical tweezers by Svoboda & Block, Annu. Rev. Biophys. Biomol. Struct. 23, 247, 1994).
The peak intensity 2 P / (pi w0^2) is at the focus.

The intensity at a cell. A cell is a sphere of radius R centred in the focal plane; the
intensity it sees from one trap is the largest over its volume: for each height z in
[-R, R] (``Z_SAMPLES`` evenly spaced heights), the beam at the cell's point nearest the
axis, max(0, D - sqrt(R^2 - z^2)) from it (D: the distance from the trap's axis to the
cell's centre). The traps' intensities are summed (an upper bound on the peak of the sum,
equal to it when one trap dominates). A trap whose focus lies inside the cell (a cell
held directly) gives the cell its focus intensity 2 P / (pi w0^2).

The dose. Intensity (mW/um^2) times time (s): mJ/um^2 (1 mJ/um^2 = 10^5 J/cm^2). The
tasks add intensity x control period each step, at the positions after the step.

A bound (what the tests check): at a point with lateral distance at least a from the
axis, I <= 2 P / (pi w^2) exp(-2 a^2 / w^2) <= P / (pi e a^2) for every w (the right side
is the largest over w, at w^2 = 2 a^2). So a cell whose surface is at least a from every
one of N traps of power P gets at most N P / (pi e a^2), and a cell held in the focus of
one such trap gets 2 P / (pi w0^2): a ratio of at least 2 e a^2 / (N w0^2).

The traps' power. otgym's trap laws give stiffness, not power; a trap's power is its
centre stiffness over ``STIFFNESS_PER_POWER_PN_PER_UM_MW`` (0.2 pN/um per mW, the
assumption the ``assemble`` task also makes, of the order Neuman & Block, Rev. Sci.
Instrum. 75, 2787, 2004, report for ~1 um beads). Its waist is the Gaussian (and
harmonic) law's ``waist_um``; for the paper's law, whose linear range ends at delta, it is
2 delta, since a Gaussian trap's force is largest at r = w0 / 2 (``otgym.physics.traps``).
The wavelength is 1.064 um (Nd:YAG, the common trapping laser) in water (n = 1.33).

Left out: the light scattered or refracted by the cell and the robots, the beam's
aberrations in the sample, absorption of the beam by the cell on its way (the cell is
taken as transparent), and heating of the medium by the beam (about 1 K per 100 mW in
water at 1064 nm, Peterman, Gittes & Schmidt, Biophys. J. 84, 1308, 2003), which reaches
a cell near a handle trap without any light reaching it.
"""

from __future__ import annotations

import dataclasses
import math

import jax
import jax.numpy as jnp

from otgym.physics.traps import TrapLaw
from otgym.physics.validation import require_positive_scalar

STIFFNESS_PER_POWER_PN_PER_UM_MW = 0.2
WAVELENGTH_UM = 1.064
MEDIUM_INDEX = 1.33
Z_SAMPLES = 33


@dataclasses.dataclass(frozen=True)
class TrapBeam:
    """One trap's beam: power at the sample (mW), focal waist (um), vacuum wavelength
    (um) and the medium's refractive index (hashable, static under jit)."""

    power_mw: float
    waist_um: float
    wavelength_um: float = WAVELENGTH_UM
    medium_index: float = MEDIUM_INDEX

    def __post_init__(self):
        for name in ("power_mw", "waist_um", "wavelength_um", "medium_index"):
            require_positive_scalar(name, getattr(self, name))

    @classmethod
    def of_trap_law(cls, law: TrapLaw, stiffness_per_power_pn_per_um_mw: float = STIFFNESS_PER_POWER_PN_PER_UM_MW):
        """The beam of a trap obeying ``law``: power from its centre stiffness, waist
        from its own parameters (the module docstring says how)."""
        require_positive_scalar("stiffness_per_power_pn_per_um_mw", stiffness_per_power_pn_per_um_mw)
        waist = 2 * law.paper_delta_um if law.name == "paper" else law.waist_um
        return cls(law.centre_stiffness_pn_per_um / stiffness_per_power_pn_per_um_mw, waist)

    @property
    def rayleigh_range_um(self) -> float:
        return math.pi * self.waist_um**2 * self.medium_index / self.wavelength_um

    @property
    def focus_intensity_mw_per_um2(self) -> float:
        """The peak intensity 2 P / (pi w0^2), at the focus."""
        return 2 * self.power_mw / (math.pi * self.waist_um**2)


def beam_intensity_mw_per_um2(beam: TrapBeam, radial_um, z_um):
    """I(r, z) of ``beam`` (mW/um^2) at lateral distance ``radial_um`` from its axis and
    height ``z_um`` above its focus (broadcast arrays)."""
    width_sq = beam.waist_um**2 * (1 + (jnp.asarray(z_um) / beam.rayleigh_range_um) ** 2)
    return 2 * beam.power_mw / (jnp.pi * width_sq) * jnp.exp(-2 * jnp.asarray(radial_um) ** 2 / width_sq)


def cell_intensity_mw_per_um2(beam: TrapBeam, trap_xy_um, cell_xy_um, cell_radius_um, active=None):
    """The intensity (mW/um^2) a spherical cell sees from traps of ``beam``: the sum over
    traps of each one's largest intensity within the cell (module docstring).

    ``trap_xy_um`` (..., T, 2), ``cell_xy_um`` (..., 2), ``cell_radius_um`` scalar or
    (...,); ``active`` (..., T) bool (None: all traps on). Returns (...,). Pure, jittable."""
    trap_xy = jnp.asarray(trap_xy_um)
    cell_xy = jnp.asarray(cell_xy_um)
    radius = jnp.asarray(cell_radius_um, trap_xy.dtype)
    distance = jnp.sqrt(jnp.sum((trap_xy - cell_xy[..., None, :]) ** 2, axis=-1))  # (..., T)
    fraction = jnp.linspace(-1.0, 1.0, Z_SAMPLES, dtype=trap_xy.dtype)  # z / R
    z = radius[..., None, None] * fraction  # (..., 1, Z)
    half_chord = radius[..., None, None] * jnp.sqrt(1 - fraction**2)
    lateral = jnp.maximum(distance[..., None] - half_chord, 0.0)  # (..., T, Z)
    per_trap = jnp.max(beam_intensity_mw_per_um2(beam, lateral, z), axis=-1)
    if active is not None:
        per_trap = jnp.where(jnp.asarray(active), per_trap, 0.0)
    return jnp.sum(per_trap, axis=-1)


cell_intensity_jit = jax.jit(cell_intensity_mw_per_um2, static_argnums=0)
"""``cell_intensity_mw_per_um2`` compiled as one program per beam and shapes: what a
host loop calls each tick (called eagerly, its dozen primitives each dispatch and
compile on their own)."""


def dose_bound_ratio(surface_distance_um: float, n_traps: int, waist_um: float) -> float:
    """The least ratio of the dose of a cell held in one trap's focus to that of a cell
    whose surface stays at least ``surface_distance_um`` from each of ``n_traps`` traps
    of the same power: 2 e a^2 / (N w0^2) (module docstring)."""
    return 2 * math.e * surface_distance_um**2 / (n_traps * waist_um**2)
