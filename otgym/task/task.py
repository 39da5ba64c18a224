"""The interactive task's host wrapper (paper section III-C): two trapped microrobots
approach and grip a cell, then carry it along the planned route to the destination
past dynamic obstacles that cross the route, stepped at a fixed control rate (50 Hz),
so that one environment can run in real time and many run batched for experiments.
The physics, the route and the tick are the functional core
``otgym.tasks.transport.interactive``; this wrapper takes and gives numpy, keeps each
environment's phase and its trial's tallies (float64) and the scenarios.

The robots start ``approach_gap_um`` farther from the cell than their grip; the
cell, free until gripped, drifts with the flow.

Phases per environment: APPROACH (until both grippers are within ``grip_gap_um`` of
the cell's surface), CARRY (the cell detaching sends it back to APPROACH and counts a
detachment), DONE (the cell within ``goal_tolerance_um`` of the route's end; or a trap
lost; or the time limit). Per trial (``TrialMetrics``): completion time, obstacles
encountered (gap to the assembly below ``encounter_gap_um`` at some time) and avoided
(encountered and never touched), collisions, trap losses, detachments, goal reached,
peak robot-cell contact force, and time in each control band of alpha.
"""

from __future__ import annotations

import dataclasses
import functools

import jax
import jax.numpy as jnp
import numpy as np

from otgym.physics import light_dose as ld
from otgym.sim import scene as sc
from otgym.tasks.transport import interactive as core
from otgym.tasks.transport.interactive import InteractiveConfig
from otgym.tasks.transport.route_follow import APPROACH, CARRY, DONE
from otgym.tasks.transport.scenario import Scenario, make_scenario, stack_tracks

ALPHA_BANDS = (("autonomous", 0.0, 0.2), ("balanced", 0.2, 0.4), ("fine_tune", 0.4, 1.0 + 1e-9))
"""The paper's three operation modes of shared control by the human's share alpha
(alpha 0.1 far from obstacles, 0.5 near them); manual control counts as fine-tuning."""
FINE_TUNE_ALPHA = dict((name, low) for name, low, _ in ALPHA_BANDS)["fine_tune"]
"""0.4: where the paper's fine-tuning band of alpha begins. The one threshold of the
fine-tune cue: the window shows its prompt from here (``otgym.ui.cues``) and the simulated
participants take over from here (``otgym.human.participants``; they act on the cue the
window shows, an assumption about people, not a measurement)."""
ROUTE_SEARCH_POINTS = (-40, 400)


@dataclasses.dataclass
class Observation:
    """What a tick shows (numpy, leading environment axis E)."""

    time_s: np.ndarray  # (E,)
    phase: np.ndarray  # (E,) APPROACH, CARRY or DONE
    cell_xy_um: np.ndarray  # (E, 2)
    cell_arc_um: np.ndarray  # (E,) the cell's progress along the route
    trap_xy_um: np.ndarray  # (E, T, 2)
    handle_xy_um: np.ndarray  # (E, T, 2)
    robot_xy_um: np.ndarray  # (E, R, 2)
    obstacle_xy_um: np.ndarray  # (E, K, 2)
    obstacle_gap_um: np.ndarray  # (E, K) gap between each obstacle and the assembly's spheres
    contact_force_pn: np.ndarray  # (E, R) robot-cell contact force
    cell_gap_um: np.ndarray  # (E, R) gripper-to-cell surface gap
    trap_distance_um: np.ndarray  # (E, T)
    obstacle_touched: np.ndarray | None = None  # (E, K) an obstacle touched the assembly during the tick

    @property
    def nearest_obstacle_gap_um(self) -> np.ndarray:
        return self.obstacle_gap_um.min(axis=1) if self.obstacle_gap_um.shape[1] else np.full(len(self.time_s), np.inf)


