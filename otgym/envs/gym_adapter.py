"""Gymnasium adapters of the functional tasks (numpy at the edges):
numpy float32 observations, python float rewards and bool flags, ``render_mode``
"rgb_array" (an RGB frame of the chip, the robots, the cell and the path) or "human"
(the same frame in a matplotlib window). Invalid actions raise ValueError.

The jitted reset/step of each (task, preset) pair are built once per process and
shared by every adapter instance.
"""

from __future__ import annotations

import functools

import gymnasium as gym
import jax
import numpy as np

from otgym import physics as ph
from otgym.envs import cell_transport, speed_control, transport
from otgym.envs.presets import preset

TASKS = {"speed_control": speed_control, "cell_transport": cell_transport}


@functools.cache
def _compiled(task: str, preset_name: str):
    module = TASKS[task]
    params = module.make_params(preset(preset_name))
    return params, jax.jit(module.reset), jax.jit(module.step)


class _TransportEnv(gym.Env):
    metadata = {"render_modes": ["rgb_array", "human"], "render_fps": 5}
    task = ""

    def __init__(self, preset: str = "paper", render_mode: str | None = None):
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be one of {self.metadata['render_modes']} or None, got {render_mode!r}")
        self.params, self._reset, self._step = _compiled(self.task, preset)
        self.render_mode = render_mode
        self.observation_space = gym.spaces.Box(-np.inf, np.inf, (transport.OBS_SIZE,), np.float32)
        self._state = None
        self._key = None
        self._renderer = None
        self._figure = None

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        self._key = jax.random.PRNGKey(int(self.np_random.integers(2**31)))
        self._key, reset_key = jax.random.split(self._key)
        obs, self._state = self._reset(reset_key, self.params)
        if self.render_mode == "human":
            self.render()
        return np.asarray(obs, np.float32), {}

    def _checked_action(self, action):
        raise NotImplementedError

    def step(self, action):
        if self._state is None:
            raise RuntimeError("call reset() before step()")
        action = self._checked_action(action)
        self._key, step_key = jax.random.split(self._key)
        obs, self._state, reward, terminated, truncated, info = self._step(step_key, self._state, action, self.params)
        events = info.pop("events")
        info = {name: value.item() for name, value in info.items()}
        info["contact_force_pn"] = np.asarray(events.contact_force_pn)
        info["trap_distance_um"] = np.asarray(events.trap_distance_um)
        if self.render_mode == "human":
            self.render()
        return np.asarray(obs, np.float32), float(reward), bool(terminated), bool(truncated), info

    def render(self):
        if self.render_mode is None or self._state is None:
            return None
        from otgym.sim.render import SceneRenderer

        scene = self.params.scene
        model = scene.model
        if self._renderer is None:
            self._renderer = SceneRenderer(
                scene.config.chip if not isinstance(scene.config.chip, str) else _chip(scene.config.chip),
                size_px=(600, 400),
            )
        physics = jax.device_get(self._state.scene.physics)
        handles = np.zeros(len(model.sphere_body), bool)
        handles[list(model.trap_sphere)] = True
        frame = self._renderer.render(
            np.asarray(ph.sphere_positions_um(model, physics.pose)),
            np.asarray(model.sphere_radius_um),
            np.array([model.body_kinds[b] for b in model.sphere_body]),
            handles,
            np.asarray(physics.trap_xy_um),
            np.asarray(self.params.path.points_um),
        )
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


def _chip(name: str):
    from otgym.sim.chip import load_chip

    return load_chip(name)


class SpeedControlEnv(_TransportEnv):
    """``otgym/SpeedControl-v0``: pick one of the preset's speed levels each step."""

    task = "speed_control"

    def __init__(self, preset: str = "paper", render_mode: str | None = None):
        super().__init__(preset, render_mode)
        self.action_space = gym.spaces.Discrete(self.params.config.n_actions)

    def _checked_action(self, action):
        integer = isinstance(action, (int, np.integer)) or (
            isinstance(action, np.ndarray) and action.ndim == 0 and np.issubdtype(action.dtype, np.integer)
        )
        if not integer or not 0 <= int(action) < self.action_space.n:
            raise ValueError(f"action must be an integer in 0..{self.action_space.n - 1}, got {action!r}")
        return int(action)


class CellTransportEnv(_TransportEnv):
    """``otgym/CellTransport-v0``: a 2D trap velocity (um/s) per robot, shape (2, 2)."""

    task = "cell_transport"

    def __init__(self, preset: str = "paper", render_mode: str | None = None):
        super().__init__(preset, render_mode)
        limit = self.params.config.max_robot_speed_um_s
        self.action_space = gym.spaces.Box(-limit, limit, (2, 2), np.float32)

    def _checked_action(self, action):
        array = np.asarray(action, np.float32)
        if array.shape != (2, 2):
            raise ValueError(f"action must have shape (2, 2) (robot, x/y velocity in um/s), got {array.shape}")
        if not np.all(np.isfinite(array)):
            raise ValueError(f"action must be finite, got {array.tolist()}")
        if not self.action_space.contains(array):
            limit = self.params.config.max_robot_speed_um_s
            raise ValueError(f"action components must lie in [-{limit}, {limit}] um/s, got {array.tolist()}")
        return array
