"""Optional overlap projection: after each Euler-Maruyama step, bodies are moved
apart so that no sphere overlaps another (or a wall) by more than a cap.

The penalty contact of ``otgym.physics.interactions`` lets a pair overlap by the force
pressing it divided by its stiffness, about two steps' worth of the free motion that
force would cause: with stiff traps pressing on a small bead that can be a third of
its radius. With ``PhysicsConfig(contact_overlap_cap=c)`` each step is followed by a
projection onto the set of poses whose overlaps are at most c times the smaller
radius of each pair (c times the radius at a wall): the position-level, "potential-
free" treatment of hard contacts in Brownian dynamics (Heyes & Melrose, J.
Non-Newtonian Fluid Mech. 46, 1, 1993; Strating, Phys. Rev. E 59, 2175, 1999),
applied to rigid bodies through their mobilities, so the correction is the
displacement a constraint force would cause in overdamped motion.

The gaps are linearised about the step's start (normals and lever arms held; a
sphere moves by its body's translation plus the rotation times its lever arm), and
the constraint is solved by Jacobi iterations: each iteration gives every violating
contact the force that would remove its violation alone (its violation over the
point mobility of its two spheres along its normal, times dt), divides it by the
larger number of violating contacts on either of its two bodies (averaged Jacobi, so
a body pressed from several sides is not over-corrected), and moves the bodies by
their mobility times the summed forces. A lone contact is resolved in one iteration;
contacts sharing bodies converge geometrically. The forces are added to the step's
reported contact forces.

The iterations stop as soon as no overlap exceeds its cap by more than 1 % of the cap
(one iteration, which finds nothing to do, in a step where nothing presses that
deep), at most ``PhysicsConfig.contact_projection_iterations``. The default (no cap)
leaves the penalty alone: this is opt-in, and it costs one more evaluation of every
pair's geometry and the iterations each step (benchmarks/contact_projection.py).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from otgym.physics.fields import NoWalls
from otgym.physics.model import Model, turn_to_body, turn_to_lab

CONVERGED_FRACTION = 0.01
"""The iterations stop once no overlap exceeds its cap by more than this fraction of
the cap (or after ``PhysicsConfig.contact_projection_iterations``)."""


def _point_mobility_along(model: Model, sphere_turn, lever_x, lever_y, normal_x, normal_y, body):
    """Displacement per unit force per unit time (um / (pN s)) of each sphere along a
    unit normal when that force acts on it along the same normal: the body's
    translational mobility (turned with it) plus its rotational mobility times the
    lever arm's moment about the centre, squared."""
    mobility = model.body_translational_mobility[body][..., None]  # (N, 2, 2, 1) body frame
    nb_x, nb_y = turn_to_body(sphere_turn, normal_x, normal_y)
    translational = nb_x * (mobility[:, 0, 0] * nb_x + mobility[:, 0, 1] * nb_y) + nb_y * (
        mobility[:, 1, 0] * nb_x + mobility[:, 1, 1] * nb_y
    )
    moment = lever_x * normal_y - lever_y * normal_x
    return translational + model.body_rotational_mobility[body][:, None] * moment**2


