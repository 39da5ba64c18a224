"""Van der Waals adhesion between the materials of a chip, from the literature.

Materials: ``polymer`` (the robots, two-photon-polymerised resin, and trappable beads;
taken as polystyrene), ``cell`` (biological cells; the obstacles are taken to be other
cells of the sample), ``glass`` (the chip's walls).

Hamaker constants across water, A_11(3), from P. Walstra, *Physical Chemistry of
Foods* (Marcel Dekker, 2003), table 12.2: polystyrene 9e-21 J, glass about 13e-21 J,
biological cells about 1e-21 J. Between different materials the combining rule
A_12(3) = sqrt(A_11(3) A_22(3)) (Israelachvili, *Intermolecular and Surface Forces*,
3rd ed., section 13.6): polymer-cell 3.0e-21 J, polymer-glass 10.8e-21 J, cell-glass
3.6e-21 J. (The previous single constant, polystyrene-polystyrene 9.5e-21 J for every
pair, made a cell 3 times as sticky as it is.)

Retardation: beyond a few nanometres the dispersion force weakens because the
fluctuating fields take time to cross the gap; Gregory's expression for the
sphere-plate energy, V = -A R / (6 D (1 + 14 D / lambda)) with lambda = 100 nm
(J. Gregory, J. Colloid Interface Sci. 83, 138, 1981), gives the force
F = A R (1 + 28 D / lambda) / (6 D^2 (1 + 14 D / lambda)^2), the non-retarded
A R / (6 D^2) when D << lambda and a quarter of it at 50 nm. Sphere-sphere pairs use
the Derjaguin reduced radius R = a1 a2 / (a1 + a2).

Minimum gap: surfaces in a buffer do not reach contact; their charged double layers
(and any passivating coat) hold them apart. The gap D is clamped below at
``min_gap_um``, 50 nm by default: a few Debye lengths in a low-salt buffer (the Debye
length is 0.304 nm / sqrt(I / mol L^-1), about 10 nm at 1 mM; Israelachvili, ch. 14),
where the double-layer repulsion of like-charged surfaces balances the attraction. It
is a modelling choice, stated per scene: in physiological saline (Debye length 0.8 nm)
unpassivated surfaces do stick, which the scene can express with a smaller gap.

With these values a 1.25 um handle touching a wall is held by 0.21 pN (below the
paper law's 0.30 pN maximum, so its trap pulls it off) and a 1 um gripper sphere
touching a 4 um cell by 0.04 pN (the robots can let go of the cell).
"""

from __future__ import annotations

import dataclasses
import math

import jax.numpy as jnp

MATERIALS = ("polymer", "cell", "glass")
JOULE_TO_PN_UM = 1e18

WALSTRA_HAMAKER_ACROSS_WATER_J = (("polymer", 9e-21), ("cell", 1e-21), ("glass", 13e-21))
"""A_11(3) per material across water (Walstra 2003, table 12.2)."""

GREGORY_WAVELENGTH_UM = 0.1
"""Characteristic wavelength lambda of Gregory's retarded van der Waals force (1981)."""


def _check_material(name: str, material: str) -> None:
    if material not in MATERIALS:
        raise ValueError(f"{name} must be one of {MATERIALS}, got {material!r}")


@dataclasses.dataclass(frozen=True)
class Adhesion:
    """Van der Waals parameters of a scene (hashable, so it can sit in a frozen config).

    ``hamaker_across_water_j``: (material, A_11(3) in J) for every material;
    ``wall_material``: what the chip's walls are made of; ``min_gap_um``: the closest
    approach of two surfaces; ``retardation_wavelength_um``: Gregory's lambda (``inf``
    for the non-retarded Hamaker force)."""

    hamaker_across_water_j: tuple[tuple[str, float], ...] = WALSTRA_HAMAKER_ACROSS_WATER_J
    wall_material: str = "glass"
    min_gap_um: float = 0.05
    retardation_wavelength_um: float = GREGORY_WAVELENGTH_UM

    def __post_init__(self):
        table = dict(self.hamaker_across_water_j)
        for material in MATERIALS:
            if material not in table:
                raise ValueError(f"hamaker_across_water_j has no value for material {material!r}")
        for material, value in table.items():
            _check_material("hamaker_across_water_j material", material)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise ValueError(
                    f"Hamaker constant of {material!r} must be a non-negative number of joules, got {value!r}"
                )
        _check_material("wall_material", self.wall_material)
        if not (isinstance(self.min_gap_um, (int, float)) and math.isfinite(self.min_gap_um) and self.min_gap_um > 0):
            raise ValueError(f"min_gap_um must be a positive number, got {self.min_gap_um!r}")
        wavelength = self.retardation_wavelength_um
        if not (isinstance(wavelength, (int, float)) and wavelength > 0):
            raise ValueError(f"retardation_wavelength_um must be positive (inf: no retardation), got {wavelength!r}")

    @classmethod
    def none(cls) -> Adhesion:
        """No van der Waals force at all."""
        return cls(hamaker_across_water_j=tuple((m, 0.0) for m in MATERIALS))

    def hamaker_pn_um(self, material_a: str, material_b: str) -> float:
        """A_12(3) in pN um by the combining rule."""
        _check_material("material_a", material_a)
        _check_material("material_b", material_b)
        table = dict(self.hamaker_across_water_j)
        return math.sqrt(table[material_a] * table[material_b]) * JOULE_TO_PN_UM

    def force_pn(self, hamaker_pn_um, radius_um, gap_um):
        """Attractive force magnitude (pN) for an effective radius R (the sphere's radius
        against a wall, the reduced radius between spheres) at surface gap D (um)."""
        return vdw_force_pn(hamaker_pn_um, radius_um, gap_um, self.min_gap_um, self.retardation_wavelength_um)


def vdw_force_pn(hamaker_pn_um, radius_um, gap_um, min_gap_um, wavelength_um):
    """Gregory's retarded sphere-plate force A R (1 + 28 D/l) / (6 D^2 (1 + 14 D/l)^2)
    with D = max(gap, min gap) (array inputs broadcast; l = inf gives A R / (6 D^2))."""
    gap = jnp.maximum(gap_um, min_gap_um)
    ratio = gap / wavelength_um
    return hamaker_pn_um * radius_um * (1 + 28 * ratio) / (6 * gap**2 * (1 + 14 * ratio) ** 2)
