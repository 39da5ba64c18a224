"""The environment axis split over every local device.

A host with N accelerators (or a CPU with ``XLA_FLAGS=--xla_force_host_platform_device_count=N``)
steps a batch of E environments as N slices of E / N, one per device: the physics
constrains its batch-last arrays to a ``NamedSharding`` over a 1-D mesh of
``jax.local_devices()`` (axis ``"env"``) and XLA's partitioner splits the step, and what
the training and evaluation rollouts compute from it, along that axis. Nothing else
changes: the step has no sum over environments, and JAX's partitionable threefry PRNG
(``jax_threefry_partitionable``, the default) gives each element the same random value
however the draw is split. With one device, or a batch that does not divide evenly
over the devices, arrays are left as they are (one device: the same program as without
this module).
"""

from __future__ import annotations

import functools

import jax
import numpy as np
from jax.sharding import Mesh, NamedSharding, PartitionSpec

ENV_AXIS = "env"


@functools.cache
def environment_mesh() -> Mesh | None:
    """A 1-D mesh (axis ``"env"``) of this process's devices, None with one device."""
    devices = jax.local_devices()
    return Mesh(np.array(devices), (ENV_AXIS,)) if len(devices) > 1 else None


def shard_environments(array, axis: int):
    """``array`` constrained to be split along ``axis`` (its environment axis; negative
    counts from the end) over every local device; unchanged with one device or where
    the axis's length is not a multiple of the device count. Use inside ``jit``."""
    mesh = environment_mesh()
    if mesh is None or array.ndim == 0:
        return array
    axis = axis % array.ndim
    if array.shape[axis] % mesh.size:
        return array
    spec = PartitionSpec(*([None] * axis + [ENV_AXIS]))
    return jax.lax.with_sharding_constraint(array, NamedSharding(mesh, spec))


def shard_environment_tree(tree, axis: int):
    """``shard_environments`` on every array of a pytree."""
    return jax.tree.map(lambda array: shard_environments(array, axis), tree)