def project_overlaps(model: Model, start, turn, moved, fields):
    """Correct one step's end poses ``moved`` (px, py, theta; each (B, E)) taken from
    ``start`` so that no overlap exceeds its cap (to the linearisation and the
    iterations). ``turn``: (cos, sin) of the start's angles (B, E), which the integrator
    carries. ``fields``: the integrator's sampled fields (walls carried to the start's
    sphere centres to first order, as its forces do).

    Returns (px, py, theta, pair force on b (x, y), (P, E) each, wall force (N, E))."""
    px0, py0, theta0 = start
    body = np.asarray(model.sphere_body, dtype=int)
    cos, sin = turn[0][body], turn[1][body]
    ox, oy = model.sphere_offset_um[:, 0:1], model.sphere_offset_um[:, 1:2]
    lever_x, lever_y = cos * ox - sin * oy, sin * ox + cos * oy
    x, y = px0[body] + lever_x, py0[body] + lever_y
    sphere_turn = cos, sin
    radius = model.sphere_radius_um[:, None]
    a, b = np.asarray(model.pair_a, dtype=int), np.asarray(model.pair_b, dtype=int)
    dx, dy = x[b] - x[a], y[b] - y[a]
    distance = jnp.sqrt(dx**2 + dy**2)
    apart = distance > 1e-9
    inverse = jnp.where(apart, 1.0 / jnp.where(apart, distance, 1.0), 0.0)
    nx, ny = jnp.where(apart, dx * inverse, 1.0), dy * inverse
    pair_gap = distance - radius[a] - radius[b]
    along_a = _point_mobility_along(model, (cos[a], sin[a]), lever_x[a], lever_y[a], nx, ny, body[a])
    along_b = _point_mobility_along(model, (cos[b], sin[b]), lever_x[b], lever_y[b], nx, ny, body[b])
    pair_weight = (along_a + along_b) * model.dt_s
    pair_cap = model.pair_overlap_cap_um[:, None]
    has_walls = not isinstance(model.walls, NoWalls)
    if has_walls:
        distance0, wall_nx, wall_ny, x0, y0 = fields[3:]
        wall_gap = distance0 + wall_nx * (x - x0) + wall_ny * (y - y0) - radius
        wall_weight = _point_mobility_along(model, sphere_turn, lever_x, lever_y, wall_nx, wall_ny, body) * model.dt_s
        wall_cap = model.wall_overlap_cap_um[:, None]
        dynamic = (model.wall_stiffness_pn_per_um > 0)[:, None]
    to_body = model.body_of_sphere.T
    incidence_abs = jnp.abs(model.pair_incidence)
    mobility = model.body_translational_mobility[:, :, :, None]
    rotational = model.body_rotational_mobility[:, None]

    def gaps(dpx, dpy, dth):
        sx, sy = dpx[body] - dth[body] * lever_y, dpy[body] + dth[body] * lever_x
        pair = pair_gap + nx * (sx[b] - sx[a]) + ny * (sy[b] - sy[a])
        wall = wall_gap + wall_nx * sx + wall_ny * sy if has_walls else None
        return pair, wall

    def iteration(carry):
        count_done, dpx, dpy, dth, pair_force, wall_force, _ = carry
        pair, wall = gaps(dpx, dpy, dth)
        pair_violation = jnp.maximum(-pair_cap - pair, 0.0)
        violating = (pair_violation > 0).astype(pair.dtype)
        count = incidence_abs @ violating  # (N, E) violating pairs at each sphere
        worst = jnp.max(pair_violation / pair_cap)
        if has_walls:
            wall_violation = jnp.where(dynamic, jnp.maximum(-wall_cap - wall, 0.0), 0.0)
            count = count + (wall_violation > 0)
            worst = jnp.maximum(worst, jnp.max(wall_violation / wall_cap))
        per_body = jnp.maximum(to_body @ count, 1.0)  # (B, E)
        share = jnp.maximum(per_body[body[a]], per_body[body[b]])
        push = pair_violation / jnp.maximum(pair_weight, 1e-30) / share  # pN, on b along +n
        fx = model.pair_incidence @ (-push * nx)
        fy = model.pair_incidence @ (-push * ny)
        if has_walls:
            wall_push = wall_violation / jnp.maximum(wall_weight, 1e-30) / per_body[body]
            fx, fy = fx + wall_push * wall_nx, fy + wall_push * wall_ny
            wall_force = wall_force + wall_push
        gx, gy, gt = to_body @ fx, to_body @ fy, to_body @ (lever_x * fy - lever_y * fx)
        body_gx, body_gy = turn_to_body(turn, gx, gy)
        step_x = (mobility[:, 0, 0] * body_gx + mobility[:, 0, 1] * body_gy) * model.dt_s
        step_y = (mobility[:, 1, 0] * body_gx + mobility[:, 1, 1] * body_gy) * model.dt_s
        step_x, step_y = turn_to_lab(turn, step_x, step_y)
        return (
            count_done + 1,
            dpx + step_x,
            dpy + step_y,
            dth + rotational * gt * model.dt_s,
            pair_force + push,
            wall_force,
            worst,
        )

    def unfinished(carry):  # iterate while some overlap exceeds its cap by more than 1 % of it
        return (carry[0] < model.projection_iterations) & (carry[-1] > CONVERGED_FRACTION)

    px1, py1, theta1 = moved
    zeros_pairs = jnp.zeros_like(pair_gap)
    zeros_walls = jnp.zeros_like(x)
    carry = (0, px1 - px0, py1 - py0, theta1 - theta0, zeros_pairs, zeros_walls, jnp.array(jnp.inf, x.dtype))
    _, dpx, dpy, dth, pair_force, wall_force, _ = jax.lax.while_loop(unfinished, iteration, carry)
    return px0 + dpx, py0 + dpy, theta0 + dth, pair_force * nx, pair_force * ny, wall_force
