"""Mobility of a rigid multi-sphere body in a viscous fluid at low Reynolds number.

Default model (``interaction=True``): the spheres of a body interact
hydrodynamically in the Rotne-Prager-Yamakawa approximation, and the body's planar
resistance R (3 x 3: x, y, rotation) and its drag from a background flow come from
the rigid multiblob method of ``otgym.physics.hydrodynamics``. A cluster of touching
spheres drags markedly less than the sum of its spheres' Stokes drags (two touching
spheres: 0.62-0.72 of it). The body's translational block may be anisotropic (a bar
drags less along its axis).

Free-draining model (``interaction=False``): each sphere i of radius a_i contributes
Stokes' drag gamma_i = 6 pi eta a_i and rotational drag 8 pi eta a_i^3 on its own,
optionally raised near the chip floor: a sphere whose centre is a height h above a
no-slip wall has Faxen's series for motion parallel to it,
    gamma_par = 6 pi eta a / (1 - 9/16 x + 1/8 x^3 - 45/256 x^4 - 1/16 x^5),  x = a/h,
and 1 / (1 - x^3/8) for rotation about the wall normal (Happel & Brenner, Low Reynolds
Number Hydrodynamics, 1965, ch. 7; Leach et al., Phys. Rev. E 79, 026301, 2009). The
near-floor correction of interacting spheres of unequal radii with rotations is not
published in a usable form (see ``hydrodynamics``), so a floor height requires the
free-draining model.

Either way the body is described about its *hydrodynamic centre* c: the point about
which translation and rotation decouple. In the plane it always exists: with
R = [[A, b], [b^T, r]] about the offsets' origin, the coupling about a point p is
b - A J p (J the 90 degree rotation), zero for J c = A^-1 b. About c the mobility is
block diagonal, diag(A^-1, 1/r'), with r' = r - b^T A^-1 b, and since A^-1 depends on
the body's angle only through a rotation and no entry couples position to angle, the
divergence of the mobility vanishes: Brownian motion needs no spurious-drift term.
For the free-draining model c is the drag-weighted centre sum gamma_i r_i / sum gamma_i.
Poses in otgym are poses of the hydrodynamic centre.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from otgym.physics.hydrodynamics import planar_flow_weights, resistance_matrix
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
class BodyHydrodynamics:
    """Planar hydrodynamics of one rigid body about its hydrodynamic centre.

    centre_um: the hydrodynamic centre in the body's input frame (offsets are shifted
    by it). In the body frame about the centre: translational_resistance_pn_s_per_um
    (2, 2), rotational_resistance_pn_s_um; flow_weights (S, 3, 3): the body's
    [F_x, F_y, T_z] is sum_i flow_weights[i] [u_x, u_y, w_z / 2] for a flow of velocity
    u (um/s) and vorticity w_z (1/s) at sphere i. max_point_mobility_um_per_pn_s: the
    largest mobility of a sphere centre under a force through it (contact and trap
    forces act along lines through centres), which sets the contact stiffness and the
    stable step.
    """

    centre_um: np.ndarray
    translational_resistance_pn_s_per_um: np.ndarray
    rotational_resistance_pn_s_um: float
    flow_weights: np.ndarray
    max_point_mobility_um_per_pn_s: float

    @property
    def translational_mobility_um_per_pn_s(self) -> np.ndarray:
        return np.linalg.inv(self.translational_resistance_pn_s_per_um)

    @property
    def rotational_mobility_per_pn_um_s(self) -> float:
        return 1.0 / self.rotational_resistance_pn_s_um


def _free_draining(offsets_um, radii_um, viscosity_pa_s, height_above_floor_um):
    """Planar resistance about the offsets' origin and flow weights of independent spheres."""
    gamma_i, gamma_rot_i = sphere_drag(radii_um, viscosity_pa_s, height_above_floor_um)
    lever = np.stack([-offsets_um[:, 1], offsets_um[:, 0]], axis=1)  # J r_i
    weights = np.zeros((len(gamma_i), 3, 3))
    weights[:, 0, 0] = weights[:, 1, 1] = gamma_i
    weights[:, 2, :2] = gamma_i[:, None] * lever
    weights[:, 2, 2] = gamma_rot_i
    resistance = np.zeros((3, 3))
    resistance[:2, :2] = gamma_i.sum() * np.eye(2)
    resistance[:2, 2] = resistance[2, :2] = (gamma_i[:, None] * lever).sum(axis=0)
    resistance[2, 2] = np.sum(gamma_rot_i + gamma_i * np.sum(lever**2, axis=1))
    return resistance, weights


def _planar(offsets_um, radii_um, viscosity_pa_s, interaction, height_above_floor_um):
    if interaction:
        return (
            resistance_matrix(offsets_um, radii_um, viscosity_pa_s),
            planar_flow_weights(offsets_um, radii_um, viscosity_pa_s),
        )
    return _free_draining(offsets_um, radii_um, viscosity_pa_s, height_above_floor_um)


def body_hydrodynamics(
    offsets_um, radii_um, viscosity_pa_s: float, *, interaction: bool = True, height_above_floor_um: float | None = None
) -> BodyHydrodynamics:
    """A sphere cluster's planar hydrodynamics about its hydrodynamic centre (model in
    the module docstring). Raises ValueError for a floor height with interaction."""
    offsets = np.asarray(offsets_um, float)
    radii = require_positive("radii_um", radii_um)
    if interaction and height_above_floor_um is not None:
        raise ValueError(
            "height_above_floor_um: the near-floor correction exists only for the free-draining "
            "model; set hydrodynamic_interaction=False (interaction=False) to use it"
        )
    about_origin, _ = _planar(offsets, radii, viscosity_pa_s, interaction, height_above_floor_um)
    j_centre = np.linalg.solve(about_origin[:2, :2], about_origin[:2, 2])  # J c = A^-1 b
    centre = np.array([j_centre[1], -j_centre[0]])
    lever = offsets - centre
    resistance, weights = _planar(lever, radii, viscosity_pa_s, interaction, height_above_floor_um)
    translational = (resistance[:2, :2] + resistance[:2, :2].T) / 2
    mobility_t = np.linalg.inv(translational)
    arm = np.stack([-lever[:, 1], lever[:, 0]], axis=1)  # a force F at sphere i turns the body by (J l_i).F
    point = mobility_t[None] + arm[:, :, None] * arm[:, None, :] / resistance[2, 2]
    reach = float(np.max(np.linalg.eigvalsh(point)))
    return BodyHydrodynamics(centre, translational, float(resistance[2, 2]), weights, reach)
