"""Surface interactions between spheres of different bodies and with the chip walls.

Contact (non-penetration): a penalty force k * overlap along the line of centres.
The stiffness is tied to the step, k = kappa / (dt * (mu_a + mu_b)), with mu the
largest point mobility of each body, so one explicit step removes a fraction kappa
of any overlap: the scheme cannot blow up however hard bodies are pushed together,
and in steady contact the penalty force equals the force pushing the bodies
together, so the reported contact force (pN) is the physical constraint force of
overdamped dynamics. Same idea as the step-adapted repulsion of Brownian dynamics
codes (e.g. Heyes & Melrose, J. Non-Newtonian Fluid Mech. 46, 1, 1993). A pressed
pair settles at an overlap of the pressing force over k; ``otgym.physics.projection``
(opt-in, ``PhysicsConfig(contact_overlap_cap=...)``) caps it.

Van der Waals: the retarded Hamaker attraction of ``otgym.physics.adhesion`` (Hamaker
constant per material pair, Gregory's retardation, the surface gap clamped below at
the scene's minimum gap), sphere-wall with the sphere's radius, sphere-sphere with the
Derjaguin reduced radius a1 a2 / (a1 + a2).
"""

from __future__ import annotations

import jax.numpy as jnp

from otgym.physics.adhesion import vdw_force_pn

CONTACT_STEP_FRACTION = 0.5
"""kappa: fraction of an overlap removed per step (stable below 2 / number of contacts)."""


def sphere_pair_forces(dx, dy, radius_a, radius_b, contact_stiffness, hamaker_pn_um, min_gap_um, wavelength_um=jnp.inf):
    """Forces between sphere pairs, component-wise (arrays broadcast over pairs and
    environments). (dx, dy) is the vector from centre a to centre b.

    Returns (force_on_a_x, force_on_a_y, contact_on_b_x, contact_on_b_y, overlap_um):
    the total (contact + vdW) force on a (the force on b is its negative) and the
    contact part acting on b. Coincident centres get the normal (1, 0), never NaN.
    """
    distance = jnp.sqrt(dx**2 + dy**2)
    apart = distance > 1e-9
    inverse = jnp.where(apart, 1.0 / jnp.where(apart, distance, 1.0), 0.0)
    nx, ny = jnp.where(apart, dx * inverse, 1.0), dy * inverse
    gap = distance - radius_a - radius_b
    overlap = jnp.maximum(-gap, 0.0)
    contact = contact_stiffness * overlap
    reduced_radius = radius_a * radius_b / (radius_a + radius_b)
    vdw = vdw_force_pn(hamaker_pn_um, reduced_radius, gap, min_gap_um, wavelength_um)
    net = vdw - contact
    return net * nx, net * ny, contact * nx, contact * ny, overlap


def sphere_wall_forces(
    distance_um, normal_x, normal_y, radius, contact_stiffness, hamaker_pn_um, min_gap_um, wavelength_um=jnp.inf
):
    """Forces of the walls on spheres: (total_x, total_y, contact magnitude, overlap).
    The normal points from the wall into the fluid."""
    gap = distance_um - radius
    overlap = jnp.maximum(-gap, 0.0)
    contact = contact_stiffness * overlap
    vdw = vdw_force_pn(hamaker_pn_um, radius, gap, min_gap_um, wavelength_um)
    return (contact - vdw) * normal_x, (contact - vdw) * normal_y, contact, overlap