@dataclasses.dataclass
class TrialMetrics:
    """Per-environment results, accumulated tick by tick."""

    done: np.ndarray
    reached_goal: np.ndarray
    completion_time_s: np.ndarray
    grip_time_s: np.ndarray
    encountered: np.ndarray  # (E, K)
    collided: np.ndarray  # (E, K)
    trap_losses: np.ndarray
    detachments: np.ndarray
    peak_contact_force_pn: np.ndarray
    band_time_s: np.ndarray  # (E, 3) time in ALPHA_BANDS
    light_dose_mj_per_um2: np.ndarray  # (E,) the cell's light dose (``otgym.physics.light_dose``)

    @classmethod
    def empty(cls, n_env: int, n_obstacles: int) -> TrialMetrics:
        zeros = lambda *shape, dtype=float: np.zeros(shape, dtype)  # noqa: E731
        return cls(
            zeros(n_env, dtype=bool),
            zeros(n_env, dtype=bool),
            np.full(n_env, np.nan),
            np.full(n_env, np.nan),
            zeros(n_env, n_obstacles, dtype=bool),
            zeros(n_env, n_obstacles, dtype=bool),
            zeros(n_env, dtype=int),
            zeros(n_env, dtype=int),
            zeros(n_env),
            zeros(n_env, len(ALPHA_BANDS)),
            zeros(n_env),
        )

    def rows(self) -> list[dict]:
        """One dict per trial with the experiment's columns."""
        rows = []
        for e in range(len(self.done)):
            encountered = int(self.encountered[e].sum())
            avoided = int((self.encountered[e] & ~self.collided[e]).sum())
            rows.append(
                {
                    "completion_time_s": float(self.completion_time_s[e]),
                    "obstacles_encountered": encountered,
                    "obstacles_avoided": avoided,
                    "collisions": int(self.collided[e].sum()),
                    "success": avoided / encountered if encountered else float("nan"),
                    "reached_goal": bool(self.reached_goal[e]),
                    "trap_losses": int(self.trap_losses[e]),
                    "detached": bool(self.detachments[e] > 0),
                    "detachments": int(self.detachments[e]),
                    "peak_contact_force_pn": float(self.peak_contact_force_pn[e]),
                    "grip_time_s": float(self.grip_time_s[e]),
                    "light_dose_mj_per_um2": float(self.light_dose_mj_per_um2[e]),
                    **{f"time_{name}_s": float(self.band_time_s[e, i]) for i, (name, _, _) in enumerate(ALPHA_BANDS)},
                }
            )
        return rows


@dataclasses.dataclass
class TaskState:
    scene: sc.SceneState  # batched
    tracks: dict
    phase: np.ndarray
    route_index: np.ndarray  # (E,) index of the route point nearest the cell
    metrics: TrialMetrics
    observation: Observation | None = None
    sphere_xy_um: np.ndarray | None = None  # (E, S, 2) every sphere's centre, as of ``observation``


@dataclasses.dataclass(frozen=True)
class PendingStep:
    """A tick's physics dispatched by ``InteractiveTask.dispatch`` and not yet
    completed: JAX computes it in the background until ``complete`` reads it."""

    scene: sc.SceneState
    measured: dict
    before_done: np.ndarray  # (E,) environments already DONE when it was dispatched


_reset_batch = jax.jit(jax.vmap(sc.reset_at, in_axes=(None, 0, None, None)))
"""``reset_at`` for a batch of keys, compiled whole (bitwise the op-by-op result)."""


