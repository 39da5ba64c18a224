"""Task ``sort-cells``: cells of two sizes arrive with the flow at a sorting chip's inlet,
and a manipulator moves each across the flow into its size's outlet (issue 38; ``config``
holds the config and the manipulation it implies, ``core`` the model, ``baseline`` the
scripted controller). The chip, ``sorter`` (``otgym.sim.sorter_chip``), is a PNG with a
sidecar naming its inlet, its two outlets and the junction.

Presets: ``robots`` (default): two microrobots grip the cell, so it sees only the light
of the handle traps that reaches it; ``direct``: one trap holds the cell in its focus,
quicker to take hold of a cell, with the flow and arrivals twice as fast, and a dose
orders of magnitude higher."""

from __future__ import annotations

import dataclasses

import gymnasium as gym
import jax
import numpy as np

from otgym.physics.bodies import BodyKind
from otgym.sim import scene as sc
from otgym.sim.chip import load_chip
from otgym.sim.render import SceneRenderer
from otgym.tasks.base import Task, TaskScene
from otgym.tasks.sort_cells import core
from otgym.tasks.sort_cells.config import SortConfig


def robots() -> SortConfig:
    return SortConfig(name="robots", mode="robots")


def direct() -> SortConfig:
    return SortConfig(name="direct", mode="direct", flow_scale=1.0, arrival_interval_s=5.0)


def direct_slow() -> SortConfig:
    """Direct trapping at the ``robots`` preset's flow and arrivals (for the trade-off)."""
    return dataclasses.replace(robots(), name="direct-slow", mode="direct")


def robots_fast() -> SortConfig:
    """Robots at the ``direct`` preset's flow and arrivals (for the trade-off)."""
    return dataclasses.replace(direct(), name="robots-fast", mode="robots")


PRESETS = {"robots": robots, "direct": direct, "direct-slow": direct_slow, "robots-fast": robots_fast}


class SortCells(Task):
    """Sort cells by size: each step let go of the target cell or move it toward one of
    the two outlets' sides."""

    name = "sort-cells"

    def presets(self) -> tuple[str, ...]:
        return tuple(PRESETS)

    def default_config(self) -> SortConfig:
        return robots()

    def config(self, preset: str | None = None) -> SortConfig:
        if preset not in (None, *PRESETS):
            raise ValueError(f"task {self.name!r} has no preset {preset!r}; choose one of {list(PRESETS)}")
        return PRESETS[preset or "robots"]()

    def make_params(self, config: SortConfig) -> core.SortParams:
        return core.make_params(config)

    def max_steps(self, params) -> int:
        return params.config.max_steps

    def control_period_s(self, params) -> float:
        return params.config.control_period_s

    def reset_batch(self, key, params, n_envs: int):
        return core.reset_batch(key, params, n_envs)

    def step_batch(self, key, state, action, params):
        return core.step_batch(key, state, action, params)

    def auto_reset(self, key, params, obs, state, done):
        return core.auto_reset(key, params, obs, state, done)

    def observation_size(self, params) -> int:
        return core.OBS_SIZE

    def action_space(self, params) -> gym.spaces.Discrete:
        return gym.spaces.Discrete(core.N_ACTIONS)

    def frame(self, state, params: core.SortParams, size_px=(600, 400)) -> np.ndarray:
        """The chip, the cells in it (their sizes tell the kinds apart) and, on a held
        cell, the traps: on the robots' handles (``robots``) or in the cell (``direct``)."""
        state = jax.device_get(state)
        renderer = _renderer(params.config.chip, tuple(size_px))
        active = np.asarray(state.active, bool)
        xy = np.asarray(state.xy_um)[active]
        radii = np.asarray(params.radius_um)[np.asarray(state.kind)[active]]
        traps = _held_traps(state, params)
        kinds = np.full(len(xy), int(BodyKind.CELL))
        return renderer.render(xy, radii, kinds, np.zeros(len(xy), bool), traps)

    def scene(self, state, params: core.SortParams) -> TaskScene:
        """The cells in the chip (kind ``"cell"``; their radii tell the two kinds apart,
        as in ``frame``), the traps on a held cell (``_held_traps``), the two outlets as
        targets of radius ``exit_distance_um`` (where a cell leaves by one), and the
        target cell's route: from it through the junction to its kind's outlet."""
        state = jax.device_get(state)
        active = np.asarray(state.active, bool)
        kind = np.asarray(state.kind)
        xy = np.asarray(state.xy_um, float)
        first, present, _, _ = core._upstream_order(params, state)
        lines = ()
        if bool(present):
            outlet = np.asarray(params.outlets_um, float)[kind[int(first)]]
            lines = (np.stack([xy[int(first)], np.asarray(params.junction_um, float), outlet]),)
        return TaskScene(
            spheres_um=xy[active],
            radii_um=np.asarray(params.radius_um, float)[kind[active]],
            kinds=("cell",) * int(active.sum()),
            traps_um=_held_traps(state, params),
            targets_um=np.asarray(params.outlets_um, float),
            target_radius_um=params.config.exit_distance_um,
            lines_um=lines,
        )

    def device_action(self, velocity_um_s, params: core.SortParams) -> np.ndarray:
        """Up or down on screen moves the target toward the outlet on that side; a
        device at rest (below 0.5 um/s across) lets go."""
        vy = float(np.asarray(velocity_um_s, float).reshape(-1)[1])
        if abs(vy) < 0.5:
            return np.asarray(0, np.int32)
        side = np.asarray(params.side_sign)
        return np.asarray(1 + int(np.argmax(side == np.sign(vy))), np.int32)


def _held_traps(state, params: core.SortParams) -> np.ndarray:
    """The traps (um, (T, 2)) of one environment once its cell is held (after the grip
    time): on the robots' handles around it (``robots``) or one in it (``direct``);
    none otherwise."""
    held = int(state.held)
    if held < 0 or float(state.grip_s) < params.config.grip_time or not bool(state.active[held]):
        return np.zeros((0, 2))
    centre = np.asarray(state.xy_um[held], float)
    offsets = (
        _grip_offsets(params.config, int(state.kind[held])) if params.config.mode == "robots" else np.zeros((1, 2))
    )
    return centre[None] + offsets


def _renderer(chip: str, size_px) -> SceneRenderer:
    return _RENDERERS.setdefault((chip, size_px), SceneRenderer(load_chip(chip), size_px=size_px))


_RENDERERS: dict = {}


def _grip_offsets(config: SortConfig, kind: int) -> np.ndarray:
    key = (config.robot, config.cell_radii_um[kind])
    if key not in _GRIPS:
        _GRIPS[key] = sc.grip_geometry_um(
            sc.SceneConfig(robot=config.robot, cell_radius_um=config.cell_radii_um[kind])
        )[0]
    return _GRIPS[key]


_GRIPS: dict = {}

__all__ = ["PRESETS", "SortCells", "SortConfig"]
