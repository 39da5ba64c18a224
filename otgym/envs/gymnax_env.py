"""otgym's learning tasks as gymnax ``Environment``s, so the JAX RL libraries written
for gymnax (rejax, purejaxrl, gymnax's own wrappers) train on them unchanged:

    env, params = make("speed-control", preset="paper")
    obs, state = env.reset(key, params)
    obs, state, reward, done, info = env.step(key, state, action, params)

The task is any registered task (``otgym list tasks``) whose entry names its functional
module (extra ``functional``: ``make_params``, ``reset``, ``step``, as
``otgym.envs.speed_control``). ``step`` resets a finished episode in place, as gymnax
does; ``done`` is ``terminated or truncated`` (gymnax 0.0.x's five-tuple, which rejax
expects) and ``info`` carries both, with the task's own entries. An action outside
``0..n-1`` is clipped by the task (nothing can raise inside ``jit``).

Needs the extra ``[jax-rl]`` (gymnax below 1.0, whose ``step`` returns the five-tuple
rejax reads).
"""

from __future__ import annotations

import importlib

import jax.numpy as jnp
from flax import struct
from gymnax.environments import environment, spaces

from otgym import registry
from otgym.envs import transport as tr
from otgym.envs.presets import preset as load_preset
from otgym.envs.transport import TransportParams, TransportState


@struct.dataclass
class GymnaxParams:
    """gymnax's params: the task's own (a pytree) and the episode's step limit."""

    task: TransportParams
    max_steps_in_episode: int = struct.field(pytree_node=False)


class TaskEnvironment(environment.Environment):
    """Registered task ``task`` with preset ``preset`` as a gymnax environment
    (``task_params``: that preset's task params, when built already)."""

    def __init__(self, task: str = "speed-control", preset: str = "paper", task_params: TransportParams | None = None):
        found = registry.entry("tasks", task)
        module = found.extras.get("functional")
        if not module:
            raise ValueError(f"task {task!r} has no functional form (its registry entry names no 'functional' module)")
        importlib.import_module(module)  # fails here, not inside a trainer's jit
        self._module, self._task, self._preset = module, task, preset
        self._params: GymnaxParams | None = None
        if task_params is not None:  # built already (the scene and path plan of ``preset``)
            self._params = GymnaxParams(task_params, task_params.config.max_steps)

    @property
    def _functional(self):
        return importlib.import_module(self._module)  # by name: trainers deep-copy the environment

    @property
    def default_params(self) -> GymnaxParams:
        if self._params is None:  # the scene and the path plan, built once per environment
            config = load_preset(self._preset)
            self._params = GymnaxParams(self._functional.make_params(config), config.max_steps)
        return self._params

    def reset_env(self, key, params: GymnaxParams):
        return self._functional.reset(key, params.task)

    def step_env(self, key, state: TransportState, action, params: GymnaxParams):
        obs, state, reward, terminated, truncated, info = self._functional.step(key, state, action, params.task)
        info = {**info, "terminated": terminated, "truncated": truncated}
        return obs, state, reward, jnp.logical_or(terminated, truncated), info

    @property
    def name(self) -> str:
        return f"otgym/{self._task}/{self._preset}"

    @property
    def num_actions(self) -> int:
        return self.default_params.task.config.n_actions

    def action_space(self, params: GymnaxParams | None = None) -> spaces.Discrete:
        params = params or self.default_params
        return spaces.Discrete(params.task.config.n_actions)

    def observation_space(self, params: GymnaxParams | None = None) -> spaces.Box:
        return spaces.Box(-jnp.inf, jnp.inf, (tr.OBS_SIZE,), jnp.float32)


def make(task: str = "speed-control", preset: str = "paper") -> tuple[TaskEnvironment, GymnaxParams]:
    """gymnax's ``make``: the environment and its default params."""
    env = TaskEnvironment(task, preset)
    return env, env.default_params