class InteractiveTask:
    """The task on one chip: scene, route, formation; ``reset``/``step`` over E environments."""

    def __init__(self, config: InteractiveConfig = InteractiveConfig()):
        self.config = config
        params = core.make_params(config)
        self.params = params
        self.scene, self.chip, self.route = params.scene, params.chip, params.route
        self.route_um, self.route_arc_um = params.route_um, params.route_arc_um
        self.offsets_um, self.trap_robot = params.offsets_um, params.trap_robot
        self.trap_sphere = np.asarray(self.scene.model.trap_sphere, int)
        self.escape_speed_um_s = core.escape_speed_um_s(self.scene, config)
        """Speed at which the traps' largest force no longer drags the assembly (the
        trap-speed clamp of teleoperation stays below it)."""
        self._step = jax.jit(functools.partial(core.advance, config=config))
        self._measure_jit = jax.jit(functools.partial(core.measure, config=config))
        self._scenarios: dict[int, Scenario] = {}

    @property
    def n_traps(self) -> int:
        return self.scene.model.n_traps

    def scenario(self, seed: int) -> Scenario:
        """Scenario ``seed`` of this task (``make_scenario``), made once and kept: a batch
        whose modes or samples share their scenarios (each one's search for open water
        probes the walls about a hundred times) makes each only once. Its arrays are
        read-only."""
        seed = int(seed)
        if seed not in self._scenarios:
            scenario = make_scenario(
                seed,
                self.route_um,
                self.route_arc_um,
                self.wall_distance_um,
                self.config.scene.obstacle_radius_um,
                self.config.scenario,
            )
            for field in dataclasses.fields(scenario)[1:]:
                getattr(scenario, field.name).setflags(write=False)
            self._scenarios[seed] = scenario
        return self._scenarios[seed]

    def wall_distance_um(self, points_um) -> np.ndarray:
        """Wall distance (n,) at points (n, 2) um (``otgym.tasks.transport.interactive.wall_distance_um``)."""
        return core.wall_distance_um(self.scene, points_um)

    def reset(self, scenarios: list[Scenario], key) -> TaskState:
        """E environments, one per scenario: the cell at the route's start, the robots
        ``approach_gap_um`` out from their grip, the obstacles at their tracks' starts."""
        n_env = len(scenarios)
        heading = self.params.heading_rad
        keys = jax.random.split(key, n_env)
        state = _reset_batch(self.scene, keys, self.route.points_um[0], heading)
        pose = np.array(state.physics.pose)
        traps = np.array(state.physics.trap_xy_um)
        normal = np.array([-np.sin(float(heading)), np.cos(float(heading))])
        gap = self.config.approach_gap_um
        for robot, sign in zip(self.scene.robots, (-1.0, 1.0)):
            pose[:, robot, :2] += sign * gap * normal
            traps[:, self.trap_robot == robot] += sign * gap * normal
        obstacles = np.asarray(self.scene.obstacles)
        pose[:, obstacles, :2] = np.stack([s.start_um for s in scenarios])
        dtype = state.physics.pose.dtype
        physics = state.physics.replace(pose=jnp.asarray(pose, dtype), trap_xy_um=jnp.asarray(traps, dtype))
        scene_state = state.replace(
            physics=physics, obstacle_propulsion_um_s=jnp.zeros_like(state.obstacle_propulsion_um_s)
        )
        task_state = TaskState(
            scene_state,
            stack_tracks(scenarios),
            np.full(n_env, APPROACH),
            np.zeros(n_env, int),
            TrialMetrics.empty(n_env, len(obstacles)),
        )
        task_state.observation = self._observe(task_state, *self._measure(scene_state))
        return task_state

    def step(self, state: TaskState, trap_increment_um, key, alpha=None) -> Observation:
        """Advance every environment by one tick, moving each trap by
        ``trap_increment_um`` (E, T, 2) um (finished environments hold); ``alpha`` (E,)
        is only recorded. Updates ``state`` in place and returns the new observation."""
        return self.complete(state, self.dispatch(state, trap_increment_um, key), alpha)

    def dispatch(self, state: TaskState, trap_increment_um, key) -> PendingStep:
        """Start one tick's physics (as ``step``) and return at once: JAX's asynchronous
        dispatch runs it on its own thread while the caller works on the state as it was
        (``otgym.runtime.loop`` renders and senses the tick's starting frame meanwhile).
        ``state`` is not touched until ``complete``."""
        increment = np.where((state.phase == DONE)[:, None, None], 0.0, np.asarray(trap_increment_um, float))
        if not np.all(np.isfinite(increment)):
            raise ValueError("trap increments must be finite")
        # a numpy argument goes to the device with the call itself (jnp.asarray first would
        # dispatch a conversion of its own: a fifth of a one-environment tick's overhead)
        scene_state, measured = self._step(self.scene, state.scene, increment.astype(np.float32), key, state.tracks)
        return PendingStep(scene_state, measured, state.phase == DONE)

    def complete(self, state: TaskState, pending: PendingStep, alpha=None) -> Observation:
        """Wait for a dispatched tick, update ``state`` in place (phases, metrics) and
        return the new observation."""
        state.scene = pending.scene
        observation = self._observe(state, pending.scene, pending.measured)
        self._account(state, observation, pending.before_done, alpha)
        state.observation = observation
        return observation

    def _measure(self, scene_state):
        return scene_state, self._measure_jit(self.scene, scene_state)

    def _observe(self, state: TaskState, scene_state, measured) -> Observation:
        measured = jax.tree.map(np.asarray, measured)
        state.sphere_xy_um = measured["sphere_xy_um"].astype(float)
        cell = measured["cell_xy_um"].astype(float)
        state.route_index = self.route_index(cell, state.route_index)
        return Observation(
            time_s=np.asarray(scene_state.time_s, float),
            phase=state.phase.copy(),
            cell_xy_um=cell,
            cell_arc_um=self.route_arc_um[state.route_index],
            trap_xy_um=measured["trap_xy_um"].astype(float),
            handle_xy_um=measured["handle_xy_um"].astype(float),
            robot_xy_um=measured["robot_xy_um"].astype(float),
            obstacle_xy_um=measured["obstacle_xy_um"].astype(float),
            obstacle_gap_um=measured["obstacle_gap_um"].astype(float),
            contact_force_pn=measured["contact_force_pn"].astype(float),
            cell_gap_um=measured["cell_gap_um"].astype(float),
            trap_distance_um=measured["trap_distance_um"].astype(float),
            obstacle_touched=measured["obstacle_touched"].astype(bool),
        )

    def route_index(self, cell_xy, previous):
        """Nearest route point (E,) to each cell (E, 2), searched in a window ahead of the last one (E,)."""
        window = previous[:, None] + np.arange(*ROUTE_SEARCH_POINTS)[None]
        window = np.clip(window, 0, len(self.route_um) - 1)
        distance = np.linalg.norm(self.route_um[window] - cell_xy[:, None], axis=-1)
        return window[np.arange(len(window)), np.argmin(distance, axis=1)]

    def _account(self, state: TaskState, obs: Observation, before_done, alpha):
        config, metrics = self.config, state.metrics
        active = ~before_done
        tick = config.tick_s
        gripped = np.all(obs.cell_gap_um < config.grip_gap_um, axis=1)
        detached = np.any(obs.cell_gap_um > config.scene.detach_distance_um, axis=1)
        lost = np.any(obs.trap_distance_um > config.scene.trap_law.escape_distance, axis=1)
        carrying = state.phase == CARRY
        metrics.detachments += active & carrying & detached
        first_grip = active & (state.phase == APPROACH) & gripped & np.isnan(metrics.grip_time_s)
        metrics.grip_time_s[first_grip] = obs.time_s[first_grip]
        state.phase = np.where(active & carrying & detached, APPROACH, state.phase)
        state.phase = np.where(active & (state.phase == APPROACH) & gripped, CARRY, state.phase)
        near = obs.obstacle_gap_um < config.encounter_gap_um
        metrics.encountered |= active[:, None] & near
        metrics.collided |= active[:, None] & ((obs.obstacle_gap_um <= 0.0) | obs.obstacle_touched)
        metrics.peak_contact_force_pn = np.where(
            active,
            np.maximum(metrics.peak_contact_force_pn, obs.contact_force_pn.max(axis=1)),
            metrics.peak_contact_force_pn,
        )
        if alpha is not None:
            alpha = np.broadcast_to(np.asarray(alpha, float), active.shape)
            for i, (_, low, high) in enumerate(ALPHA_BANDS):
                metrics.band_time_s[:, i] += tick * (active & (alpha >= low) & (alpha < high))
        at_goal = (state.phase == CARRY) & (
            np.linalg.norm(obs.cell_xy_um - self.route_um[-1], axis=1) <= config.goal_tolerance_um
        )
        metrics.trap_losses += active & lost
        beam = ld.TrapBeam.of_trap_law(config.scene.trap_law)
        intensity = np.asarray(ld.cell_intensity_jit(beam, obs.trap_xy_um, obs.cell_xy_um, config.scene.cell_radius_um))
        metrics.light_dose_mj_per_um2 += tick * np.where(active, intensity, 0.0)
        timeout = obs.time_s >= config.time_limit_s - 0.5 * tick  # time_s is float32
        finished = active & (at_goal | lost | timeout)
        metrics.reached_goal |= active & at_goal & ~lost
        metrics.completion_time_s[finished] = obs.time_s[finished]
        metrics.done |= finished
        state.phase = np.where(finished, DONE, state.phase)
        obs.phase = state.phase.copy()
