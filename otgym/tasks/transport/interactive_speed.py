"""Task ``interactive-speed``: the interactive task (paper section III-C) in autonomous
mode, where an agent picks the route follower's cruise speed, as a pure, jittable
``Task``: what the learned-speed navigator ``rl`` (``otgym.autonomy.rl_navigator``) is
trained on by the one DQN trainer (``otgym train --task interactive-speed``).

One ``step`` is one decision: the action picks a speed of ``SPEEDS_UM_S`` and the
route follower (``otgym.tasks.transport.route_follow``) then carries the formation for
``DECISION_S`` (25 ticks of 50 Hz, each the interactive task's tick,
``otgym.tasks.transport.interactive.advance``), with the phases of the real-time task
(approach and grip, carry, done; a detachment sends the cell back to approach). The
observation is ``speed_features`` (``otgym.tasks.transport.speed_features``) after the
tick of the decision, with the obstacle tracker's 1 s least-squares fit of what the
ticks showed, as the navigator computes them in the window.

Each episode draws one scenario from a pool of ``n_scenarios`` seeded scenarios from
``scenario_base`` (``otgym.tasks.transport.scenario``, made once by ``make_params``).

Reward per decision, like the paper's speed control (progress, time, failure):
``progress_reward_per_um`` times the cell's progress along the route, minus
``time_cost``, minus ``collision_cost`` per obstacle that touches the assembly for the
first time, ``detach_cost`` per detachment and ``loss_cost`` for a lost trap. The
episode terminates once the cell is past ``finish_fraction`` of the route (the
scenarios' crossings lie within 0.35-0.65 of it, so the rest holds no decision worth
learning), at the goal or on a lost trap; it is truncated at the time limit.
"""

from __future__ import annotations

import dataclasses
import functools

import gymnasium as gym
import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from otgym.sim import scene as sc
from otgym.tasks.base import Task, TaskScene
from otgym.tasks.scene_frame import scene_frame, scene_of
from otgym.tasks.transport import interactive as core
from otgym.tasks.transport import speed_features as sf
from otgym.tasks.transport.route_follow import APPROACH, CARRY, DONE, RouteFollow
from otgym.tasks.transport.scenario import make_scenario, stack_tracks

ROUTE_SEARCH_POINTS = (-40, 400)
"""The cell's route point is searched in this window of points around the last one."""


@dataclasses.dataclass(frozen=True)
class SpeedTaskConfig:
    interactive: core.InteractiveConfig = dataclasses.field(
        default_factory=lambda: core.InteractiveConfig(time_limit_s=90.0)
    )
    scenario_base: int = 962_000
    n_scenarios: int = 64
    progress_reward_per_um: float = 0.1
    time_cost: float = 0.1
    collision_cost: float = 20.0
    detach_cost: float = 2.0
    loss_cost: float = 10.0
    finish_fraction: float = 0.75

    def __post_init__(self):
        if not isinstance(self.n_scenarios, int) or self.n_scenarios < 1:
            raise ValueError(f"n_scenarios must be a positive integer, got {self.n_scenarios!r}")
        if not 0 < self.finish_fraction <= 1:
            raise ValueError(f"finish_fraction must be in (0, 1], got {self.finish_fraction!r}")

    @property
    def decision_ticks(self) -> int:
        return max(1, int(round(sf.DECISION_S / self.interactive.tick_s)))

    @property
    def max_steps(self) -> int:
        return int(np.ceil(self.interactive.time_limit_s / sf.DECISION_S))


PRESETS = {"default": SpeedTaskConfig(), "train": SpeedTaskConfig(n_scenarios=640)}
"""``default``: 64 scenarios; ``train``: the 640 the shipped policy was trained on."""


@struct.dataclass
class SpeedTaskParams:
    scene: sc.Scene
    route_um: jnp.ndarray  # (M, 2)
    route_arc_um: jnp.ndarray  # (M,)
    tangents: jnp.ndarray  # (M, 2)
    offsets_um: jnp.ndarray  # (T, 2)
    trap_robot: jnp.ndarray  # (T,) the robot each trap holds
    heading_rad: jnp.ndarray
    tracks: dict  # the scenario pool's tracks, (N, K, ...)
    config: SpeedTaskConfig = struct.field(pytree_node=False)


@struct.dataclass
class SpeedTaskState:
    scene: sc.SceneState
    tracks: dict  # this episode's scenario, (K, ...) per environment
    phase: jnp.ndarray
    route_index: jnp.ndarray
    measured: dict  # the last tick's ``core.measure``, minus the spheres
    commanded_arc_um: jnp.ndarray
    speed_um_s: jnp.ndarray
    seen_times_s: jnp.ndarray  # (W,) the tracker's ring buffer
    seen_xy_um: jnp.ndarray  # (W, K, 2)
    seen_count: jnp.ndarray
    seen_moving: jnp.ndarray  # (K,)
    collided: jnp.ndarray  # (K,)
    detachments: jnp.ndarray
    lost: jnp.ndarray
    steps: jnp.ndarray


