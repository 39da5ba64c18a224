"""The Gymnasium environment of any registered task (``otgym.tasks``), numpy at the
edges: float32 observations, python float rewards and bool flags, ``render_mode``
"rgb_array" (the task's frame) or "human" (the same frame in a matplotlib window).
Invalid actions raise ValueError (``Task.check_action``).

``import otgym`` registers every task that has a Gymnasium id as
``gymnasium.make(ID, preset=...)``; ``TaskEnv(task=NAME, preset=...)`` makes any
registered task directly. The params and the jitted reset/step of each (task, preset)
pair are built once per process and shared by every instance.
"""

from __future__ import annotations

import functools

import gymnasium as gym
import jax
import numpy as np

from otgym import tasks
from otgym.tasks.base import Task


@functools.cache
def compiled(task_name: str, preset_name: str | None):
    """(task, params, jitted reset, jitted step) of a (task, preset) pair."""
    task = tasks.load(task_name)
    params = task.make_params(task.config(preset_name))
    return task, params, jax.jit(task.reset), jax.jit(task.step)


def _host_info(info: dict) -> dict:
    return {name: (np.asarray(value) if np.ndim(value) else np.asarray(value).item()) for name, value in info.items()}


class TaskEnv(gym.Env):
    """Registered task ``task`` with preset ``preset`` (None: the task's default)."""

    metadata = {"render_modes": ["rgb_array", "human"], "render_fps": 5}

    def __init__(self, task: str = "speed-control", preset: str | None = None, render_mode: str | None = None):
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be one of {self.metadata['render_modes']} or None, got {render_mode!r}")
        self.task: Task
        self.task, self.params, self._reset, self._step = compiled(task, preset)
        self.render_mode = render_mode
        self.observation_space = self.task.observation_space(self.params)
        self.action_space = self.task.action_space(self.params)
        self._state = None
        self._key = None
        self._figure = None

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        self._key = jax.random.PRNGKey(int(self.np_random.integers(2**31)))
        self._key, reset_key = jax.random.split(self._key)
        obs, self._state = self._reset(reset_key, self.params)
        if self.render_mode == "human":
            self.render()
        return np.asarray(obs, np.float32), {}

    def step(self, action):
        if self._state is None:
            raise RuntimeError("call reset() before step()")
        action = self.task.check_action(action, self.params)
        self._key, step_key = jax.random.split(self._key)
        obs, self._state, reward, terminated, truncated, info = self._step(step_key, self._state, action, self.params)
        info = _host_info(jax.device_get(info))
        if self.render_mode == "human":
            self.render()
        return np.asarray(obs, np.float32), float(reward), bool(terminated), bool(truncated), info

    def render(self):
        if self.render_mode is None or self._state is None:
            return None
        frame = self.task.frame(self._state, self.params)
        if self.render_mode == "rgb_array":
            return frame
        import matplotlib.pyplot as plt

        if self._figure is None:
            self._figure = plt.figure(self.spec.id if self.spec else "otgym")
            self._image = self._figure.add_subplot().imshow(frame)
            self._figure.axes[0].axis("off")
        self._image.set_data(frame)
        plt.pause(1 / self.metadata["render_fps"])
        return None

    def close(self):
        if self._figure is not None:
            import matplotlib.pyplot as plt

            plt.close(self._figure)
            self._figure = None
