"""The model-predictive navigator: dP_r of the interactive task from
``otgym.autonomy.mpc``, with the route navigator's interface (``reset(n_env)``,
``increments(observation)``), so that trials and shared control take either.

Per tick, from the task's ``Observation`` only:
* obstacles' observed positions go into the tracker (``ObstacleTracker``), whose
  constant-velocity fit predicts them in the model;
* APPROACH: the route navigator's chase grips the cell (the MPC plans the carry);
* CARRY: every ``step_s`` (5 ticks of 20 ms) a replan starts from the scene state
  rebuilt from the observation (``model_state``: robots' poses from their handles,
  the cell and obstacles where they are seen, model traps where the traps are, moved
  towards the cell by the model's extra grip squeeze, ``mpc.grip_squeeze_um``). The plan chosen becomes the segment executed from the next replan
  tick on; until then the robots execute the segment the previous replan chose (the
  first replan after the grip holds still for one step). Within a segment the
  formation's pose (arc, lateral offset, rotation) is interpolated linearly from
  where it was observed at the segment's start to the segment's end, and each trap
  moves by its place's motion plus ``carry_gain_per_s`` times its offset from its
  place, as the route navigator does, capped at the trap-speed limit.

Replans are batched over the environments that carry, in chunks of ``chunk_envs``
environments (one compiled shape; large batches of rollouts ran slower per step on
this CPU). ``replan_seconds`` keeps each replan's wall time.
"""

from __future__ import annotations

import time

import jax
import jax.numpy as jnp
import numpy as np

from otgym import physics as ph
from otgym.autonomy.grip_calibration import grip_squeeze_um, squeezed_offsets_um
from otgym.autonomy.mpc import MPCConfig, MPCCosts, cap_rigid, make_replan, model_scene_config
from otgym.autonomy.navigator import RouteNavigator, cap_speed
from otgym.autonomy.obstacle_prediction import ObstacleTracker
from otgym.autonomy.route_frame import clip_lateral, formation_places, formation_pose, route_data
from otgym.sim import scene as sc
from otgym.task.task import CARRY, InteractiveTask, Observation
from otgym.tasks.transport.scenario import Scenario

TRACKER_WINDOW_S = 1.0