def make_params(config: SpeedTaskConfig) -> SpeedTaskParams:
    """The interactive task's scene and route (``core.make_params``) and the scenario pool."""
    base = core.make_params(config.interactive)
    route_um, route_arc_um = base.route_um, base.route_arc_um
    scenarios = [
        make_scenario(
            config.scenario_base + i,
            route_um,
            route_arc_um,
            functools.partial(core.wall_distance_um, base.scene),
            config.interactive.scene.obstacle_radius_um,
            config.interactive.scenario,
        )
        for i in range(config.n_scenarios)
    ]
    f32 = lambda a: jnp.asarray(a, jnp.float32)  # noqa: E731
    return SpeedTaskParams(
        base.scene,
        f32(route_um),
        f32(route_arc_um),
        f32(sf.route_tangents(route_um)),
        f32(base.offsets_um),
        jnp.asarray(base.trap_robot),
        f32(base.heading_rad),
        stack_tracks(scenarios),
        config,
    )


def _follow(params: SpeedTaskParams) -> RouteFollow:
    return RouteFollow(params.route_um, params.route_arc_um, params.offsets_um, params.config.interactive.tick_s)


def _route_index(params, cell_xy_um, previous):
    window = jnp.clip(previous[:, None] + jnp.arange(*ROUTE_SEARCH_POINTS)[None], 0, params.route_um.shape[0] - 1)
    distance = jnp.linalg.norm(params.route_um[window] - cell_xy_um[:, None], axis=-1)
    return jnp.take_along_axis(window, jnp.argmin(distance, axis=1)[:, None], axis=1)[:, 0]


def _observe_obstacles(state: SpeedTaskState) -> SpeedTaskState:
    """The tracker takes the last tick's obstacle positions (``ObstacleTracker.observe``)."""
    rows = jnp.arange(state.seen_count.shape[0])
    slot = state.seen_count % state.seen_times_s.shape[1]
    times = state.seen_times_s.at[rows, slot].set(state.scene.time_s)
    xy = state.seen_xy_um.at[rows, slot].set(state.measured["obstacle_xy_um"])
    count = state.seen_count + 1
    speed = jnp.linalg.norm(sf.tracked_velocity_um_s(times, xy, count, jnp), axis=-1)
    full = (count >= times.shape[1])[:, None]
    moving = state.seen_moving | (full & (speed > sf.MOVING_SPEED_UM_S))
    return state.replace(seen_times_s=times, seen_xy_um=xy, seen_count=count, seen_moving=moving)


def _cell_arc(params, state):
    return params.route_arc_um[state.route_index]


def features(params: SpeedTaskParams, state: SpeedTaskState) -> jnp.ndarray:
    """The policy's observation (E, ``N_FEATURES``) (``speed_features``)."""
    measured = state.measured
    return sf.speed_features(
        params.route_um,
        params.route_arc_um,
        params.tangents,
        _cell_arc(params, state),
        measured["obstacle_xy_um"],
        sf.tracked_velocity_um_s(state.seen_times_s, state.seen_xy_um, state.seen_count, jnp),
        measured["obstacle_gap_um"],
        ~state.seen_moving,
        state.speed_um_s,
        measured["trap_distance_um"].max(axis=1) / params.config.interactive.scene.trap_law.escape_distance,
        state.phase == CARRY,
        jnp,
    )


def _measured(full: dict) -> dict:
    return {name: value for name, value in full.items() if name != "sphere_xy_um"}


