"""The route as the model-predictive navigator sees it (pure JAX unless noted): the
formation's pose as (arc along the route, lateral offset from it, rotation from its
heading), the traps' places at such a pose, the pose that fits observed traps, the
cell's progress, and the free room on each side of the route, from the chip's wall
distance (what the microscope shows of the chip).

The route's frame at arc s: its point, unit tangent t(s) (the heading by a central
difference over +-2 um, as the navigator's) and left normal n(s) = (-sin h, cos h).
A formation at (s, d, phi) has its centre at point(s) + d n(s) and faces h(s) + phi.
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
from flax import struct

from otgym.planning import formation as fm

PROJECTION_PASSES = 2
"""Projections on the tangent: each shrinks the arc error by lateral offset / radius of
curvature (a guess 1.5 um off, 5 um beside a 60 um bend: 0.12 um after one, 0.01 after two)."""


@struct.dataclass
class RouteData:
    """The route and the free room beside it (jnp), as the planner needs them."""

    path: fm.DensePath
    room_arc_um: jnp.ndarray  # (G,)
    room_left_um: jnp.ndarray  # (G,) room towards the route's left normal (-sin h, cos h)
    room_right_um: jnp.ndarray  # (G,) room towards the right normal


def lateral_room_um(
    route_um,
    route_arc_um,
    wall_distance_um,
    clearance_um: float,
    spacing_um: float = 1.0,
    reach_um: float = 40.0,
    resolution_um: float = 0.25,
):
    """Arc grid (G,) and the room (G,) on each side of the route: how far the
    formation's centre may move along the route's normal with its bounding circle
    ``clearance_um`` clear of the walls (numpy; ``wall_distance_um(points (n, 2)) -> (n,)``)."""
    route_um, route_arc_um = np.asarray(route_um, float), np.asarray(route_arc_um, float)
    arc = np.arange(0.0, route_arc_um[-1] + 1e-9, spacing_um)
    path = fm.dense_path(route_um)
    centre = np.asarray(fm.point_at(path, jnp.asarray(arc, jnp.float32)), float)
    heading = np.asarray(fm.heading_at(path, jnp.asarray(arc, jnp.float32)), float)
    normal = np.stack([-np.sin(heading), np.cos(heading)], axis=-1)
    offsets = np.arange(0.0, reach_um + 1e-9, resolution_um)
    rooms = []
    for side in (1.0, -1.0):
        points = centre[:, None] + side * offsets[None, :, None] * normal[:, None]
        free = np.asarray(wall_distance_um(points.reshape(-1, 2))).reshape(len(arc), len(offsets)) >= clearance_um
        blocked = ~free
        first_blocked = np.where(blocked.any(axis=1), blocked.argmax(axis=1), len(offsets))
        rooms.append(np.where(first_blocked > 0, offsets[np.maximum(first_blocked - 1, 0)], 0.0))
    return arc, rooms[0], rooms[1]


def route_data(route_um, route_arc_um, wall_distance_um, clearance_um: float) -> RouteData:
    arc, left, right = lateral_room_um(route_um, route_arc_um, wall_distance_um, clearance_um)
    f32 = lambda a: jnp.asarray(a, jnp.float32)  # noqa: E731
    return RouteData(fm.dense_path(route_um), f32(arc), f32(left), f32(right))


def _rotate(vectors, angle):
    cos, sin = jnp.cos(angle)[..., None], jnp.sin(angle)[..., None]
    return jnp.stack(
        [cos * vectors[..., 0] - sin * vectors[..., 1], sin * vectors[..., 0] + cos * vectors[..., 1]], axis=-1
    )


def route_frame(route: RouteData, arc_um):
    """Point (..., 2), unit tangent (..., 2) and left normal (..., 2) at ``arc_um``."""
    heading = fm.heading_at(route.path, arc_um)
    tangent = jnp.stack([jnp.cos(heading), jnp.sin(heading)], axis=-1)
    normal = jnp.stack([-jnp.sin(heading), jnp.cos(heading)], axis=-1)
    return fm.point_at(route.path, arc_um), tangent, normal, heading


def clip_lateral(route: RouteData, arc_um, lateral_um):
    left = jnp.interp(arc_um, route.room_arc_um, route.room_left_um)
    right = jnp.interp(arc_um, route.room_arc_um, route.room_right_um)
    return jnp.clip(lateral_um, -right, left)


def formation_places(route: RouteData, offsets_um, arc_um, lateral_um, rotation_rad):
    """Trap places (..., T, 2) of the formation at arc, lateral offset and rotation (...)."""
    point, _, normal, heading = route_frame(route, arc_um)
    centre = point + lateral_um[..., None] * normal
    return centre[..., None, :] + _rotate(jnp.asarray(offsets_um, point.dtype), heading + rotation_rad)


def formation_pose(route: RouteData, offsets_um, trap_xy_um, arc_guess_um):
    """(arc, lateral, rotation) (...,) of the formation that best fits traps (..., T, 2):
    its centre projected on the route from ``arc_guess_um`` and its rotation by a 2D
    Procrustes fit of the traps about their centre to the formation's offsets."""
    centre = jnp.mean(trap_xy_um, axis=-2)
    arc = arc_guess_um
    for _ in range(PROJECTION_PASSES):
        point, tangent, _, _ = route_frame(route, arc)
        arc = jnp.clip(arc + jnp.sum((centre - point) * tangent, axis=-1), 0.0, route.path.length_um)
    point, tangent, normal, heading = route_frame(route, arc)
    lateral = jnp.sum((centre - point) * normal, axis=-1)
    relative = trap_xy_um - centre[..., None, :]
    offsets = jnp.asarray(offsets_um, relative.dtype)
    cross = jnp.sum(offsets[..., 0] * relative[..., 1] - offsets[..., 1] * relative[..., 0], axis=-1)
    dot = jnp.sum(offsets[..., 0] * relative[..., 0] + offsets[..., 1] * relative[..., 1], axis=-1)
    rotation = jnp.arctan2(cross, dot) - heading
    return arc, lateral, jnp.arctan2(jnp.sin(rotation), jnp.cos(rotation))


def cell_arc_um(route: RouteData, cell_xy_um, arc_guess_um):
    """The cell's progress along the route: its projection on the tangent at the guess."""
    point, tangent, _, _ = route_frame(route, arc_guess_um)
    return jnp.clip(arc_guess_um + jnp.sum((cell_xy_um - point) * tangent, axis=-1), 0.0, route.path.length_um)
