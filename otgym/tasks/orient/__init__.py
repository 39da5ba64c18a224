"""Task ``orient``: two robots gripping a cell turn it in place to a target angle
without losing the grip (``core`` holds the model, the observation and the
reward; ``baseline`` the scripted bang-bang controller).

Preset ``default``: the ``paper`` trap law (equation 3, at most 0.30 pN per handle)
and medium of the transport task's ``paper`` preset (water at 20 C, 4 ms physics step),
in still liquid (no flow: a cell is turned for imaging in a resting chamber) and
without obstacles; turning speeds 1.5 and 5 deg/s (about 0.2 and 0.7 um/s at the
handles), targets of 10 to 90 degrees either way, a 2 degree tolerance held for 10
steps (2 s), 200 steps (40 s) per episode."""

from __future__ import annotations

import gymnasium as gym
import jax
import numpy as np

from otgym import physics as ph
from otgym.sim.render import PATH_RGB, Label, Line
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
"""Half the length of the target line, drawn and recorded (beyond the robots' reach)."""
VIEW_WIDTH_UM = 64.0
"""The width of chip the frame shows, centred on the formation (the robots, the cell and
the channel's walls nearby)."""
TARGET_RGB = tuple(float(v) for v in PATH_RGB)
GRIP_RGB = (40.0, 44.0, 52.0)
ARROW_HEAD_UM = (2.0, 1.0)
"""The recorded target line's arrowhead: its length back along the line, its half width."""


def _axis_um(centre, angle, half_um=TARGET_LINE_HALF_UM) -> np.ndarray:
    """A line (2, 2) through ``centre`` at ``angle`` (chip frame), ``half_um`` each way."""
    half = half_um * np.array([np.cos(angle), np.sin(angle)])
    return np.stack([centre - half, centre + half])


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

    def policy_shape(self, config) -> tuple[int, int]:
        return core.OBS_SIZE, config.n_actions

    def frame(self, state, params: OrientParams, size_px=(600, 400)) -> np.ndarray:
        """The formation close up (``VIEW_WIDTH_UM`` of chip about its centre): the
        robots, the cell and the traps; the target, the grip axis (robot a to robot b)
        turned by the target, as a dashed magenta arrow through the formation's centre
        pointing where robot b should end up; the grip axis now, a solid dark arrow
        through the robots' midpoint toward robot b (beneath the bodies); and a legend
        with the angle error and the way to turn (right: clockwise on screen)."""
        state = jax.device_get(state)
        centre = np.asarray(state.centre_um, float)
        width, height = size_px
        half_x = VIEW_WIDTH_UM / 2
        half_y = half_x * height / width
        region = (centre[0] - half_x, centre[1] - half_y, centre[0] + half_x, centre[1] + half_y)
        pose = np.asarray(state.scene.physics.pose, float)
        a, b = params.scene.robots
        axis = pose[b, :2] - pose[a, :2]
        grip_now = _axis_um((pose[a, :2] + pose[b, :2]) / 2, np.arctan2(axis[1], axis[0]))
        target = _axis_um(centre, float(state.grip_start_rad) + float(state.target_rad))
        error_deg = float(np.rad2deg(state.error_rad))
        if abs(error_deg) <= params.config.tolerance_deg:
            advice = "within the tolerance: hold"
        else:
            advice = "turn right (clockwise)" if error_deg > 0 else "turn left (counter-clockwise)"
        line_px = 20 * size_px[0] / 840
        legend = [
            Label((8, 8 + row * line_px), text, (235, 238, 242), at_px=True, box_rgb=(30, 32, 38))
            for row, text in enumerate(
                ["target: dashed arrow   grip now: solid arrow", f"error {error_deg:+.1f} deg: {advice}"]
            )
        ]
        return scene_frame(
            params.scene,
            state.scene.physics,
            None,
            size_px,
            region_um=tuple(float(v) for v in region),
            under=[Line(grip_now, GRIP_RGB, width_px=3.0, arrow=True)],
            over=[Line(target, TARGET_RGB, width_px=3.0, dash_px=8.0, arrow=True), *legend],
        )

    def scene(self, state, params: OrientParams) -> TaskScene:
        """The robots, the cell and the traps, and the target: the grip axis (robot a to
        robot b) turned by the target, a line through the formation's centre with an
        arrowhead (``ARROW_HEAD_UM``) at robot b's end."""
        centre = np.asarray(state.centre_um, float)
        angle = float(state.grip_start_rad) + float(state.target_rad)
        start, tip = _axis_um(centre, angle)
        along = np.array([np.cos(angle), np.sin(angle)])
        back, side = ARROW_HEAD_UM[0] * along, ARROW_HEAD_UM[1] * np.array([-along[1], along[0]])
        line = np.stack([start, tip, tip - back + side, tip, tip - back - side])
        return scene_of(params.scene, state.scene.physics, lines_um=[line])

    def device_action(self, velocity_um_s, params: OrientParams) -> np.ndarray:
        """The device's horizontal component picks the direction: right turns the cell
        clockwise on screen (a positive turn: chip y points down), left
        counter-clockwise, at the slowest speed; none holds."""
        vx = float(np.asarray(velocity_um_s, float).reshape(-1)[0])
        return np.asarray(params.config.hold_action + int(np.sign(vx)), np.int32)


__all__ = ["Orient", "OrientConfig", "PRESETS"]
