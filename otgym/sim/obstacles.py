"""Dynamic obstacles: debris drifting through the chip as a persistent random walk
carried by the flow, never through a wall (paper section II-B: "four randomly moving
obstacles").

Model, per control step of length T for each obstacle at x with radius r:

    u <- u exp(-T/tau) + s sqrt(1 - exp(-2T/tau)) xi       (Ornstein-Uhlenbeck drift,
                                                          speed scale s, persistence tau)
    v  = c * flow(x) + u

then, with d and n the wall distance and inward normal at the predicted position
x + v T: if d < r + margin and v points into the wall (v.n < 0), the normal part of v
is removed and u is reflected (u -= 2 (u.n) n), so the walk bounces off walls; if the
predicted position is still too close, the obstacle waits this step. Obstacles are
kinematic bodies: they push robots and cells, nothing pushes them.
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp

from otgym.physics.validation import require_non_negative, require_positive_scalar


@dataclasses.dataclass(frozen=True)
class ObstacleMotion:
    speed_um_s: float = 2.0
    persistence_s: float = 3.0
    flow_coupling: float = 1.0
    wall_margin_um: float = 0.5

    def __post_init__(self):
        require_non_negative("speed_um_s", self.speed_um_s)
        require_positive_scalar("persistence_s", self.persistence_s)
        require_non_negative("flow_coupling", self.flow_coupling)
        require_non_negative("wall_margin_um", self.wall_margin_um)


def obstacle_velocities(key, xy_um, drift_um_s, radius_um, flow, walls, motion: ObstacleMotion,
                        period_s: float):
    """New drift (K, 2) and the velocity (K, 2) each obstacle keeps for the next
    ``period_s`` (model in the module docstring)."""
    decay = jnp.exp(-period_s / motion.persistence_s)
    kick = motion.speed_um_s * jnp.sqrt(1 - decay**2) * jax.random.normal(key, drift_um_s.shape, drift_um_s.dtype)
    drift = drift_um_s * decay + kick
    velocity = motion.flow_coupling * flow.velocity_um_s(xy_um) + drift
    clearance = radius_um + motion.wall_margin_um
    distance, normal = walls.distance_and_normal(xy_um + velocity * period_s)
    into_wall = jnp.sum(velocity * normal, axis=-1)
    blocked = (distance < clearance) & (into_wall < 0)
    velocity = jnp.where(blocked[:, None], velocity - into_wall[:, None] * normal, velocity)
    drift_normal = jnp.sum(drift * normal, axis=-1)
    drift = jnp.where((blocked & (drift_normal < 0))[:, None], drift - 2 * drift_normal[:, None] * normal, drift)
    distance_after, _ = walls.distance_and_normal(xy_um + velocity * period_s)
    here, _ = walls.distance_and_normal(xy_um)
    unsafe = (distance_after < clearance) & (distance_after < here)
    return drift, jnp.where(unsafe[:, None], 0.0, velocity)
