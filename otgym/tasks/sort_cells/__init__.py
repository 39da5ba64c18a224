"""Task ``sort-cells``: cells of two sizes arrive with the flow at a sorting chip's inlet,
and a manipulator moves each across the flow into its size's outlet (``config``
holds the config and the manipulation it implies, ``core`` the model, ``baseline`` the
scripted controller, ``view`` what its frame and recorded scene show). The chip,
``sorter`` (``otgym.sim.sorter_chip``), is a PNG with a sidecar naming its inlet, its
two outlets and the junction.

Presets: ``robots`` (default): two microrobots grip the cell, so it sees only the light
of the handle traps that reaches it; ``direct``: one trap holds the cell in its focus,
quicker to take hold of a cell, with the flow and arrivals twice as fast, and a dose
orders of magnitude higher."""

from __future__ import annotations

import dataclasses

import gymnasium as gym
import numpy as np

from otgym.tasks.base import Task, TaskScene
from otgym.tasks.sort_cells import core, view
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

    def policy_shape(self, config) -> tuple[int, int]:
        return core.OBS_SIZE, core.N_ACTIONS

    def frame(self, state, params: core.SortParams, size_px=(600, 400)) -> np.ndarray:
        """The chip with its ports marked (each outlet in the colour of the kind it takes,
        labelled; the inlet), the cells coloured and sized by kind, and the manipulator:
        the two robots with their traps (``robots``) or the trap in the held cell
        (``direct``); ``view`` says where the robots, which the task does not simulate,
        are drawn."""
        return view.frame(state, params, size_px)

    def scene(self, state, params: core.SortParams) -> TaskScene:
        """The cells, the robots' spheres (``robots``), the traps, the outlets as targets
        and the target cell's route and the inlet's opening as lines (``view.scene``)."""
        return view.scene(state, params)

    def device_action(self, velocity_um_s, params: core.SortParams) -> np.ndarray:
        """Up or down on screen moves the target toward the outlet on that side; a
        device at rest (below 0.5 um/s across) lets go."""
        vy = float(np.asarray(velocity_um_s, float).reshape(-1)[1])
        if abs(vy) < 0.5:
            return np.asarray(0, np.int32)
        side = np.asarray(params.side_sign)
        return np.asarray(1 + int(np.argmax(side == np.sign(vy))), np.int32)


__all__ = ["PRESETS", "SortCells", "SortConfig"]
