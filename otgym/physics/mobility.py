"""Mobility of a rigid multi-sphere body in a viscous fluid at low Reynolds number.

Model (shared/DESIGN.md): spheres do not interact hydrodynamically; each sphere i of
radius a_i at offset r_i from the reference point contributes translational drag
gamma_i = 6 pi eta a_i (Stokes) and rotational drag 8 pi eta a_i^3. The body's
planar resistance is then

    gamma_t = sum_i gamma_i
    gamma_r = sum_i (8 pi eta a_i^3 + gamma_i |r_i - c|^2)

about the *drag centre* c = sum_i gamma_i r_i / sum_i gamma_i. About c the
translation-rotation coupling vanishes exactly in the plane, so the mobility is
diagonal and the Brownian noise needs no spurious-drift correction. Poses in otgym
are therefore poses of the drag centre.

Near-wall correction (optional): a sphere whose centre is a height h above the chip
floor has its drag raised by Faxen's series for motion parallel to a no-slip wall,
    gamma_par = 6 pi eta a / (1 - 9/16 x + 1/8 x^3 - 45/256 x^4 - 1/16 x^5),  x = a/h,
and for rotation about the wall normal by 1 / (1 - x^3/8) (Happel & Brenner,
Low Reynolds Number Hydrodynamics, 1965, ch. 7; Leach et al., Phys. Rev. E 79,
026301, 2009).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from otgym.physics.validation import require_positive


def faxen_parallel_factor(radius_um, height_um) -> np.ndarray:
    """Drag increase factor (>= 1) for translation parallel to a no-slip wall."""
    x = np.asarray(radius_um, float) / np.asarray(height_um, float)
    return 1.0 / (1 - 9 / 16 * x + x**3 / 8 - 45 / 256 * x**4 - x**5 / 16)


def wall_normal_rotation_factor(radius_um, height_um) -> np.ndarray:
    """Drag increase factor (>= 1) for rotation about the wall normal."""
    x = np.asarray(radius_um, float) / np.asarray(height_um, float)
    return 1.0 / (1 - x**3 / 8)


def sphere_drag(radii_um, viscosity_pa_s: float, height_above_floor_um: float | None = None):
    """Per-sphere (translational pN*s/um, rotational pN*s*um) drag coefficients."""
    radii = require_positive("radii_um", radii_um)
    eta = float(require_positive("viscosity_pa_s", viscosity_pa_s))
    translational = 6 * np.pi * eta * radii
    rotational = 8 * np.pi * eta * radii**3
    if height_above_floor_um is not None:
        height = float(require_positive("height_above_floor_um", height_above_floor_um))
        if np.any(radii >= height):
            raise ValueError(
                f"height_above_floor_um={height} must exceed every sphere radius "
                f"(largest {radii.max()}): a sphere would cut the chip floor"
            )
        translational = translational * faxen_parallel_factor(radii, height)
        rotational = rotational * wall_normal_rotation_factor(radii, height)
    return translational, rotational


@dataclasses.dataclass(frozen=True)
class BodyDrag:
    """Planar drag of one rigid body about its drag centre.

    drag_centre_um: the drag centre in the body's input frame (offsets are shifted
    by it); translational_pn_s_per_um, rotational_pn_s_um: diagonal resistance;
    max_point_mobility_um_per_pn_s: the largest mobility of the body under a force
    applied through a sphere centre, 1/gamma_t + R^2/gamma_r with R the distance of the
    farthest sphere centre (contact and trap forces act along lines through centres).
    """

    drag_centre_um: np.ndarray
    translational_pn_s_per_um: float
    rotational_pn_s_um: float
    max_point_mobility_um_per_pn_s: float


def body_drag(offsets_um, radii_um, viscosity_pa_s: float,
              height_above_floor_um: float | None = None) -> BodyDrag:
    """Drag of a sphere cluster about its drag centre (model in the module docstring)."""
    offsets = np.asarray(offsets_um, float)
    radii = np.asarray(radii_um, float)
    gamma_i, gamma_rot_i = sphere_drag(radii, viscosity_pa_s, height_above_floor_um)
    gamma_t = float(gamma_i.sum())
    centre = (gamma_i[:, None] * offsets).sum(axis=0) / gamma_t
    lever = offsets - centre
    gamma_r = float(np.sum(gamma_rot_i + gamma_i * np.sum(lever**2, axis=1)))
    reach = float(np.max(np.linalg.norm(lever, axis=1)))
    return BodyDrag(centre, gamma_t, gamma_r, 1.0 / gamma_t + reach**2 / gamma_r)
