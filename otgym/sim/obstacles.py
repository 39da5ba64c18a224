"""Dynamic obstacles: debris drifting through the chip as a persistent random walk
carried by the flow (paper section II-B: "four randomly moving obstacles").

Obstacles are ordinary (dynamic) spheres of the physics core, so the flow carries
them, walls and robots push back on them, and they can never pass through a wall.
They are self-propelled: each control step of length T their propulsion velocity u
follows an Ornstein-Uhlenbeck process with speed scale s and persistence time tau,

    u <- u exp(-T/tau) + s sqrt(1 - exp(-2T/tau)) xi,

and is applied as the force gamma_t u (so on its own an obstacle moves at u plus the
local flow). Near a wall (distance < r + margin) a propulsion pointing into the wall
is reflected, u -= 2 (u.n) n, so the walk bounces instead of pressing on the wall.
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
    wall_margin_um: float = 1.0

    def __post_init__(self):
        require_non_negative("speed_um_s", self.speed_um_s)
        require_positive_scalar("persistence_s", self.persistence_s)
        require_non_negative("wall_margin_um", self.wall_margin_um)


def next_propulsion(key, xy_um, propulsion_um_s, radius_um, walls, motion: ObstacleMotion, period_s: float):
    """New propulsion velocities (K, 2) for obstacles at ``xy_um`` (K, 2)."""
    decay = jnp.exp(-period_s / motion.persistence_s)
    noise = jax.random.normal(key, propulsion_um_s.shape, propulsion_um_s.dtype)
    propulsion = propulsion_um_s * decay + motion.speed_um_s * jnp.sqrt(1 - decay**2) * noise
    distance, normal = walls.distance_and_normal(xy_um)
    inward = jnp.sum(propulsion * normal, axis=-1)
    bounce = (distance < radius_um + motion.wall_margin_um) & (inward < 0)
    return jnp.where(bounce[:, None], propulsion - 2 * inward[:, None] * normal, propulsion)
