"""Task ``CellTransport``: the ``SpeedControl`` scene with continuous actions, a 2D
trap velocity (um/s) per robot, both traps of a robot moving together. For general
RL and for teleoperation. Progress is the cell's position projected on the path
segment; the goal is the cell within 0.5 um of the segment's end. Actions are
clipped to +-``max_robot_speed_um_s`` per axis and NaN maps to 0 here (no error can be
raised inside ``jit``); the Gymnasium adapter rejects both. Same observation and reward
terms as ``SpeedControl`` (``otgym.tasks.transport.core``), the speed term using the robots'
mean speed along the path.
"""

from __future__ import annotations

import jax.numpy as jnp

from otgym.planning import formation as fm
from otgym.tasks.transport import core as tr
from otgym.tasks.transport.core import TransportParams, TransportState
from otgym.tasks.transport.presets import TaskConfig, preset

GOAL_TOLERANCE_UM = 0.5
ROBOT_OF_TRAP = (0, 0, 1, 1)  # traps of robot a, then b (``scene.reset_at``)


def make_params(config: TaskConfig | str = "paper") -> TransportParams:
    return tr.make_params(preset(config) if isinstance(config, str) else config)


def reset_batch(key, params: TransportParams, n_envs: int):
    return tr.reset_batch(key, params, n_envs)


def _cell_arc(params: TransportParams, state: TransportState, scene_state):
    """Arc length of the path point nearest the cell, within the episode's segment."""
    path = params.path
    end = tr.segment_end(params, state)
    cell = scene_state.physics.pose[:, params.scene.payload, :2]  # (E, 2)
    distance = jnp.linalg.norm(path.points_um[None] - cell[:, None], axis=-1)  # (E, M)
    inside = (path.arc_um[None] >= state.start_arc_um[:, None]) & (path.arc_um[None] <= end[:, None])
    nearest = jnp.argmin(jnp.where(inside, distance, jnp.inf), axis=1)
    arc = path.arc_um[nearest]
    return jnp.where(arc >= end - GOAL_TOLERANCE_UM, end, arc)


def step_batch(key, state: TransportState, action, params: TransportParams):
    """Step E environments with robot velocities (E, 2, 2) in um/s."""
    limit = params.config.max_robot_speed_um_s
    robot_velocity = jnp.clip(jnp.nan_to_num(jnp.asarray(action, state.arc_um.dtype), nan=0.0), -limit, limit)
    velocity = robot_velocity[:, jnp.asarray(ROBOT_OF_TRAP)]
    heading = fm.heading_at(params.path, state.arc_um)
    tangent = jnp.stack([jnp.cos(heading), jnp.sin(heading)], axis=-1)
    speed = jnp.clip(jnp.sum(jnp.mean(robot_velocity, axis=1) * tangent, axis=-1), 0.0, None)
    return tr.advance_batch(
        key, params, state, velocity, lambda scene_state: _cell_arc(params, state, scene_state), speed
    )


reset, step = tr.single_environment(reset_batch, step_batch)
