"""The scripted baseline of ``orient``: a bang-bang controller on the observation's
angle error. It turns toward the target at the fastest speed while the error exceeds
``slow_within_deg``, at the slowest speed closer in, and holds once the error is within
half the goal's tolerance (half, so that Brownian jitter of the measured angle does not
push it back out). Pure and jittable: ``actions(obs, config)`` for a batch."""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from otgym.tasks.orient.core import OrientConfig

SLOW_WITHIN_DEG = 4.0


def actions(obs, config: OrientConfig, slow_within_deg: float = SLOW_WITHIN_DEG):
    """Integer actions (E,) for observations (E, 17)."""
    error = jnp.arctan2(obs[:, 0], obs[:, 1])
    size = jnp.abs(error)
    speeds = len(config.turn_speeds_deg_s)
    level = jnp.where(size > np.deg2rad(slow_within_deg), speeds, 1)
    level = jnp.where(size <= np.deg2rad(config.tolerance_deg) / 2, 0, level)
    return (config.hold_action + jnp.sign(error).astype(jnp.int32) * level).astype(jnp.int32)
