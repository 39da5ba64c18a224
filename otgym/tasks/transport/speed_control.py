"""Task ``SpeedControl`` (paper section II-C, III-B/C): the planner gives the path,
the agent gives the speed. Each control step the action picks one of the discrete
speed levels; the four traps advance as one rigid formation along the path by
speed x control period (``otgym.planning.formation``), the physics runs its sub-steps
in between. The episode ends at the segment's end (goal) or on a failure, and is
truncated after ``max_steps``. See ``otgym.tasks.transport.core`` for observation and reward.

Functional API (pure, jittable): ``reset(key, params) -> (obs, state)``,
``step(key, state, action, params) -> (obs, state, reward, terminated, truncated,
info)`` and the batched forms (leading axis E). Actions outside ``0..n-1`` are
clipped here (no error can be raised inside ``jit``); the Gymnasium adapter rejects them.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from otgym.planning import formation as fm
from otgym.tasks.transport import core as tr
from otgym.tasks.transport.core import TransportParams, TransportState
from otgym.tasks.transport.presets import TaskConfig, preset


def make_params(config: TaskConfig | str = "paper") -> TransportParams:
    return tr.make_params(preset(config) if isinstance(config, str) else config)


def reset_batch(key, params: TransportParams, n_envs: int):
    return tr.reset_batch(key, params, n_envs)


def step_batch(key, state: TransportState, action, params: TransportParams):
    """Step E environments with integer actions (E,)."""
    config = params.config
    period = config.scene.control_period_s
    levels = jnp.asarray(config.speed_levels_um_s, state.arc_um.dtype)
    speed = levels[jnp.clip(jnp.asarray(action, jnp.int32), 0, config.n_actions - 1)]
    next_arc = jnp.minimum(state.arc_um + speed * period, tr.segment_end(params, state))
    velocity = jax.vmap(lambda traps, arc: fm.formation_velocity(params.path, params.offsets_um, traps, arc, period))(
        state.scene.physics.trap_xy_um, next_arc
    )
    return tr.advance_batch(key, params, state, velocity, lambda _: next_arc, speed)


reset, step = tr.single_environment(reset_batch, step_batch)
