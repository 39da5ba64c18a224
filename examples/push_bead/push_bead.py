"""PushBead: carry one optically trapped bead to a target spot on a chip.

otgym's "Write your own task" tutorial (docs/tutorial-own-task.md). One 1 um bead sits
in one Gaussian trap on the default chip, in its flow and among its walls and posts
(otgym's ``bead`` scene, ``otgym.sim.scene``). Each step the agent moves the trap one
of four ways or holds it; the physics (Brownian motion, Stokes drag, the trap's force,
wall contact) runs ``substeps`` steps in between and the bead follows the trap. The
episode ends when the bead is within ``target_radius_um`` of the target (success),
when it touches a wall or leaves the trap (failure), or after ``max_steps`` steps.
"""

from __future__ import annotations

import dataclasses

import gymnasium as gym
import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from otgym import physics as ph
from otgym.sim import scene as sc
from otgym.tasks import Task
from otgym.tasks.scene_frame import scene_frame

MOVES = np.array([[0, 0], [1, 0], [-1, 0], [0, 1], [0, -1]], np.float32)
"""Action i moves the trap along MOVES[i]: hold, right, left, down, up (chip y points down)."""


@dataclasses.dataclass(frozen=True)
class PushBeadConfig:
    """Everything that defines the task (frozen and hashable: static under ``jit``)."""

    scene: sc.SceneConfig = sc.SceneConfig(
        kind="bead",
        n_obstacles=0,
        bead_radius_um=1.0,
        trap_law=ph.TrapLaw("gaussian", stiffness_pn_per_um=20.0, waist_um=1.0),
        dt_s=2e-4,  # a fifth of the bead's relaxation time in the trap, 8e-4 s
        control_period_s=0.1,
    )
    trap_speed_um_s: float = 10.0
    target_distance_um: tuple[float, float] = (5.0, 15.0)
    target_radius_um: float = 1.0
    max_steps: int = 60
    device_dead_band_um_s: float = 1.0  # a slower pointing device holds the trap
    n_spots: int = 2048  # start and target spots drawn once from the chip's free places


@struct.dataclass
class PushBeadParams:
    scene: sc.Scene
    spots_um: jnp.ndarray  # (n_spots, 2) places with room for the bead
    config: PushBeadConfig = struct.field(pytree_node=False)


@struct.dataclass
class PushBeadState:
    scene: sc.SceneState
    target_um: jnp.ndarray  # (2,)
    steps: jnp.ndarray  # int32


class PushBead(Task):
    """Carry one trapped bead to a target spot: hold the trap or move it one of 4 ways."""

    name = "push-bead"

    def default_config(self) -> PushBeadConfig:
        return PushBeadConfig()

    def make_params(self, config: PushBeadConfig) -> PushBeadParams:
        scene = sc.build_scene(config.scene)  # loads the chip, its walls and flow (cached)
        spots = np.asarray(scene.start_candidates_um)
        chosen = np.random.default_rng(0).choice(len(spots), min(config.n_spots, len(spots)), replace=False)
        return PushBeadParams(scene, jnp.asarray(spots[np.sort(chosen)]), config)

    def max_steps(self, params: PushBeadParams) -> int:
        return params.config.max_steps

    def control_period_s(self, params: PushBeadParams) -> float:
        return params.config.scene.control_period_s

    def reset(self, key, params: PushBeadParams):
        start_key, target_key, scene_key = jax.random.split(key, 3)
        spots = params.spots_um
        start = spots[jax.random.randint(start_key, (), 0, spots.shape[0])]
        distance = jnp.linalg.norm(spots - start, axis=-1)
        low, high = params.config.target_distance_um
        near = (distance >= low) & (distance <= high)
        logits = jnp.where(jnp.any(near), jnp.where(near, 0.0, -jnp.inf), 0.0)  # any spot if none is near
        target = spots[jax.random.categorical(target_key, logits)]
        scene_state = sc.reset_at(params.scene, scene_key, start, 0.0)  # the trap on the bead
        state = PushBeadState(scene_state, target, jnp.zeros((), jnp.int32))
        return self._observe(state, params), state

    def step(self, key, state: PushBeadState, action, params: PushBeadParams):
        config = params.config
        move = jnp.asarray(MOVES)[jnp.clip(jnp.asarray(action, jnp.int32), 0, len(MOVES) - 1)]
        trap_velocity = (move * config.trap_speed_um_s)[None]  # (traps, 2) um/s
        scene_state, events = sc.step(params.scene, state.scene, trap_velocity, key)
        new = PushBeadState(scene_state, state.target_um, state.steps + 1)
        before = jnp.linalg.norm(state.scene.physics.pose[0, :2] - state.target_um)
        after = jnp.linalg.norm(scene_state.physics.pose[0, :2] - state.target_um)
        failed = events.failed  # the bead left its trap or touched a wall
        success = (after < config.target_radius_um) & ~failed
        terminated = success | failed
        truncated = (new.steps >= config.max_steps) & ~terminated
        reward = (before - after) - 0.05 + 10.0 * success - 10.0 * failed  # um gained, time, outcome
        info = {"success": success, "failed": failed, "distance_um": after}
        return self._observe(new, params), new, reward.astype(jnp.float32), terminated, truncated, info

    def _observe(self, state: PushBeadState, params: PushBeadParams):
        """Bead-to-target (over 10 um), bead-to-trap (um) and the time used (over max_steps)."""
        physics = state.scene.physics
        bead = physics.pose[0, :2]
        return jnp.concatenate(
            [
                (state.target_um - bead) / 10.0,
                physics.trap_xy_um[0] - bead,
                (state.steps / params.config.max_steps)[None],
            ]
        ).astype(jnp.float32)

    def observation_size(self, params: PushBeadParams) -> int:
        return 5

    def action_space(self, params: PushBeadParams) -> gym.spaces.Discrete:
        return gym.spaces.Discrete(len(MOVES))

    def frame(self, state: PushBeadState, params: PushBeadParams, size_px=(600, 400)) -> np.ndarray:
        """The chip, the bead in its trap and a line from the bead to a cross on the target."""
        bead = np.asarray(state.scene.physics.pose[0, :2])
        target = np.asarray(state.target_um)
        r = params.config.target_radius_um
        cross = [target + (r, 0), target - (r, 0), target, target + (0, r), target - (0, r)]
        return scene_frame(params.scene, state.scene.physics, np.stack([bead, target, *cross]), size_px)

    def device_action(self, velocity_um_s, params: PushBeadParams) -> np.ndarray:
        """Hold below the dead band; else the move closest to the device's direction."""
        velocity = np.asarray(velocity_um_s, np.float32)
        if np.hypot(*velocity) < params.config.device_dead_band_um_s:
            return np.asarray(0, np.int32)
        return np.asarray(int(np.argmax(MOVES @ velocity)), np.int32)
