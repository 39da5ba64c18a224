"""Task ``orient``: two robots gripping a cell turn it in place to a target angle
without losing the grip (issue 38; ``core`` holds the model, the observation and the
reward; ``baseline`` the scripted bang-bang controller).

Preset ``default``: the ``paper`` trap law (equation 3, at most 0.30 pN per handle)
and medium of the transport task's ``paper`` preset (water at 20 C, 4 ms physics step),
in still liquid (no flow: a cell is turned for imaging in a resting chamber) and
without obstacles; turning speeds 1.5 and 5 deg/s (about 0.2 and 0.7 um/s at the
handles), targets of 10 to 90 degrees either way, a 2 degree tolerance held for 10
steps (2 s), 200 steps (40 s) per episode."""

from __future__ import annotations

import gymnasium as gym
import numpy as np

from otgym import physics as ph
from otgym.sim.scene import SceneConfig
from otgym.tasks.base import Task, TaskScene
from otgym.tasks.orient import core
from otgym.tasks.orient.core import OrientConfig, OrientParams
from otgym.tasks.scene_frame import scene_frame, scene_of


def default() -> OrientConfig:
    scene = SceneConfig(
        trap_law=ph.TrapLaw.paper(),
        dt_s=4e-3,
        viscosity_pa_s=1.0e-3,
        flow_scale=0.0,
        n_obstacles=0,
    )
    return OrientConfig(name="default", scene=scene)


PRESETS = {"default": default}
TARGET_LINE_HALF_UM = 12.0
"""Half the length of the recorded scene's target line (about the robots' reach)."""


class Orient(Task):
    """Turn a gripped cell to a target angle: one of the preset's angular speeds either
    way, or hold, each step."""

    name = "orient"

    def presets(self) -> tuple[str, ...]:
        return tuple(PRESETS)

    def default_config(self) -> OrientConfig:
        return default()

    def config(self, preset: str | None = None) -> OrientConfig:
        if preset not in (None, *PRESETS):
            raise ValueError(f"task {self.name!r} has no preset {preset!r}; choose one of {list(PRESETS)}")
        return PRESETS[preset or "default"]()

    def make_params(self, config: OrientConfig) -> OrientParams:
        return core.make_params(config)

    def max_steps(self, params: OrientParams) -> int:
        return params.config.max_steps

    def reset_batch(self, key, params, n_envs: int):
        return core.reset_batch(key, params, n_envs)

    def step_batch(self, key, state, action, params):
        return core.step_batch(key, state, action, params)

    def auto_reset(self, key, params, obs, state, done):
        return core.auto_reset(key, params, obs, state, done)

    def observation_size(self, params) -> int:
        return core.OBS_SIZE

    def action_space(self, params: OrientParams) -> gym.spaces.Discrete:
        return gym.spaces.Discrete(params.config.n_actions)

    def frame(self, state, params: OrientParams, size_px=(600, 400)) -> np.ndarray:
        return scene_frame(params.scene, state.scene.physics, None, size_px)

    def scene(self, state, params: OrientParams) -> TaskScene:
        """The robots, the cell and the traps, and the target: the grip axis (robot a to
        robot b) turned by the target, a line through the formation's centre."""
        centre = np.asarray(state.centre_um, float)
        angle = float(state.grip_start_rad) + float(state.target_rad)
        half = TARGET_LINE_HALF_UM * np.array([np.cos(angle), np.sin(angle)])
        return scene_of(params.scene, state.scene.physics, lines_um=[np.stack([centre - half, centre + half])])

    def device_action(self, velocity_um_s, params: OrientParams) -> np.ndarray:
        """The device's horizontal component picks the direction: right turns the cell
        clockwise on screen (a positive turn: chip y points down), left
        counter-clockwise, at the slowest speed; none holds."""
        vx = float(np.asarray(velocity_um_s, float).reshape(-1)[0])
        return np.asarray(params.config.hold_action + int(np.sign(vx)), np.int32)


__all__ = ["Orient", "OrientConfig", "PRESETS"]
