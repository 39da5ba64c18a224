"""Hooks through which the environment (a chip) acts on the physics: an external
flow-velocity field and the side walls.

Both are pytrees (flax struct dataclasses) with methods, so they can be passed into
jitted functions; their Python class is part of the pytree structure, so the method
called is fixed at trace time. A higher layer (``otgym.sim``) supplies grid-based
implementations with the same methods:

* flow: ``velocity_um_s(xy_um (..., 2)) -> (..., 2)`` and
  ``vorticity_per_s(xy_um (..., 2)) -> (...)`` (dv_y/dx - dv_x/dy);
* walls: ``distance_and_normal(xy_um (..., 2)) -> (distance_um (...), normal (..., 2))``
  where ``distance_um`` is the signed distance to the nearest wall (positive in the
  fluid) and ``normal`` the unit vector pointing from the wall into the fluid.

The defaults here are a uniform flow and an unbounded fluid (no side walls).
"""

from __future__ import annotations

import jax.numpy as jnp
from flax import struct

FAR_FROM_WALLS_UM = 1.0e6
"""Distance reported where there are no walls (finite, so forces stay finite)."""


@struct.dataclass
class UniformFlow:
    """A spatially uniform flow (zero by default)."""

    velocity: jnp.ndarray = struct.field(default_factory=lambda: jnp.zeros(2))

    def velocity_um_s(self, xy_um):
        return jnp.broadcast_to(self.velocity.astype(xy_um.dtype), xy_um.shape)

    def vorticity_per_s(self, xy_um):
        return jnp.zeros(xy_um.shape[:-1], xy_um.dtype)


@struct.dataclass
class NoWalls:
    """An unbounded fluid: every point is far from any wall."""

    def distance_and_normal(self, xy_um):
        distance = jnp.full(xy_um.shape[:-1], FAR_FROM_WALLS_UM, xy_um.dtype)
        normal = jnp.zeros_like(xy_um).at[..., 0].set(1.0)
        return distance, normal
