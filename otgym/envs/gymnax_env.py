"""otgym's tasks as gymnax ``Environment``s, so the JAX RL libraries written for gymnax
(rejax, purejaxrl, gymnax's own wrappers) train on them unchanged:

    env, params = make("speed-control", preset="paper")
    obs, state = env.reset(key, params)
    obs, state, reward, done, info = env.step(key, state, action, params)

The task is any registered task (``otgym list tasks``, ``otgym.tasks.base.Task``).
``step`` resets a finished episode in place, as gymnax does; ``done`` is ``terminated
or truncated`` (gymnax 0.0.x's five-tuple, which rejax expects) and ``info`` carries
both, with the task's own entries. An action outside the task's space is clipped by
the task (nothing can raise inside ``jit``).

Needs the extra ``[jax-rl]`` (gymnax below 1.0, whose ``step`` returns the five-tuple
rejax reads).
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import jax.numpy as jnp
from flax import struct
from gymnax.environments import environment, spaces

from otgym import tasks


@struct.dataclass
class GymnaxParams:
    """gymnax's params: the task's own (a pytree) and the episode's step limit."""

    task: Any
    max_steps_in_episode: int = struct.field(pytree_node=False)


class TaskEnvironment(environment.Environment):
    """Registered task ``task`` with preset ``preset`` as a gymnax environment
    (``task_params``: that preset's task params, when built already)."""

    def __init__(self, task: str = "speed-control", preset: str | None = None, task_params: Any = None):
        self._task_name, self._preset = task, preset
        self._params: GymnaxParams | None = None
        if task_params is not None:
            self._params = GymnaxParams(task_params, self.task.max_steps(task_params))
        else:
            self.task.config(preset)  # an unknown preset fails here, not inside a trainer's jit

    @property
    def task(self) -> tasks.Task:
        return tasks.load(self._task_name)  # by name: trainers deep-copy the environment

    @property
    def default_params(self) -> GymnaxParams:
        if self._params is None:  # the task's host work (scene, path plan), once per environment
            task = self.task
            task_params = task.make_params(task.config(self._preset))
            self._params = GymnaxParams(task_params, task.max_steps(task_params))
        return self._params

    def reset_env(self, key, params: GymnaxParams):
        return self.task.reset(key, params.task)

    def step_env(self, key, state, action, params: GymnaxParams):
        obs, state, reward, terminated, truncated, info = self.task.step(key, state, action, params.task)
        info = {**info, "terminated": terminated, "truncated": truncated}
        return obs, state, reward, jnp.logical_or(terminated, truncated), info

    @property
    def name(self) -> str:
        return f"otgym/{self._task_name}/{self._preset or 'default'}"

    @property
    def num_actions(self) -> int:
        space = self.task.action_space(self.default_params.task)
        return int(space.n) if isinstance(space, gym.spaces.Discrete) else int(space.shape[-1])

    def action_space(self, params: GymnaxParams | None = None):
        params = params or self.default_params
        space = self.task.action_space(params.task)
        if isinstance(space, gym.spaces.Discrete):
            return spaces.Discrete(int(space.n))
        return spaces.Box(jnp.asarray(space.low), jnp.asarray(space.high), space.shape, jnp.float32)

    def observation_space(self, params: GymnaxParams | None = None) -> spaces.Box:
        params = params or self.default_params
        return spaces.Box(-jnp.inf, jnp.inf, (self.task.observation_size(params.task),), jnp.float32)


def make(task: str = "speed-control", preset: str | None = None) -> tuple[TaskEnvironment, GymnaxParams]:
    """gymnax's ``make``: the environment and its default params."""
    env = TaskEnvironment(task, preset)
    return env, env.default_params
