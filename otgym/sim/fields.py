"""JAX samplers of a chip's cached fields, plugging into the physics core's hooks
(``otgym.physics.fields``): ``GridFlow.velocity_um_s`` / ``vorticity_per_s`` and
``GridWalls.distance_and_normal``. Both are ``flax.struct.dataclass`` pytrees with
float32 grids and bilinear interpolation written in plain jax.numpy: jittable and
vmappable, no NaN anywhere.

* ``GridFlow`` holds the focal-plane (mid-height) velocity and its vorticity on the
  pixel corners (x = col * dx, y = row * dx). Outside the image the fluid is solid:
  zero velocity.
* ``GridWalls`` holds the signed wall distance and the unit normals on the pixel
  centres (x = (col + 0.5) dx). Outside the grid a point takes the value at the
  nearest grid point minus its distance to it, so it is negative (solid) everywhere
  outside the image and continuous at the border; its normal points back in.
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
from flax import struct

from otgym.sim.cache import ChipFields
from otgym.sim.cache import chip_fields as cached_chip_fields
from otgym.sim.chip import Chip


def _bilinear(grid, index_xy):
    """Interpolate ``grid`` (R, C, K) at fractional (col, row) indices (..., 2),
    clamped to the grid; returns (..., K). The four corners are gathered from the
    flattened grid with one flat index each (cheaper on CPU than 2-D gathers)."""
    rows, cols = grid.shape[0], grid.shape[1]
    col = jnp.clip(index_xy[..., 0], 0.0, cols - 1.0)
    row = jnp.clip(index_xy[..., 1], 0.0, rows - 1.0)
    c0 = jnp.clip(jnp.floor(col).astype(jnp.int32), 0, cols - 2)
    r0 = jnp.clip(jnp.floor(row).astype(jnp.int32), 0, rows - 2)
    tc = (col - c0)[..., None]
    tr = (row - r0)[..., None]
    flat = grid.reshape(rows * cols, grid.shape[2])
    corner = r0 * cols + c0
    top = flat[corner] * (1 - tc) + flat[corner + 1] * tc
    bottom = flat[corner + cols] * (1 - tc) + flat[corner + cols + 1] * tc
    return top * (1 - tr) + bottom * tr


@struct.dataclass
class GridFlow:
    """Focal-plane flow on the pixel corners, packed as (H+1, W+1, 3): velocity
    (um/s, 2 channels) and vorticity (1/s), so one interpolation serves both."""

    packed: jnp.ndarray
    pixel_size_um: float = struct.field(pytree_node=False)

    @classmethod
    def from_arrays(cls, velocity, vorticity, pixel_size_um: float) -> GridFlow:
        return cls(jnp.concatenate([velocity, vorticity[..., None]], axis=-1), pixel_size_um)

    @property
    def velocity(self):
        return self.packed[..., :2]

    @property
    def vorticity(self):
        return self.packed[..., 2]

    def scaled(self, factor: float) -> GridFlow:
        """The same flow with every rate multiplied by ``factor`` (creeping flow is linear)."""
        return self.replace(packed=self.packed * factor)

    def _sample(self, xy_um):
        rows, cols = self.packed.shape[:2]
        size = jnp.array([cols - 1, rows - 1], xy_um.dtype) * self.pixel_size_um
        inside = jnp.all((xy_um >= 0) & (xy_um <= size), axis=-1)
        sample = _bilinear(self.packed, xy_um / self.pixel_size_um).astype(xy_um.dtype)
        return jnp.where(inside[..., None], sample, 0.0)

    def velocity_um_s(self, xy_um):
        return self._sample(xy_um)[..., :2]

    def vorticity_per_s(self, xy_um):
        return self._sample(xy_um)[..., 2]


@struct.dataclass
class GridWalls:
    """Signed wall distance (um) and unit normals on the pixel centres, packed as
    (H, W, 3): distance, normal x, normal y."""

    packed: jnp.ndarray
    pixel_size_um: float = struct.field(pytree_node=False)

    @classmethod
    def from_arrays(cls, distance, normal, pixel_size_um: float) -> GridWalls:
        return cls(jnp.concatenate([distance[..., None], normal], axis=-1), pixel_size_um)

    @property
    def distance(self):
        return self.packed[..., 0]

    @property
    def normal(self):
        return self.packed[..., 1:]

    def distance_and_normal(self, xy_um):
        rows, cols = self.packed.shape[:2]
        half = 0.5 * self.pixel_size_um
        high = jnp.array([cols, rows], xy_um.dtype) * self.pixel_size_um - half
        clamped = jnp.clip(xy_um, half, high)
        offset = clamped - xy_um
        outside = jnp.sqrt(jnp.sum(offset**2, axis=-1))
        sample = _bilinear(self.packed, clamped / self.pixel_size_um - 0.5).astype(xy_um.dtype)
        distance = sample[..., 0] - outside
        normal = jnp.where((outside > 0)[..., None], offset / jnp.maximum(outside, 1e-12)[..., None], sample[..., 1:])
        norm = jnp.sqrt(jnp.sum(normal**2, axis=-1, keepdims=True))
        fallback = jnp.zeros_like(normal).at[..., 0].set(1.0)
        normal = jnp.where(norm > 1e-6, normal / jnp.maximum(norm, 1e-6), fallback)
        return distance, normal


def fields_from(fields: ChipFields, fluid: np.ndarray, dtype=jnp.float32) -> tuple[GridFlow, GridWalls]:
    """Wrap derived numpy fields as JAX samplers; the flow is scaled from the depth
    average to the focal plane (mid-height) by ``fields.mid_height_factor``."""
    factor = fields.mid_height_factor

    def device(x):  # rounded to dtype on the host: no conversion program compiled per field
        return jnp.asarray(np.asarray(x).astype(dtype))

    flow = GridFlow.from_arrays(
        device(factor * fields.flow.node_velocity_um_s(fluid)),
        device(factor * fields.flow.node_vorticity_per_s(fluid)),
        fields.flow.pixel_size_um,
    )
    walls = GridWalls.from_arrays(device(fields.distance_um), device(fields.normal), fields.flow.pixel_size_um)
    return flow, walls


def chip_fields(chip: Chip, dtype=jnp.float32) -> tuple[GridFlow, GridWalls]:
    """The JAX flow and walls of ``chip`` (derived fields from the disk cache)."""
    return fields_from(cached_chip_fields(chip), chip.fluid, dtype)