def reset_batch(key, params: SpeedTaskParams, n_envs: int):
    """E environments, each on a scenario drawn from the pool: the cell at the route's
    start, the robots ``approach_gap_um`` out from their grip (``InteractiveTask.reset``)."""
    config = params.config.interactive
    pick_key, scene_key = jax.random.split(key)
    chosen = jax.random.randint(pick_key, (n_envs,), 0, params.config.n_scenarios)
    tracks = jax.tree.map(lambda a: a[chosen], params.tracks)
    heading = params.heading_rad
    scene_state = jax.vmap(sc.reset_at, in_axes=(None, 0, None, None))(
        params.scene, jax.random.split(scene_key, n_envs), params.route_um[0], heading
    )
    normal = jnp.stack([-jnp.sin(heading), jnp.cos(heading)])
    robots = list(params.scene.robots)
    pose, traps = scene_state.physics.pose, scene_state.physics.trap_xy_um
    for robot, sign in zip(robots, (-1.0, 1.0)):
        shift = sign * config.approach_gap_um * normal
        pose = pose.at[:, robot, :2].add(shift)
        traps = jnp.where((params.trap_robot == robot)[None, :, None], traps + shift, traps)
    pose = pose.at[:, np.asarray(params.scene.obstacles), :2].set(tracks["start_um"])
    scene_state = scene_state.replace(
        physics=scene_state.physics.replace(pose=pose, trap_xy_um=traps),
        obstacle_propulsion_um_s=jnp.zeros_like(scene_state.obstacle_propulsion_um_s),
    )
    measured = _measured(core.measure(params.scene, scene_state, config))
    n_obstacles = len(params.scene.obstacles)
    window = int(round(sf.TRACKER_WINDOW_S / config.tick_s)) + 1
    zeros = lambda *shape, dtype=jnp.float32: jnp.zeros((n_envs, *shape), dtype)  # noqa: E731
    state = SpeedTaskState(
        scene_state,
        tracks,
        zeros(dtype=jnp.int32) + APPROACH,
        _route_index(params, measured["cell_xy_um"], zeros(dtype=jnp.int32)),
        measured,
        zeros(),
        zeros(),
        zeros(window),
        zeros(window, n_obstacles, 2),
        zeros(dtype=jnp.int32),
        zeros(n_obstacles, dtype=bool),
        zeros(n_obstacles, dtype=bool),
        zeros(dtype=jnp.int32),
        zeros(dtype=bool),
        zeros(dtype=jnp.int32),
    )
    state = _observe_obstacles(state)
    return features(params, state), state


def _tick(params: SpeedTaskParams, state: SpeedTaskState, key) -> SpeedTaskState:
    """One 50 Hz tick: the follower's dP_r, the physics, then the phases and tallies of
    ``InteractiveTask._account`` and the tracker's observation."""
    config = params.config.interactive
    measured = state.measured
    done_before = state.phase == DONE
    increment, commanded = _follow(params).increments(
        state.commanded_arc_um,
        state.speed_um_s,
        state.phase,
        _cell_arc(params, state),
        measured["cell_xy_um"],
        measured["trap_xy_um"],
        jnp,
    )
    increment = jnp.where(done_before[:, None, None], 0.0, increment)
    scene_state, new = core.advance(params.scene, state.scene, increment, key, state.tracks, config)
    new = _measured(new)
    route_index = _route_index(params, new["cell_xy_um"], state.route_index)
    active = ~done_before
    gripped = jnp.all(new["cell_gap_um"] < config.grip_gap_um, axis=1)
    detached = jnp.any(new["cell_gap_um"] > config.scene.detach_distance_um, axis=1)
    lost = jnp.any(new["trap_distance_um"] > config.scene.trap_law.escape_distance, axis=1)
    phase = state.phase
    detaching = active & (phase == CARRY) & detached
    phase = jnp.where(detaching, APPROACH, phase)
    phase = jnp.where(active & (phase == APPROACH) & gripped, CARRY, phase)
    touched = (new["obstacle_gap_um"] <= 0.0) | new["obstacle_touched"]
    at_goal = (phase == CARRY) & (
        jnp.linalg.norm(new["cell_xy_um"] - params.route_um[-1], axis=1) <= config.goal_tolerance_um
    )
    timeout = scene_state.time_s >= config.time_limit_s - 0.5 * config.tick_s
    phase = jnp.where(active & (at_goal | lost | timeout), DONE, phase)
    state = state.replace(
        scene=scene_state,
        phase=phase,
        route_index=route_index,
        measured=new,
        commanded_arc_um=commanded,
        collided=state.collided | (active[:, None] & touched),
        detachments=state.detachments + (detaching).astype(jnp.int32),
        lost=state.lost | (active & lost),
    )
    return _observe_obstacles(state)


def _ended(params, state):
    """(terminated, ended) per environment: past the finish, at the goal or a trap lost;
    or else done (the time limit)."""
    config = params.config.interactive
    finish = params.config.finish_fraction * params.route_arc_um[-1]
    timed_out = state.scene.time_s >= config.time_limit_s - 0.5 * config.tick_s  # as _tick's timeout
    terminated = state.lost | (_cell_arc(params, state) >= finish) | ((state.phase == DONE) & ~timed_out)
    return terminated, terminated | (state.phase == DONE)


