"""The ``assemble`` task: beads held directly by N holographic traps
are placed into a target pattern (ring, lattice, a letter) without collisions, within
what a holographic tweezer can do (``config``: SLM refresh rate, bounded trap count,
power shared between the traps). The assignment of beads to targets and the
collision-free synchronised straight moves are the task's (``plan``); the action is
the pace, one of ``pace_levels_um`` per SLM frame, so the task trains with otgym's
DQN (``otgym train --task assemble``). The functional core is ``core``; a scripted
baseline is ``baseline``.
"""

from __future__ import annotations

import functools

import gymnasium as gym
import jax
import numpy as np

from otgym.tasks.assemble import core
from otgym.tasks.assemble.config import PRESETS, AssembleConfig, preset
from otgym.tasks.base import Task, TaskScene


@functools.lru_cache(maxsize=8)
def _renderer(arena_um: float, size_px: tuple[int, int]):
    from otgym.sim.render import SceneRenderer

    return SceneRenderer(None, size_px=size_px, region_um=(0.0, 0.0, arena_um, arena_um))


class Assemble(Task):
    """Holographic micro-assembly: pick the pace of the planned moves each SLM frame."""

    name = "assemble"

    def presets(self) -> tuple[str, ...]:
        return tuple(PRESETS)

    def default_config(self) -> AssembleConfig:
        return preset("ring")

    def config(self, preset_name: str | None = None) -> AssembleConfig:
        if preset_name is not None and preset_name not in PRESETS:
            raise ValueError(f"task {self.name!r} has no preset {preset_name!r}; choose one of {list(PRESETS)}")
        return preset(preset_name)

    def make_params(self, config: AssembleConfig) -> core.AssembleParams:
        return core.make_params(config)

    def max_steps(self, params) -> int:
        return params.config.max_steps

    def reset_batch(self, key, params, n_envs: int):
        return core.reset_batch(key, params, n_envs)

    def step_batch(self, key, state, action, params):
        return core.step_batch(key, state, action, params)

    def observation_size(self, params) -> int:
        return core.OBS_SIZE

    def action_space(self, params) -> gym.spaces.Discrete:
        return gym.spaces.Discrete(params.config.n_actions)

    def policy_shape(self, config) -> tuple[int, int]:
        return core.OBS_SIZE, config.n_actions

    def frame(self, state, params, size_px=(600, 400)) -> np.ndarray:
        """The field of view: beads (yellow), traps (red rings) and the targets (grey
        discs beneath)."""
        from otgym.physics.bodies import BodyKind

        config = params.config
        state = jax.device_get(state)
        beads = np.asarray(state.physics.pose)[:, :2]
        targets = np.asarray(state.goal_um)
        n = config.n_beads
        radii = np.full(2 * n, config.bead_radius_um)
        kinds = np.array([-1] * n + [int(BodyKind.BEAD)] * n)
        return _renderer(float(config.arena_um), tuple(size_px)).render(
            np.concatenate([targets, beads]), radii, kinds, np.zeros(2 * n, bool), np.asarray(state.physics.trap_xy_um)
        )

    def scene(self, state, params) -> TaskScene:
        """The beads, their traps and the targets (discs of the placement tolerance)."""
        config = params.config
        state = jax.device_get(state)
        return TaskScene(
            spheres_um=np.asarray(state.physics.pose, float)[:, :2],
            radii_um=np.full(config.n_beads, float(config.bead_radius_um)),
            kinds=("bead",) * config.n_beads,
            traps_um=np.asarray(state.physics.trap_xy_um, float),
            targets_um=np.asarray(state.goal_um, float),
            target_radius_um=float(config.placement_tolerance_um),
        )

    def device_action(self, velocity_um_s, params) -> np.ndarray:
        """The pace level nearest the device's speed times the SLM frame period (the
        direction is the plan's)."""
        config = params.config
        velocity = np.asarray(velocity_um_s, float)
        if velocity.shape != (2,) or not np.all(np.isfinite(velocity)):
            raise ValueError(f"velocity_um_s must be two finite numbers, got {velocity_um_s!r}")
        wanted = float(np.hypot(*velocity)) * config.frame_period_s
        return np.asarray(int(np.argmin(np.abs(np.asarray(config.pace_levels_um) - wanted))), np.int32)


__all__ = ["Assemble", "AssembleConfig"]
