"""The native Gymnasium vector environment of any registered task: ``TaskVectorEnv``,
``num_envs`` copies of ``TaskEnv`` (``otgym.envs.gym_adapter``) stepped together.
``gymnasium.make_vec("otgym/SpeedControl-v0", num_envs=8)`` returns one
(``vectorization_mode="vector_entry_point"``, the default for otgym's ids);
``vectorization_mode="sync"`` still gives ``SyncVectorEnv`` over the single adapters.

Why native: tasks are batched (``Task.reset_batch`` / ``step_batch``, one leading
environment axis), so a step of all environments, their auto-reset included, is ONE
jitted XLA call and one device-to-host copy, instead of ``num_envs`` Python envs each
making its own jitted call of a batch of one.

Autoreset mode ``AutoresetMode.SAME_STEP`` (``metadata["autoreset_mode"]``): an
environment that terminates or truncates is replaced by a fresh episode within the
same ``step`` (``otgym.tasks.transport.core.auto_reset``); the returned observation is the
new episode's first, and the step's reward, terminated and truncated are those of
the finished episode. As in ``gymnasium.vector.SyncVectorEnv`` with SAME_STEP, when
any environment finished, ``infos`` also holds ``"final_obs"`` (an object array of
``num_envs`` entries: the float32 last observation of each finished episode,
None elsewhere), ``"final_info"`` (the finished episodes' last info, the dict below)
and the masks ``"_final_obs"`` = ``"_final_info"`` = terminated | truncated.

``infos`` of ``step`` (numpy, leading axis ``num_envs``): the task's info entries
(the transport tasks: ``progress``, ``time_s``, ``success``, ``failed``,
``contact_force_pn`` (E, 2) and ``trap_distance_um`` (E, 4)), each with its Gymnasium
mask ``_<key>`` (all True: every environment reports every key each step). For a finished environment these values
describe the step that ended its episode (the same as in ``final_info``), not the new
episode. ``reset`` returns empty infos, as the single adapters do.

Observations are float32 (num_envs, O), rewards float32 (num_envs,), terminations
and truncations bool (num_envs,). Invalid actions raise ValueError (the functional
step would silently clip them). ``reset(seed=s)`` reproduces the same episodes and
(with the same actions) the same steps. ``render_mode="rgb_array"``: ``render()``
returns a tuple of ``num_envs`` RGB frames (H, W, 3) uint8, the single adapter's
frame of each environment (``SyncVectorEnv``'s convention); "human" is not supported.

The params of a (task, preset) pair are built once per process
(``gym_adapter.compiled``, shared with the single adapters) and the jitted
batched reset/step once per (task, preset); JAX's own cache keeps one compiled program
per ``num_envs``.
"""

from __future__ import annotations

import functools

import gymnasium as gym
import jax
import numpy as np
from gymnasium.vector import AutoresetMode
from gymnasium.vector.utils import batch_space

from otgym.envs import gym_adapter


@functools.cache
def _compiled_batch(task_name: str, preset_name: str | None):
    """(task, params, reset(key, params, n_envs), step(key, state, actions, params)) of
    a task, jitted; ``step`` steps every environment and auto-resets the finished ones,
    returning (obs, state, final_obs, reward, terminated, truncated, info)."""
    task, params = gym_adapter.compiled(task_name, preset_name)[:2]

    def step(key, state, actions, params):
        step_key, reset_key = jax.random.split(key)
        obs, state, reward, terminated, truncated, info = task.step_batch(step_key, state, actions, params)
        next_obs, state = task.auto_reset(reset_key, params, obs, state, terminated | truncated)
        return next_obs, state, obs, reward, terminated, truncated, info

    return task, params, jax.jit(task.reset_batch, static_argnums=2), jax.jit(step)


class TaskVectorEnv(gym.vector.VectorEnv):
    """``num_envs`` copies of registered task ``task`` with preset ``preset``."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 5, "autoreset_mode": AutoresetMode.SAME_STEP}

    def __init__(
        self, num_envs: int, task: str = "speed-control", preset: str | None = None, render_mode: str | None = None
    ):
        if isinstance(num_envs, bool) or not isinstance(num_envs, (int, np.integer)) or num_envs < 1:
            raise ValueError(f"num_envs must be a positive integer, got {num_envs!r}")
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be one of {self.metadata['render_modes']} or None, got {render_mode!r}")
        self.num_envs = int(num_envs)
        self.preset = preset
        self.render_mode = render_mode
        self.task, self.params, self._reset, self._step = _compiled_batch(task, preset)
        self.single_observation_space = self.task.observation_space(self.params)
        self.single_action_space = self.task.action_space(self.params)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self._state = None
        self._key = None

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        if options:
            raise ValueError(f"reset options are not supported, got {options!r}")
        super().reset(seed=seed)
        self._key = jax.random.PRNGKey(int(self.np_random.integers(2**31)))
        self._key, reset_key = jax.random.split(self._key)
        obs, self._state = self._reset(reset_key, self.params, self.num_envs)
        return np.array(obs, np.float32), {}  # a writable copy (device arrays are read-only)

    def step(self, actions):
        if self._state is None:
            raise RuntimeError("call reset() before step()")
        actions = self.task.check_actions(actions, self.params, self.num_envs)
        self._key, step_key = jax.random.split(self._key)
        obs, self._state, *out = self._step(step_key, self._state, actions, self.params)
        obs, final_obs, reward, terminated, truncated, info = jax.device_get((obs, *out))  # one copy to the host
        # writable copies: the arrays that device_get returns are read-only
        obs, reward = np.array(obs, np.float32), np.array(reward, np.float32)
        terminated, truncated = np.array(terminated, bool), np.array(truncated, bool)
        info = {key: np.array(value, bool if value.dtype == bool else np.float32) for key, value in info.items()}
        infos = dict(info)
        infos.update({f"_{key}": np.ones(self.num_envs, bool) for key in info})
        done = terminated | truncated
        if done.any():
            finals = np.full(self.num_envs, None, dtype=object)
            for i in np.flatnonzero(done):
                finals[i] = np.array(final_obs[i], np.float32)
            final_info = {key: value.copy() for key, value in info.items()}
            final_info.update({f"_{key}": done.copy() for key in info})
            infos.update(final_obs=finals, _final_obs=done.copy(), final_info=final_info, _final_info=done.copy())
        return obs, reward, terminated, truncated, infos

    def render(self):
        """A tuple of ``num_envs`` RGB frames (the task's frame of each environment),
        or None without ``render_mode`` or before ``reset``."""
        if self.render_mode is None or self._state is None:
            return None
        return tuple(
            self.task.frame(jax.tree.map(lambda a: a[i], self._state), self.params)  # noqa: B023
            for i in range(self.num_envs)
        )
