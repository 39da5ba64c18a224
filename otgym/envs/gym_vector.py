"""Native Gymnasium vector environments of the transport tasks:
``SpeedControlVectorEnv`` and ``CellTransportVectorEnv``, ``num_envs`` copies of
``otgym/SpeedControl-v0`` / ``otgym/CellTransport-v0`` (two optical-tweezer robots
carrying a cell along a segment of the planned path through the chip;
``otgym.envs.transport``). ``gymnasium.make_vec("otgym/SpeedControl-v0",
num_envs=8)`` returns one (``vectorization_mode="vector_entry_point"``, the default
for these ids); ``vectorization_mode="sync"`` still gives ``SyncVectorEnv`` over the
single adapters.

Why native: the functional tasks are batched already (``reset_batch``/``step_batch``,
one leading environment axis), so a step of all environments, their auto-reset
included, is ONE jitted XLA call and one device-to-host copy, instead of ``num_envs``
Python envs each making its own jitted call of a batch of one.

Autoreset mode ``AutoresetMode.SAME_STEP`` (``metadata["autoreset_mode"]``): an
environment that terminates or truncates is replaced by a fresh episode within the
same ``step`` (``otgym.envs.transport.auto_reset``); the returned observation is the
new episode's first, and the step's reward, terminated and truncated are those of
the finished episode. As in ``gymnasium.vector.SyncVectorEnv`` with SAME_STEP, when
any environment finished, ``infos`` also holds ``"final_obs"`` (an object array of
``num_envs`` entries: the (21,) float32 last observation of each finished episode,
None elsewhere), ``"final_info"`` (the finished episodes' last info, the dict below)
and the masks ``"_final_obs"`` = ``"_final_info"`` = terminated | truncated.

``infos`` of ``step`` (numpy, leading axis ``num_envs``): ``progress``, ``time_s``
(float32), ``success``, ``failed`` (bool), ``contact_force_pn`` (E, 2) and
``trap_distance_um`` (E, 4), each with its Gymnasium mask ``_<key>`` (all True: every
environment reports every key each step). For a finished environment these values
describe the step that ended its episode (the same as in ``final_info``), not the new
episode. ``reset`` returns empty infos, as the single adapters do.

Observations are float32 (num_envs, 21), rewards float32 (num_envs,), terminations
and truncations bool (num_envs,). Invalid actions raise ValueError (the functional
step would silently clip them). ``reset(seed=s)`` reproduces the same episodes and
(with the same actions) the same steps. ``render_mode="rgb_array"``: ``render()``
returns a tuple of ``num_envs`` RGB frames (H, W, 3) uint8, the single adapter's
frame of each environment (``SyncVectorEnv``'s convention); "human" is not supported.

The params (scene and planned path) of a (task, preset) pair are built once per
process (``gym_adapter._compiled``, shared with the single adapters) and the jitted
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

from otgym.envs import gym_adapter, transport

INFO_KEYS = ("progress", "success", "failed", "time_s", "contact_force_pn", "trap_distance_um")


@functools.cache
def _compiled_batch(task: str, preset_name: str):
    """(params, reset(key, params, n_envs), step(key, state, actions, params)) of a
    task, jitted; ``step`` steps every environment and auto-resets the finished ones,
    returning (obs, state, final_obs, reward, terminated, truncated, info)."""
    module = gym_adapter.TASKS[task]
    params = gym_adapter._compiled(task, preset_name)[0]

    def step(key, state, actions, params):
        step_key, reset_key = jax.random.split(key)
        obs, state, reward, terminated, truncated, info = module.step_batch(step_key, state, actions, params)
        events = info.pop("events")
        info["contact_force_pn"] = events.contact_force_pn
        info["trap_distance_um"] = events.trap_distance_um
        next_obs, state = transport.auto_reset(reset_key, params, obs, state, terminated | truncated)
        return next_obs, state, obs, reward, terminated, truncated, info

    return params, jax.jit(module.reset_batch, static_argnums=2), jax.jit(step)


class _TransportVectorEnv(gym.vector.VectorEnv):
    metadata = {"render_modes": ["rgb_array"], "render_fps": 5, "autoreset_mode": AutoresetMode.SAME_STEP}
    task = ""
    single_env: type[gym_adapter._TransportEnv] | None = None  # the single adapter, for rendering

    def __init__(self, num_envs: int, preset: str = "paper", render_mode: str | None = None):
        if isinstance(num_envs, bool) or not isinstance(num_envs, (int, np.integer)) or num_envs < 1:
            raise ValueError(f"num_envs must be a positive integer, got {num_envs!r}")
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be one of {self.metadata['render_modes']} or None, got {render_mode!r}")
        self.num_envs = int(num_envs)
        self.preset = preset
        self.render_mode = render_mode
        self.params, self._reset, self._step = _compiled_batch(self.task, preset)
        self.single_observation_space = gym.spaces.Box(-np.inf, np.inf, (transport.OBS_SIZE,), np.float32)
        self.single_action_space = self._single_action_space()
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self._state = None
        self._key = None
        self._renderer_env = None

    def _single_action_space(self) -> gym.Space:
        raise NotImplementedError

    def _checked_actions(self, actions) -> np.ndarray:
        raise NotImplementedError

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
        actions = self._checked_actions(actions)
        self._key, step_key = jax.random.split(self._key)
        obs, self._state, *out = self._step(step_key, self._state, actions, self.params)
        obs, final_obs, reward, terminated, truncated, info = jax.device_get((obs, *out))  # one copy to the host
        # writable copies: the arrays that device_get returns are read-only
        obs, reward = np.array(obs, np.float32), np.array(reward, np.float32)
        terminated, truncated = np.array(terminated, bool), np.array(truncated, bool)
        info = {key: np.array(info[key], bool if key in ("success", "failed") else np.float32) for key in INFO_KEYS}
        infos = dict(info)
        infos.update({f"_{key}": np.ones(self.num_envs, bool) for key in INFO_KEYS})
        done = terminated | truncated
        if done.any():
            finals = np.full(self.num_envs, None, dtype=object)
            for i in np.flatnonzero(done):
                finals[i] = np.array(final_obs[i], np.float32)
            final_info = {key: value.copy() for key, value in info.items()}
            final_info.update({f"_{key}": done.copy() for key in INFO_KEYS})
            infos.update(final_obs=finals, _final_obs=done.copy(), final_info=final_info, _final_info=done.copy())
        return obs, reward, terminated, truncated, infos

    def render(self):
        """A tuple of ``num_envs`` RGB frames (the single adapter's frame of each
        environment), or None without ``render_mode`` or before ``reset``."""
        if self.render_mode is None or self._state is None:
            return None
        if self._renderer_env is None:
            # The single adapter draws the scene of its ``_state``: lend it each environment's state in turn.
            self._renderer_env = self.single_env(self.preset, render_mode="rgb_array")
        frames = []
        for i in range(self.num_envs):
            self._renderer_env._state = jax.tree.map(lambda a: a[i], self._state)  # noqa: B023
            frames.append(self._renderer_env.render())
        return tuple(frames)

    def close_extras(self, **kwargs):
        if self._renderer_env is not None:
            self._renderer_env.close()
            self._renderer_env = None


class SpeedControlVectorEnv(_TransportVectorEnv):
    """``num_envs`` copies of ``otgym/SpeedControl-v0`` stepped together: actions are
    integers (num_envs,) in ``0..n-1``, each picking one of the preset's speed levels."""

    task = "speed_control"
    single_env = gym_adapter.SpeedControlEnv

    def _single_action_space(self):
        return gym.spaces.Discrete(self.params.config.n_actions)

    def _checked_actions(self, actions):
        n = self.single_action_space.n
        array = np.asarray(actions)
        if array.shape != (self.num_envs,):
            raise ValueError(f"actions must have shape ({self.num_envs},) (one per environment), got {array.shape}")
        if not np.issubdtype(array.dtype, np.integer):
            raise ValueError(f"actions must be integers in 0..{n - 1}, got dtype {array.dtype}: {array.tolist()}")
        if np.any(array < 0) or np.any(array >= n):
            raise ValueError(f"actions must be integers in 0..{n - 1}, got {array.tolist()}")
        return array.astype(np.int32)


