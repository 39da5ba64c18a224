"""What the learned speed policy sees, written once for both array modules (``xp``:
``numpy`` in the real-time navigator ``otgym.autonomy.rl_navigator``, float64;
``jax.numpy`` in the jittable ``interactive-speed`` task it is trained on,
``otgym.tasks.transport.interactive_speed``).

``speed_features`` gives ``N_FEATURES`` numbers per environment, all in the route's
frame so that they do not depend on where on the chip the route runs:

* per obstacle (the ``K_OBSTACLES`` nearest by their gap to the assembly; missing ones
  padded as far away): where it is along the route relative to the cell (its nearest
  route point's arc minus the cell's, / 50 um), how far it is off the route (/ 20 um),
  how fast it closes on the route (its velocity across the route towards it, / 2 um/s,
  from a 1 s least-squares fit of what the camera showed, ``tracked_velocity_um_s``),
  its gap to the assembly (/ 20 um), each clipped to [-2, 2], and whether it has never
  yet been seen moving (1: it may still cross; one that moved and stopped has crossed:
  the scenarios' obstacles wait beside the route, cross once and park);
* the speed now (/ 8 um/s), the share of the route left, the traps' margin (the largest
  handle-to-trap distance over the trap law's escape distance: 1 is a trap lost) and
  whether the formation carries the cell.

``tracked_velocity_um_s`` is the obstacle tracker's fit (``otgym.autonomy.obstacle_prediction``):
the ordinary least-squares slope of position against time over a ring buffer of the
last ``window_s`` of observations, per axis.
"""

from __future__ import annotations

import numpy as np

SPEEDS_UM_S = (0.0, 2.0, 3.5, 5.0, 6.5, 8.0)
"""The cruise speeds the policy chooses from, um/s (5: the route navigator's constant
cruise; 8: a person's hurried pace)."""
DECISION_S = 0.5
"""How often the policy chooses a speed, s (an obstacle at 2 um/s moves 1 um meanwhile)."""
K_OBSTACLES = 4
"""Obstacles the policy sees (the task's scenarios have four)."""
PER_OBSTACLE = 5
N_GLOBAL = 4
N_FEATURES = K_OBSTACLES * PER_OBSTACLE + N_GLOBAL
ALONG_SCALE_UM = 50.0
ACROSS_SCALE_UM = 20.0
CLOSING_SCALE_UM_S = 2.0
GAP_SCALE_UM = 20.0
SPEED_SCALE_UM_S = 8.0
FEATURE_CLIP = 2.0
TRACKER_WINDOW_S = 1.0
FAR_OBSTACLE = (FEATURE_CLIP, FEATURE_CLIP, 0.0, FEATURE_CLIP, 0.0)
"""The features of an obstacle that is not there: far ahead, far off the route, still."""
MOVING_SPEED_UM_S = 1.0
"""An obstacle whose fitted speed exceeds this has been seen moving (the fit's noise is
about 0.44 um/s per axis for a free obstacle over 1 s; tracked ones wander less)."""


def _float(xp):
    return float if xp is np else xp.float32


def route_tangents(route_um, xp=np):
    """Unit tangents (M, 2) of a dense route (M, 2), by central differences."""
    tangent = xp.gradient(xp.asarray(route_um, _float(xp)), axis=0)
    return tangent / xp.maximum(xp.linalg.norm(tangent, axis=1, keepdims=True), 1e-12)


def tracked_velocity_um_s(times_s, xy_um, count, xp=np):
    """Least-squares velocity (E, K, 2) from a ring buffer of times (E, W) s and
    positions (E, W, K, 2) um of which the first ``min(count, W)`` slots (E,) hold
    data; zero with fewer than two observations."""
    capacity = times_s.shape[1]
    filled = xp.minimum(count, capacity)
    valid = xp.arange(capacity)[None] < filled[:, None]  # (E, W): ring slots holding data
    weight = valid.astype(_float(xp))
    n = xp.maximum(weight.sum(axis=1), 1.0)
    t_mean = (times_s * weight).sum(axis=1) / n
    dt = (times_s - t_mean[:, None]) * weight  # (E, W)
    xy_mean = (xy_um * weight[:, :, None, None]).sum(axis=1) / n[:, None, None]
    covariance = (dt[:, :, None, None] * (xy_um - xy_mean[:, None])).sum(axis=1)
    variance = (dt**2).sum(axis=1)
    enough = (filled >= 2) & (variance > 0)
    return xp.where(enough[:, None, None], covariance / xp.where(enough, variance, 1.0)[:, None, None], 0.0)


def speed_features(
    route_um,
    route_arc_um,
    tangents,
    cell_arc_um,
    obstacle_xy_um,
    obstacle_velocity_um_s,
    obstacle_gap_um,
    obstacle_idle,
    speed_um_s,
    trap_margin,
    carrying,
    xp=np,
):
    """Features (E, ``N_FEATURES``) float32 (module docstring). Obstacles (E, K, 2) are
    placed on the route by their nearest route point; ``obstacle_idle`` (E, K) is 1 for
    one never seen moving; ``speed_um_s``, ``trap_margin`` and ``carrying`` are (E,)."""
    ftype = _float(xp)
    route_um = xp.asarray(route_um, ftype)
    xy = xp.asarray(obstacle_xy_um, ftype)
    n_env, n_obstacles = xy.shape[:2]
    if n_obstacles:
        nearest = xp.argmin(xp.sum((xy[:, :, None] - route_um[None, None]) ** 2, axis=-1), axis=-1)  # (E, K)
        tangent = tangents[nearest]
        offset = xy - route_um[nearest]
        across = tangent[..., 0] * offset[..., 1] - tangent[..., 1] * offset[..., 0]
        velocity = xp.asarray(obstacle_velocity_um_s, ftype)
        across_velocity = tangent[..., 0] * velocity[..., 1] - tangent[..., 1] * velocity[..., 0]
        per_obstacle = xp.stack(
            [
                (route_arc_um[nearest] - xp.asarray(cell_arc_um, ftype)[:, None]) / ALONG_SCALE_UM,
                xp.abs(across) / ACROSS_SCALE_UM,
                -xp.sign(across) * across_velocity / CLOSING_SCALE_UM_S,
                xp.asarray(obstacle_gap_um, ftype) / GAP_SCALE_UM,
                xp.asarray(obstacle_idle, ftype),
            ],
            axis=-1,
        )
        order = xp.argsort(xp.asarray(obstacle_gap_um, ftype), axis=1, stable=True)[:, :K_OBSTACLES]
        per_obstacle = xp.take_along_axis(per_obstacle, order[..., None], axis=1)
    else:
        per_obstacle = xp.zeros((n_env, 0, PER_OBSTACLE))
    padding = xp.broadcast_to(
        xp.asarray(FAR_OBSTACLE, ftype), (n_env, K_OBSTACLES - per_obstacle.shape[1], PER_OBSTACLE)
    )
    obstacles = xp.clip(xp.concatenate([per_obstacle, padding], axis=1), -FEATURE_CLIP, FEATURE_CLIP)
    length = route_arc_um[-1] if xp is not np else float(route_arc_um[-1])
    general = xp.stack(
        [
            xp.asarray(speed_um_s, ftype) / SPEED_SCALE_UM_S,
            (length - xp.asarray(cell_arc_um, ftype)) / length,
            xp.asarray(trap_margin, ftype),
            xp.asarray(carrying, ftype),
        ],
        axis=-1,
    )
    return xp.concatenate(
        [obstacles.reshape(n_env, -1), xp.clip(general, -FEATURE_CLIP, FEATURE_CLIP)], axis=-1
    ).astype(np.float32)