def step_batch(key, state: SpeedTaskState, action, params: SpeedTaskParams):
    """One decision of E environments: speed ``action`` (E,) for ``decision_ticks`` ticks.
    Ticks after an environment's episode ended move nothing and count nothing."""
    config = params.config
    speeds = jnp.asarray(sf.SPEEDS_UM_S, jnp.float32)
    state = state.replace(speed_um_s=speeds[jnp.clip(jnp.asarray(action, jnp.int32), 0, len(sf.SPEEDS_UM_S) - 1)])
    start_arc, start_hits, start_detach = _cell_arc(params, state), state.collided.sum(axis=1), state.detachments

    def tick(state, tick_key):
        _, ended_before = _ended(params, state)
        frozen = state.replace(phase=jnp.where(ended_before, DONE, state.phase))
        ticked = _tick(params, frozen, tick_key)
        keep = lambda old, new: jnp.where(  # noqa: E731
            ended_before.reshape(ended_before.shape + (1,) * (new.ndim - 1)), old, new
        )
        # an ended environment keeps its tallies and phase; its physics may run on, unused
        return ticked.replace(
            phase=keep(state.phase, ticked.phase),
            route_index=keep(state.route_index, ticked.route_index),
            collided=keep(state.collided, ticked.collided),
            detachments=keep(state.detachments, ticked.detachments),
            lost=keep(state.lost, ticked.lost),
            measured=jax.tree.map(keep, state.measured, ticked.measured),
        ), None

    state, _ = jax.lax.scan(tick, state, jax.random.split(key, config.decision_ticks))
    state = state.replace(steps=state.steps + 1)
    terminated, ended = _ended(params, state)
    new_hits = state.collided.sum(axis=1) - start_hits
    reward = (
        config.progress_reward_per_um * (_cell_arc(params, state) - start_arc)
        - config.time_cost
        - config.collision_cost * new_hits
        - config.detach_cost * (state.detachments - start_detach)
        - config.loss_cost * state.lost
    )
    truncated = ~terminated & (ended | (state.steps >= config.max_steps))
    info = {
        "success": terminated & ~state.lost,
        "collisions": new_hits,
        "trap_lost": state.lost,
        "cell_arc_um": _cell_arc(params, state),
    }
    return features(params, state), state, reward.astype(jnp.float32), terminated, truncated, info


class InteractiveSpeed(Task):
    """The learned-speed navigator's task (module docstring)."""

    name = "interactive-speed"

    def presets(self) -> tuple[str, ...]:
        return tuple(PRESETS)

    def default_config(self) -> SpeedTaskConfig:
        return PRESETS["default"]

    def config(self, preset: str | None = None) -> SpeedTaskConfig:
        super().config(preset)
        return PRESETS[preset or "default"]

    def make_params(self, config: SpeedTaskConfig) -> SpeedTaskParams:
        return make_params(config)

    def max_steps(self, params) -> int:
        return params.config.max_steps

    def control_period_s(self, params) -> float:
        return sf.DECISION_S

    def reset_batch(self, key, params, n_envs: int):
        return reset_batch(key, params, n_envs)

    def step_batch(self, key, state, action, params):
        return step_batch(key, state, action, params)

    def observation_size(self, params) -> int:
        return sf.N_FEATURES

    def action_space(self, params) -> gym.spaces.Discrete:
        return gym.spaces.Discrete(len(sf.SPEEDS_UM_S))

    def policy_shape(self, config) -> tuple[int, int]:
        return sf.N_FEATURES, len(sf.SPEEDS_UM_S)

    def policy_meta(self, params) -> dict:
        """What ``otgym.autonomy.rl_navigator.load_speed_policy`` reads."""
        return {"speeds_um_s": list(sf.SPEEDS_UM_S), "decision_s": sf.DECISION_S}

    def dqn_config(self, config) -> dict:
        """64 environments for 1,000 decisions each (about 640 episodes: 10 % more than
        the pool's scenarios), a 64-64 network, 32 Adam steps per decision of the batch
        (about one per two transitions), exploration falling to 2 % over 60 % of the
        training and held for up to 4 s (8 decisions) so that waiting is tried."""
        return {
            "n_envs": 64,
            "total_env_steps": 64_000,
            "chunk_iters": 50,
            "gamma": 0.98,
            "eps_end": 0.02,
            "eps_fraction": 0.6,
            "target_every": 8,
            "learning_starts": 4096,
            "updates_per_iter": 32,
            "hidden": (64, 64),
            "explore_hold_max": 8,
        }

    def device_action(self, velocity_um_s, params) -> np.ndarray:
        """The speed nearest the device's speed (its direction is the route's)."""
        wanted = float(np.hypot(*np.asarray(velocity_um_s, float)))
        return np.asarray(int(np.argmin(np.abs(np.asarray(sf.SPEEDS_UM_S) - wanted))), np.int32)

    def frame(self, state, params, size_px=(600, 400)) -> np.ndarray:
        return scene_frame(params.scene, state.scene.physics, params.route_um, size_px)

    def scene(self, state, params) -> TaskScene:
        """The robots, the cell, the obstacles and the traps, and the planned route."""
        return scene_of(params.scene, state.scene.physics, lines_um=[np.asarray(params.route_um)])
