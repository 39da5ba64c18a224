"""Planar resistance of a rigid sphere cluster *with* hydrodynamic interaction (RPY).

``otgym.physics.mobility`` treats the spheres of a body as free-draining: the body's
drag is the sum of the spheres' Stokes drags. In reality each sphere moves in the flow
the others set up, and a cluster of touching or overlapping spheres drags markedly
less. This module computes the body resistance with the spheres'
hydrodynamic interaction in the Rotne-Prager-Yamakawa (RPY) approximation. It is
plain NumPy/SciPy, meant to be called once per body shape (a 7-sphere robot takes
well under a millisecond), not inside the JAX integrator, and it changes nothing in
the simulator by itself.

Method (rigid multiblob, e.g. Usabiaga, Kallemov, Delmotte, Bhalla, Griffith & Donev,
Commun. Appl. Math. Comput. Sci. 11, 217, 2016, "Hydrodynamics of suspensions of
passive and active rigid particles: a rigid multiblob approach"):

1. The grand mobility M (6S x 6S) of the S spheres in unbounded fluid, in 3-D: the
   RPY tensors (Rotne & Prager 1969; Yamakawa 1970) for spheres of unequal radii,
   with the forms for overlapping spheres and for a sphere inside another of
   Zuk, Wajnryb, Mizerski & Szymczak, J. Fluid Mech. 741, R5 (2014). By default
   (``sphere_rotation=True``) each sphere carries a force *and a torque*: M holds the
   translation-translation, rotation-rotation (self term 1/(8 pi eta a^3)) and
   translation-rotation blocks of the generalised RPY tensor, so one sphere is
   exactly Stokes (6 pi eta a, 8 pi eta a^3) and the rigid-body constraint holds the
   spheres' rotations too (Swan, Brady & Moore, Phys. Fluids 23, 071901, 2011). With
   ``sphere_rotation=False`` the spheres are translational blobs only (forces, no
   torques), the "rigid multiblob" of Usabiaga et al. used for shell models.
   The generalised RPY mobility is symmetric positive definite for any configuration
   of distinct spheres (Zuk et al. 2014).
2. Rigid motion: sphere i at r_i moves with U_i = U + Omega x r_i and spins with
   Omega, i.e. (U_i, Omega_i) = K (U, Omega); the sphere forces/torques lambda solve
   M lambda = K (U, Omega), and the body resistance about the origin of the offsets is
   N^-1 = K^T M^-1 K (6 x 6).
3. The planar block (x, y translation; rotation about z through the origin) of that
   6 x 6 resistance is returned. Bodies with all centres in the focal plane (z = 0)
   are mirror-symmetric about it, so in-plane and out-of-plane motions decouple and
   the block is the exact planar resistance of the model.

Accuracy (tests/physics/test_hydrodynamics.py): exact for one sphere. RPY is a
far-field approximation: it misses the near field (lubrication, higher multipoles)
between close spheres, so touching clusters come out a few per cent low. Two touching
equal spheres: 0.6154 of 2 x 6 pi eta a along their line of centres (exact 0.6451,
Stimson & Jeffery 1926: -4.6 %), 0.7177 broadside (exact 0.7244, Goldman, Cox &
Brenner 1966: -0.9 %); the two-handle robot 3 % below a refined shell-model Stokes
solution of its shape. Straight bead chains follow slender-body theory; a sphere made
of blobs on its surface converges to Stokes' law (Usabiaga et al.'s published values).

Near-wall (chip floor) corrections are not implemented for interacting spheres: the
Rotne-Prager-Blake tensor of Swan & Brady (Phys. Fluids 19, 113306, 2007) is published
for equal radii and translation only, which fits neither the unequal spheres of a
robot nor the rotation blocks used here. ``wall_height_um`` therefore raises
``NotImplementedError``; ``mobility.faxen_parallel_factor`` gives the per-sphere
factor of the free-draining model.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from otgym.physics.validation import require_finite, require_positive, require_positive_scalar

__all__ = ["grand_mobility", "planar_flow_weights", "resistance_matrix", "resistance_6x6"]


def _pair_geometry(centres):
    """Unit vectors e_ij = (x_i - x_j)/r_ij and distances r_ij (zero on the diagonal)."""
    diff = centres[:, None, :] - centres[None, :, :]
    dist = np.linalg.norm(diff, axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        unit = np.where(dist[..., None] > 0, diff / dist[..., None], 0.0)
    return unit, dist


def _tt_scalars(r, ai, aj, eta):
    """RPY translation-translation mobility f I + g e e of two distinct spheres."""
    r_safe = np.where(r > 0, r, 1.0)
    # far: r > ai + aj (Rotne-Prager-Yamakawa)
    s2 = ai**2 + aj**2
    f_far = (1 + s2 / (3 * r_safe**2)) / (8 * np.pi * eta * r_safe)
    g_far = (1 - s2 / r_safe**2) / (8 * np.pi * eta * r_safe)
    # overlapping: |ai - aj| < r <= ai + aj (Zuk et al. 2014)
    d2 = (ai - aj) ** 2
    pref = 1 / (6 * np.pi * eta * ai * aj)
    f_ov = pref * (16 * r_safe**3 * (ai + aj) - (d2 + 3 * r_safe**2) ** 2) / (32 * r_safe**3)
    g_ov = pref * 3 * (d2 - r_safe**2) ** 2 / (32 * r_safe**3)
    # one inside the other: r <= |ai - aj|
    f_in = 1 / (6 * np.pi * eta * np.maximum(ai, aj))
    far = r > ai + aj
    inside = r <= np.abs(ai - aj)
    f = np.where(far, f_far, np.where(inside, f_in, f_ov))
    g = np.where(far, g_far, np.where(inside, 0.0, g_ov))
    return f, g


def _rr_scalars(r, ai, aj, eta):
    """RPY rotation-rotation mobility f I + g e e of two distinct spheres."""
    r_safe = np.where(r > 0, r, 1.0)
    f_far = -1 / (16 * np.pi * eta * r_safe**3)
    g_far = 3 / (16 * np.pi * eta * r_safe**3)
    d = ai - aj
    q = ai**2 + 4 * ai * aj + aj**2
    pref = 1 / (8 * np.pi * eta * ai**3 * aj**3)
    f_ov = (
        pref
        * (
            5 * r_safe**6
            - 27 * r_safe**4 * (ai**2 + aj**2)
            + 32 * r_safe**3 * (ai**3 + aj**3)
            - 9 * r_safe**2 * (ai**2 - aj**2) ** 2
            - d**4 * q
        )
        / (64 * r_safe**3)
    )
    g_ov = pref * 3 * (d**2 - r_safe**2) ** 2 * (q - r_safe**2) / (64 * r_safe**3)
    f_in = 1 / (8 * np.pi * eta * np.maximum(ai, aj) ** 3)
    far = r > ai + aj
    inside = r <= np.abs(ai - aj)
    f = np.where(far, f_far, np.where(inside, f_in, f_ov))
    g = np.where(far, g_far, np.where(inside, 0.0, g_ov))
    return f, g


def _rt_scalar(r, ai, aj, eta):
    """h_ij of the rotation of sphere i due to a force F on sphere j:
    Omega_i = h_ij (x_j - x_i)/r x F (not symmetric in ai, aj when they overlap)."""
    r_safe = np.where(r > 0, r, 1.0)
    h_far = 1 / (8 * np.pi * eta * r_safe**2)
    h_ov = (
        (ai - aj + r_safe) ** 2
        * (aj**2 + 2 * aj * (ai + r_safe) - 3 * (ai - r_safe) ** 2)
        / (8 * r_safe**2)
        / (16 * np.pi * eta * ai**3 * aj)
    )
    # j inside i: i turns as a rigid sphere under the torque of F about its centre;
    # i inside j: the flow inside j is a uniform translation, no rotation.
    h_in = np.where(ai > aj, r / (8 * np.pi * eta * np.maximum(ai, aj) ** 3), 0.0)
    far = r > ai + aj
    inside = r <= np.abs(ai - aj)
    return np.where(far, h_far, np.where(inside, h_in, h_ov))


def _cross_matrices(vectors):
    """[v]_x for each v of (..., 3): [v]_x w = v x w."""
    x, y, z = vectors[..., 0], vectors[..., 1], vectors[..., 2]
    zero = np.zeros_like(x)
    return np.stack([np.stack([zero, -z, y], -1), np.stack([z, zero, -x], -1), np.stack([-y, x, zero], -1)], -2)


def grand_mobility(centres_um, radii_um, viscosity_pa_s, *, sphere_rotation: bool = True) -> np.ndarray:
    """Generalised RPY mobility of S spheres in unbounded fluid, (6S, 6S) ordered
    [U_1..U_S, Omega_1..Omega_S] x [F_1..F_S, T_1..T_S] (um/s per pN, 1/s per pN um
    ...), or (3S, 3S) translation only with ``sphere_rotation=False``. ``centres_um``
    is (S, 3); inputs are taken as validated (see ``resistance_matrix``)."""
    centres = np.asarray(centres_um, float)
    radii = np.asarray(radii_um, float)
    eta = float(viscosity_pa_s)
    n = radii.size
    unit, dist = _pair_geometry(centres)
    ai, aj = radii[:, None], radii[None, :]
    off = ~np.eye(n, dtype=bool)
    eye3 = np.eye(3)
    ee = unit[..., :, None] * unit[..., None, :]

    f, g = _tt_scalars(dist, ai, aj, eta)
    f = np.where(off, f, 1 / (6 * np.pi * eta * ai))
    g = np.where(off, g, 0.0)
    tt = f[..., None, None] * eye3 + g[..., None, None] * ee  # (S, S, 3, 3)
    blocks_tt = tt.transpose(0, 2, 1, 3).reshape(3 * n, 3 * n)
    if not sphere_rotation:
        return blocks_tt

    f, g = _rr_scalars(dist, ai, aj, eta)
    f = np.where(off, f, 1 / (8 * np.pi * eta * ai**3))
    g = np.where(off, g, 0.0)
    rr = f[..., None, None] * eye3 + g[..., None, None] * ee
    cross_e = _cross_matrices(unit)  # [e_ij]_x, e_ij = (x_i - x_j)/r
    h = np.where(off, _rt_scalar(dist, ai, aj, eta), 0.0)  # h[i, j] = h_ij
    rt = -h[..., None, None] * cross_e  # Omega_i from F_j: h_ij (x_j - x_i)/r x F = -h_ij e_ij x F
    tr = -h.T[..., None, None] * cross_e  # U_i from T_j: (rt_ji)^T = -h_ji [e_ij]_x

    def assemble(blocks):
        return blocks.transpose(0, 2, 1, 3).reshape(3 * n, 3 * n)

    return np.block([[blocks_tt, assemble(tr)], [assemble(rt), assemble(rr)]])


def _rigid_motion_matrix(centres, sphere_rotation: bool) -> np.ndarray:
    """K: (U, Omega) of the body about the origin -> sphere velocities (and spins)."""
    n = centres.shape[0]
    rows_t = np.zeros((n, 3, 6))
    rows_t[:, :, :3] = np.eye(3)
    rows_t[:, :, 3:] = -_cross_matrices(centres)  # Omega x r = -[r]_x Omega
    k = rows_t.reshape(3 * n, 6)
    if not sphere_rotation:
        return k
    rows_r = np.zeros((n, 3, 6))
    rows_r[:, :, 3:] = np.eye(3)
    return np.vstack([k, rows_r.reshape(3 * n, 6)])


def _validated(offsets_um, radii_um, viscosity_pa_s):
    radii = require_positive("radii_um", radii_um)
    if radii.ndim != 1 or radii.size == 0:
        raise ValueError(f"radii_um must be a non-empty 1-D array, got shape {radii.shape}")
    offsets = require_finite("offsets_um", offsets_um)
    if offsets.ndim != 2 or offsets.shape[0] != radii.size or offsets.shape[1] not in (2, 3):
        raise ValueError(
            f"offsets_um must have shape ({radii.size}, 2) or ({radii.size}, 3) to match radii_um, got {offsets.shape}"
        )
    eta = require_positive_scalar("viscosity_pa_s", viscosity_pa_s)
    centres = np.zeros((radii.size, 3))
    centres[:, : offsets.shape[1]] = offsets
    return centres, radii, eta


def _solved_rigid_motion(offsets_um, radii_um, viscosity_pa_s, sphere_rotation: bool):
    """(K, M^-1 K) for the cluster: the rigid-motion matrix and the sphere forces (and
    torques) per unit rigid motion."""
    centres, radii, eta = _validated(offsets_um, radii_um, viscosity_pa_s)
    mobility = grand_mobility(centres, radii, eta, sphere_rotation=sphere_rotation)
    k = _rigid_motion_matrix(centres, sphere_rotation)
    try:
        solved = scipy.linalg.cho_solve(scipy.linalg.cho_factor(mobility), k)
    except np.linalg.LinAlgError:
        # Only coincident identical spheres make M singular (their rows are equal);
        # the pseudo-inverse then counts them once, which is the right physics.
        solved = scipy.linalg.pinvh(mobility) @ k
    return k, solved


def resistance_6x6(offsets_um, radii_um, viscosity_pa_s, *, sphere_rotation: bool = True) -> np.ndarray:
    """Full rigid-body resistance K^T M^-1 K about the origin of the offsets, ordered
    (Ux, Uy, Uz, Ox, Oy, Oz) -> (Fx, Fy, Fz, Tx, Ty, Tz); see ``resistance_matrix``."""
    k, solved = _solved_rigid_motion(offsets_um, radii_um, viscosity_pa_s, sphere_rotation)
    resistance = k.T @ solved
    return (resistance + resistance.T) / 2


PLANAR = [0, 1, 5]
"""Rows/columns of (Ux, Uy, Uz, Ox, Oy, Oz) that stay in the focal plane."""


def planar_flow_weights(offsets_um, radii_um, viscosity_pa_s) -> np.ndarray:
    """Force and torque on the held-still body from a background flow, per sphere.

    Returns W (S, 3, 3): the body's [F_x, F_y, T_z] about the origin of the offsets is
    sum_i W[i] [u_x, u_y, w_z / 2](x_i), with u the flow velocity (um/s) and w_z its
    vorticity (1/s) at sphere i (a sphere in a flow spins at half the local vorticity).
    This is (M^-1 K)^T applied to the background motion of the spheres, the rigid
    multiblob's drag from an imposed flow (Usabiaga et al. 2016, eq. for the
    "slip"/background term), with sphere rotations (generalised RPY). In a uniform flow
    sum_i W[i][:, :2] equals the first two columns of ``resistance_matrix``; for one
    sphere W is diag(6 pi eta a, 6 pi eta a, 8 pi eta a^3) plus the lever arm.
    """
    k, solved = _solved_rigid_motion(offsets_um, radii_um, viscosity_pa_s, sphere_rotation=True)
    n = np.asarray(radii_um).size
    weights = solved.T[PLANAR]  # (3, 6S): planar body force per sphere velocity/spin
    columns = np.stack([3 * np.arange(n), 3 * np.arange(n) + 1, 3 * n + 3 * np.arange(n) + 2], axis=1)
    return np.moveaxis(weights[:, columns], 1, 0)  # (S, 3, 3)


def resistance_matrix(
    offsets_um, radii_um, viscosity_pa_s, *, wall_height_um=None, sphere_rotation: bool = True
) -> np.ndarray:
    """Planar resistance (3, 3) of a rigid sphere cluster with RPY hydrodynamic
    interaction between its spheres (method in the module docstring).

    offsets_um: (S, 2) sphere centres in the focal plane relative to the reference point
    (the origin), or (S, 3) for a 3-D cluster (e.g. a shell model). radii_um: (S,)
    positive; spheres may touch, overlap or lie inside one another.
    viscosity_pa_s: eta in Pa s = pN s/um^2.

    Returns R with [F_x, F_y, T_z] = R [U_x, U_y, Omega_z] about the origin: R[:2, :2]
    in pN s/um, R[2, 2] in pN um s, R[:2, 2] = R[2, :2] in pN s; symmetric positive
    definite. ``sphere_rotation=True`` (default): spheres carry forces and torques
    (full generalised RPY, a single sphere is exactly Stokes); ``False``: translational
    blobs only (Usabiaga et al.'s rigid multiblob), which needs at least two distinct
    centres for a rotational resistance.

    wall_height_um: not implemented (see the module docstring); raises
    NotImplementedError unless None. Bad input raises ValueError naming the parameter.
    """
    if wall_height_um is not None:
        raise NotImplementedError(
            "resistance_matrix: the near-wall (chip floor) correction of interacting spheres "
            "(Rotne-Prager-Blake, Swan & Brady 2007) is not implemented for unequal radii with "
            "rotations; call with wall_height_um=None (unbounded fluid). The free-draining model "
            "has a per-sphere Faxen factor: otgym.physics.mobility.faxen_parallel_factor."
        )
    full = resistance_6x6(offsets_um, radii_um, viscosity_pa_s, sphere_rotation=sphere_rotation)
    planar = full[np.ix_(PLANAR, PLANAR)]
    eigenvalues = np.linalg.eigvalsh(planar)
    if not eigenvalues[0] > 1e-10 * eigenvalues[-1]:
        raise ValueError(
            "radii_um/offsets_um: the planar resistance is singular (a single translational blob, "
            "or all blobs at one centre, has no rotational drag without sphere_rotation=True)"
        )
    return planar