class MPCNavigator:
    def __init__(
        self,
        task: InteractiveTask,
        config: MPCConfig = MPCConfig(),
        costs: MPCCosts = MPCCosts(),
        seed: int = 0,
        chunk_envs: int = 8,
        max_speed_um_s: float = 20.0,
        carry_gain_per_s: float = 3.0,
    ):
        ticks = config.step_s / task.config.tick_s
        if abs(ticks - round(ticks)) > 1e-6 or round(ticks) < 1:
            raise ValueError(
                f"step_s={config.step_s} must be a whole number of the task's {task.config.tick_s} s ticks"
            )
        if not (isinstance(chunk_envs, int) and chunk_envs >= 1):
            raise ValueError(f"chunk_envs must be a positive integer, got {chunk_envs!r}")
        self.task, self.config, self.costs, self.seed = task, config, costs, seed
        self.ticks_per_step = int(round(ticks))
        self.chunk_envs = chunk_envs
        self.max_speed_um_s = max_speed_um_s
        self.carry_gain_per_s = carry_gain_per_s
        self.model = sc.build_scene(model_scene_config(task.config.scene, config))
        self.route = route_data(
            task.route_um,
            task.route_arc_um,
            task.wall_distance_um,
            task.scene.assembly_radius_um + config.room_margin_um,
        )
        self.offsets_um = jnp.asarray(task.offsets_um, jnp.float32)
        start = task.route_um[0]
        heading = float(np.arctan2(*(task.route_um[8] - task.route_um[0])[::-1]))
        self.extra_squeeze_um = grip_squeeze_um(task.scene, self.model, start, heading)
        self.model_offsets_um = jnp.asarray(squeezed_offsets_um(task.offsets_um, self.extra_squeeze_um), jnp.float32)
        self.approach = RouteNavigator(
            task.route_um, task.route_arc_um, task.offsets_um, task.config.tick_s, max_speed_um_s=max_speed_um_s
        )
        self.tracker = ObstacleTracker(TRACKER_WINDOW_S, task.config.tick_s)
        self._replan = make_replan(config, task.config.scenario)
        self._pose = _pose
        self._places = _places
        model = self.model.model
        self._handle_offsets_um = np.asarray(model.sphere_offset_um, float)[np.asarray(model.trap_sphere, int)]
        self.replan_seconds: list[float] = []
        self.replan_sizes: list[int] = []
        self.reset(0)

    def reset(self, n_env: int) -> None:
        plan_steps = self.config.plan_steps
        self.tick_index = 0
        self.replans = 0
        self.approach.reset(n_env)
        self.tracker.reset(n_env, len(self.task.scene.obstacles))
        self.next_plan = np.zeros((n_env, plan_steps, 3), np.float32)
        self.next_valid = np.zeros(n_env, bool)
        self.segment_start = np.zeros((n_env, 3), np.float32)
        self.segment_action = np.zeros((n_env, 3), np.float32)
        self.segment_valid = np.zeros(n_env, bool)
        self.steps_since_sampling = np.zeros(n_env, int)

    @classmethod
    def for_task(
        cls,
        task: InteractiveTask,
        max_speed_um_s: float = 20.0,
        config: MPCConfig = MPCConfig(),
        costs: MPCCosts = MPCCosts(),
        seed: int = 0,
        **options,
    ) -> MPCNavigator:
        """The navigator on ``task`` (what every registered navigator offers), with its own
        configuration: ``config``, ``costs``, the ``seed`` of its sampled rollouts and
        any other keyword of the constructor (``chunk_envs``, ``carry_gain_per_s``)."""
        return cls(task, config, costs, seed=seed, max_speed_um_s=max_speed_um_s, **options)

    def stats(self) -> dict:
        """Its replans so far: ``replans`` (count), ``replan_seconds`` (the wall time of
        each) and ``environments_planned`` (the environments of each)."""
        return {
            "replans": len(self.replan_seconds),
            "replan_seconds": list(self.replan_seconds),
            "environments_planned": list(self.replan_sizes),
        }

    def warm_up(self) -> None:
        """Compile the replan and the plan-following functions for one environment, then
        reset: the first replan compiles for tens of seconds on 2 cores, which a live
        trial (an autonomy node answering a simulator) must not wait for."""
        k = len(self.task.scene.obstacles)  # obstacles parked at the route's end: no scenario to sample
        parked = Scenario(
            0,
            np.zeros(k),
            np.zeros(k),
            np.tile(self.task.route_um[-1], (k, 1)),
            np.tile([1.0, 0.0], (k, 1)),
            np.ones(k),
            np.full(k, np.inf),
            np.full(k, np.inf),
        )
        observation = self.task.reset([parked], jax.random.PRNGKey(0)).observation
        fields = dict(vars(observation), phase=np.full(1, CARRY))
        self.reset(1)
        for _ in range(2):  # a replan tick, then a tick that follows the plan
            self.increments(Observation(**fields))
        self.reset(1)

    def model_state(self, obs: Observation) -> sc.SceneState:
        """The model's scene state (E) rebuilt from an observation: each robot's pose
        from its two handles (the body-frame offsets of its handle spheres), the cell
        and obstacles at their observed centres, the traps where they are, moved towards
        the cell by the model's extra grip squeeze, time as observed."""
        scene = self.model
        n_env = len(obs.time_s)
        pose = np.zeros((n_env, scene.model.n_bodies, 3))
        trap_robot = self.task.trap_robot
        for robot in scene.robots:
            handles = obs.handle_xy_um[:, trap_robot == robot]  # (E, 2, 2)
            offsets = self._handle_offsets_um[trap_robot == robot]  # (2, 2)
            seen, body = handles[:, 1] - handles[:, 0], offsets[1] - offsets[0]
            theta = np.arctan2(seen[:, 1], seen[:, 0]) - np.arctan2(body[1], body[0])
            mean_offset = offsets.mean(axis=0)
            turned = np.stack(
                [
                    np.cos(theta) * mean_offset[0] - np.sin(theta) * mean_offset[1],
                    np.sin(theta) * mean_offset[0] + np.cos(theta) * mean_offset[1],
                ],
                axis=-1,
            )
            pose[:, robot, :2] = handles.mean(axis=1) - turned
            pose[:, robot, 2] = theta
        pose[:, scene.payload, :2] = obs.cell_xy_um
        pose[:, np.asarray(scene.obstacles, int), :2] = obs.obstacle_xy_um
        towards_cell = obs.cell_xy_um[:, None] - pose[:, np.asarray(scene.robots), :2]  # (E, R, 2)
        towards_cell /= np.maximum(np.linalg.norm(towards_cell, axis=-1, keepdims=True), 1e-9)
        traps = obs.trap_xy_um + self.extra_squeeze_um * towards_cell[:, trap_robot]
        f32 = lambda a: jnp.asarray(a, jnp.float32)  # noqa: E731
        return sc.SceneState(
            ph.PhysicsState(f32(pose), f32(traps)),
            jnp.zeros((n_env, len(scene.obstacles), 2), jnp.float32),
            f32(obs.time_s),
        )

    def increments(self, obs: Observation) -> np.ndarray:
        """dP_r (E, T, 2) in um for this tick."""
        self.tracker.observe(obs.time_s, obs.obstacle_xy_um)
        chase = self.approach.increments(obs)
        phase_tick = self.tick_index % self.ticks_per_step
        if phase_tick == 0:
            self._start_segments(obs)
        self.tick_index += 1
        carrying = obs.phase == CARRY
        self.segment_valid &= carrying
        step = np.zeros_like(chase)
        if self.segment_valid.any():
            rows = np.flatnonzero(self.segment_valid)
            low = phase_tick / self.ticks_per_step
            places_now, places_next = (
                np.asarray(a, float)
                for a in self._places(
                    self.route,
                    self.offsets_um,
                    jnp.asarray(self.segment_start[rows]),
                    jnp.asarray(self.segment_action[rows]),
                    low,
                    low + 1.0 / self.ticks_per_step,
                    step_s=self.config.step_s,
                )
            )
            correction = self.carry_gain_per_s * self.task.config.tick_s * (places_now - obs.trap_xy_um[rows])
            step[rows] = np.asarray(
                cap_rigid(places_next - places_now + correction, self.max_speed_um_s * self.task.config.tick_s)
            )
        return np.where(carrying[:, None, None], step, cap_speed(chase, self.max_speed_um_s * self.task.config.tick_s))

    def _start_segments(self, obs: Observation) -> None:
        """At a replan tick: the segment to execute now (the last replan's first step,
        or hold), and a replan for the next one."""
        carrying = obs.phase == CARRY
        self.next_valid &= carrying
        if not carrying.any():
            self.segment_valid[:] = False
            return
        rows = np.flatnonzero(carrying)
        start = np.stack(
            [
                np.asarray(a, np.float32)
                for a in self._pose(
                    self.route,
                    self.offsets_um,
                    jnp.asarray(obs.trap_xy_um[rows], jnp.float32),
                    jnp.asarray(obs.cell_arc_um[rows], jnp.float32),
                )
            ],
            axis=-1,
        )
        planned = self.next_valid[rows]
        hold = np.stack([np.zeros(len(rows)), start[:, 1], start[:, 2]], axis=-1)
        committed = np.where(planned[:, None], self.next_plan[rows, 0], hold).astype(np.float32)
        first_plan = np.zeros((len(rows), self.config.plan_steps, 3), np.float32)
        first_plan[..., 0] = self.config.cruise_speed_um_s
        shifted = np.concatenate([self.next_plan[rows, 1:], self.next_plan[rows, -1:]], axis=1)
        nominal = np.where(planned[:, None, None], shifted, first_plan).astype(np.float32)
        self.segment_start[rows], self.segment_action[rows] = start, committed
        self.segment_valid = carrying.copy()
        self.steps_since_sampling[~carrying] = 0
        self.steps_since_sampling[rows] += 1
        near = obs.nearest_obstacle_gap_um[rows] < self.config.far_gap_um
        sample = ~planned | near | (self.steps_since_sampling[rows] >= self.config.far_replan_steps)
        self.next_plan[rows] = nominal
        if sample.any():
            chosen = rows[sample]
            self.next_plan[chosen] = self._plan(obs, chosen, start[sample], committed[sample], nominal[sample])
            self.steps_since_sampling[chosen] = 0
        self.next_valid = carrying.copy()

    def _plan(self, obs: Observation, rows, start, committed, nominal) -> np.ndarray:
        """Replan the environments ``rows`` in chunks of ``chunk_envs`` (padded with the first row)."""
        began = time.perf_counter()
        chunk = min(self.chunk_envs, len(self.next_plan))
        padded = np.concatenate([np.arange(len(rows)), np.zeros((-len(rows)) % chunk, int)])
        subset = observation_rows(obs, rows[padded])
        state = self.model_state(subset)
        tracks = self.tracker.predicted_tracks(obs.time_s)
        tracks = {name: value[rows[padded]] for name, value in tracks.items()}
        key = jax.random.fold_in(jax.random.PRNGKey(self.seed), self.replans)
        self.replans += 1
        plans = []
        for index, begin in enumerate(range(0, len(padded), chunk)):
            part = slice(begin, begin + chunk)
            f32 = lambda a: jnp.asarray(np.asarray(a)[part], jnp.float32)  # noqa: E731
            plan, _, _, _ = self._replan(
                self.model,
                self.route,
                self.model_offsets_um,
                self.costs,
                jax.tree.map(lambda a: a[part], state),
                jax.tree.map(f32, tracks),
                f32(start[padded]),
                f32(committed[padded]),
                f32(nominal[padded]),
                jax.random.fold_in(key, index),
            )
            plans.append(np.asarray(plan))
        self.replan_seconds.append(time.perf_counter() - began)
        self.replan_sizes.append(len(rows))
        return np.concatenate(plans)[: len(rows)]


def _segment_places(route, offsets_um, start, action, low, high, *, step_s: float):
    """Trap places (E, T, 2) at fractions ``low`` and ``high`` of a segment that goes
    from the pose ``start`` (E, 3) with ``action`` (E, 3) for ``step_s``."""
    end_arc = jnp.clip(start[:, 0] + action[:, 0] * step_s, 0.0, route.path.length_um)
    end_lateral = clip_lateral(route, end_arc, action[:, 1])

    def at(fraction):
        arc = start[:, 0] + (end_arc - start[:, 0]) * fraction
        lateral = start[:, 1] + (end_lateral - start[:, 1]) * fraction
        rotation = start[:, 2] + (action[:, 2] - start[:, 2]) * fraction
        return formation_places(route, offsets_um, arc, lateral, rotation)

    return at(low), at(high)


_pose = jax.jit(formation_pose)  # shared by every navigator: one compilation per shape
_places = jax.jit(_segment_places, static_argnames=("step_s",))


def observation_rows(obs: Observation, rows) -> Observation:
    """The observation of the environments ``rows`` only."""
    fields = {name: (value[rows] if isinstance(value, np.ndarray) else value) for name, value in vars(obs).items()}
    return Observation(**fields)