class CellTransportVectorEnv(_TransportVectorEnv):
    """``num_envs`` copies of ``otgym/CellTransport-v0`` stepped together: actions are
    trap velocities (num_envs, 2, 2) in um/s (environment, robot, x/y), each component
    within +-``max_robot_speed_um_s``."""

    task = "cell_transport"
    single_env = gym_adapter.CellTransportEnv

    def _single_action_space(self):
        limit = self.params.config.max_robot_speed_um_s
        return gym.spaces.Box(-limit, limit, (2, 2), np.float32)

    def _checked_actions(self, actions):
        try:
            array = np.asarray(actions, np.float32)
        except (TypeError, ValueError) as error:
            raise ValueError(
                f"actions must be a float array of shape ({self.num_envs}, 2, 2), got {actions!r}"
            ) from error
        if array.shape != (self.num_envs, 2, 2):
            raise ValueError(
                f"actions must have shape ({self.num_envs}, 2, 2) (environment, robot, x/y velocity "
                f"in um/s), got {array.shape}"
            )
        if not np.all(np.isfinite(array)):
            raise ValueError(
                f"actions must be finite, got NaN or inf in environments "
                f"{np.flatnonzero(~np.all(np.isfinite(array), axis=(1, 2))).tolist()}"
            )
        if not self.action_space.contains(array):
            limit = self.params.config.max_robot_speed_um_s
            outside = np.flatnonzero(np.any(np.abs(array) > limit, axis=(1, 2))).tolist()
            raise ValueError(
                f"action components must lie in [-{limit}, {limit}] um/s, got values outside in environments {outside}"
            )
        return array
