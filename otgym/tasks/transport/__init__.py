"""The paper's transport tasks as ``Task``s (``otgym.tasks.base``): two robots pinching
a cell follow a segment of the planned path past moving obstacles (paper section
II-C). ``SpeedControl``: a discrete speed along the path each step. ``CellTransport``:
a 2-D trap velocity per robot. The functional cores are ``core`` (scene, path, the
observation and reward), ``speed_control`` and ``cell_transport``; presets in
``presets``. Every route task starts from ``route_start`` (route and formation). The
paper's interactive task (section III-C) shares it: ``interactive`` is its functional
core and ``scenario`` its obstacles (its host wrapper: ``otgym.task.task``)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np

from otgym.tasks.base import Task, TaskScene
from otgym.tasks.scene_frame import scene_frame, scene_of
from otgym.tasks.transport import cell_transport, core, speed_control
from otgym.tasks.transport.presets import PRESETS, TaskConfig, preset


def _flat_info(info: dict) -> dict:
    """The core's info with its ``SceneEvents`` replaced by the two per-step arrays
    the adapters report."""
    info = dict(info)
    events = info.pop("events")
    info["contact_force_pn"] = events.contact_force_pn
    info["trap_distance_um"] = events.trap_distance_um
    return info


class _Transport(Task):
    module = speed_control

    def presets(self) -> tuple[str, ...]:
        return tuple(PRESETS)

    def default_config(self) -> TaskConfig:
        return preset("paper")

    def config(self, preset_name: str | None = None) -> TaskConfig:
        if preset_name is not None and preset_name not in PRESETS:
            raise ValueError(f"task {self.name!r} has no preset {preset_name!r}; choose one of {list(PRESETS)}")
        return preset(preset_name or "paper")

    def make_params(self, config: TaskConfig) -> core.TransportParams:
        return core.make_params(config)

    def max_steps(self, params) -> int:
        return params.config.max_steps

    def control_period_s(self, params) -> float:
        return params.config.scene.control_period_s

    def reset_batch(self, key, params, n_envs: int):
        return core.reset_batch(key, params, n_envs)

    def step_batch(self, key, state, action, params):
        obs, state, reward, terminated, truncated, info = self.module.step_batch(key, state, action, params)
        return obs, state, reward, terminated, truncated, _flat_info(info)

    def auto_reset(self, key, params, obs, state, done):
        return core.auto_reset(key, params, obs, state, done)

    def observation_size(self, params) -> int:
        return core.OBS_SIZE

    def frame(self, state, params, size_px=(600, 400)) -> np.ndarray:
        return scene_frame(params.scene, state.scene.physics, params.path.points_um, size_px)

    def scene(self, state, params) -> TaskScene:
        """The robots, the cell, the obstacles and the traps, and the planned path."""
        return scene_of(params.scene, state.scene.physics, lines_um=[params.path.points_um])


class SpeedControl(_Transport):
    """The paper's learning task: pick one of the preset's speed levels along the path."""

    name = "speed-control"
    module = speed_control

    def action_space(self, params) -> gym.spaces.Discrete:
        return gym.spaces.Discrete(params.config.n_actions)

    def policy_shape(self, config) -> tuple[int, int]:
        return core.OBS_SIZE, config.n_actions

    def policy_meta(self, params) -> dict:
        return {"speed_levels_um_s": list(params.config.speed_levels_um_s)}

    def device_action(self, velocity_um_s, params) -> np.ndarray:
        """The speed level nearest the device's speed (its direction is the path's)."""
        levels = np.asarray(params.config.speed_levels_um_s)
        wanted = float(np.hypot(*np.asarray(velocity_um_s, float))) * levels.max() / params.config.max_robot_speed_um_s
        return np.asarray(int(np.argmin(np.abs(levels - wanted))), np.int32)


class CellTransport(_Transport):
    """Speed control with a 2-D trap velocity (um/s) per robot, shape (2, 2)."""

    name = "cell-transport"
    module = cell_transport
    action_unit = "um/s"

    def action_space(self, params) -> gym.spaces.Box:
        limit = params.config.max_robot_speed_um_s
        return gym.spaces.Box(-limit, limit, (2, 2), np.float32)

    def device_action(self, velocity_um_s, params) -> np.ndarray:
        """Both robots move with the device's velocity (clipped to the limit)."""
        limit = params.config.max_robot_speed_um_s
        velocity = np.clip(np.asarray(velocity_um_s, np.float32), -limit, limit)
        return np.stack([velocity, velocity]).astype(np.float32)


__all__ = ["CellTransport", "SpeedControl", "TaskConfig"]
