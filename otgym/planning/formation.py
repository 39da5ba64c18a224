"""Carry a formation of traps along a planned path (pure JAX, jittable).

The traps that hold a payload (two robots pinching a cell, one robot, a bead) move as
one rigid formation: a centre on the path and a heading along the path's tangent.
Each control step the formation advances by ``speed * period`` of arc length; every
trap is commanded the constant velocity that brings it to its place in the advanced
formation within the step. This is the paper's "progressive" scheme: the planner
gives the path, a speed (constant, or chosen by a policy) gives the progress.
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
from flax import struct


@struct.dataclass
class DensePath:
    points_um: jnp.ndarray  # (M, 2)
    arc_um: jnp.ndarray  # (M,) cumulative arc length from the start

    @property
    def length_um(self):
        return self.arc_um[-1]


def dense_path(points_um, dtype=jnp.float32) -> DensePath:
    """A path from (M, 2) points in um (at least two distinct points)."""
    points = np.asarray(points_um, float)
    if points.ndim != 2 or points.shape[1] != 2 or len(points) < 2:
        raise ValueError(f"path must be an (M, 2) array of at least 2 points, got shape {points.shape}")
    if not np.all(np.isfinite(points)):
        raise ValueError("path must be finite")
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])
    if arc[-1] <= 0:
        raise ValueError("path has zero length")
    return DensePath(jnp.asarray(points, dtype), jnp.asarray(arc, dtype))


def point_at(path: DensePath, arc_um):
    s = jnp.clip(arc_um, 0.0, path.length_um)
    return jnp.stack(
        [jnp.interp(s, path.arc_um, path.points_um[:, 0]), jnp.interp(s, path.arc_um, path.points_um[:, 1])], axis=-1
    )


def heading_at(path: DensePath, arc_um, lookaround_um: float = 2.0):
    """Tangent angle (rad) from a central difference over +-``lookaround_um``."""
    ahead = point_at(path, arc_um + lookaround_um)
    behind = point_at(path, arc_um - lookaround_um)
    delta = ahead - behind
    return jnp.arctan2(delta[..., 1], delta[..., 0])


def _rotate(vectors, angle):
    cos, sin = jnp.cos(angle), jnp.sin(angle)
    return jnp.stack(
        [cos * vectors[..., 0] - sin * vectors[..., 1], sin * vectors[..., 0] + cos * vectors[..., 1]], axis=-1
    )


def formation_offsets(trap_xy_um, centre_um, heading_rad):
    """Trap positions (T, 2) expressed in the formation's frame."""
    return _rotate(trap_xy_um - centre_um, -heading_rad)


def formation_velocity(path: DensePath, offsets_um, trap_xy_um, next_arc_um, period_s: float):
    """Trap velocities (T, 2) that place the formation at ``next_arc_um`` along the
    path, facing along it, after ``period_s``."""
    centre = point_at(path, next_arc_um)
    heading = heading_at(path, next_arc_um)
    target = centre + _rotate(offsets_um, heading)
    return (target - trap_xy_um) / period_s
