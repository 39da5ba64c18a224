"""The interactive task (paper section III-C): two trapped microrobots approach and grip
a cell, then carry it along the planned route to the destination past dynamic
obstacles that cross the route, stepped at a fixed control rate (50 Hz: each tick
advances the physics by the tick's duration, so one environment can run in real time
and many run batched for experiments).

The scene is the ``transport`` scene with literature physics (``SceneConfig``'s
defaults: Gaussian traps of 50 pN/um and 0.6 um waist, water at 25 C, the chip's full
flow) at a 0.25 ms physics step (80 steps a tick; the scene's stability checks accept
it). The robots start ``approach_gap_um`` farther from the cell than their grip; the
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

from otgym import physics as ph
from otgym.physics import light_dose as ld
from otgym.planning import formation as fm
from otgym.planning import plan_path
from otgym.sim import scene as sc
from otgym.sim.chip import Chip, load_chip
from otgym.task.scenario import Scenario, ScenarioConfig, make_scenario, propulsion_um_s, stack_tracks

APPROACH, CARRY, DONE = 0, 1, 2
ALPHA_BANDS = (("autonomous", 0.0, 0.2), ("balanced", 0.2, 0.4), ("fine_tune", 0.4, 1.0 + 1e-9))
"""The paper's three operation modes of shared control by the human's share alpha
(alpha 0.1 far from obstacles, 0.5 near them); manual control counts as fine-tuning."""
FINE_TUNE_ALPHA = dict((name, low) for name, low, _ in ALPHA_BANDS)["fine_tune"]
"""0.4: where the paper's fine-tuning band of alpha begins. The one threshold of the
fine-tune cue: the window shows its prompt from here (``otgym.ui.cues``) and the simulated
participants take over from here (``otgym.human.participants``; they act on the cue the
window shows, an assumption about people, not a measurement)."""
ROUTE_SEARCH_POINTS = (-40, 400)


def interactive_scene(**overrides) -> sc.SceneConfig:
    """The literature transport scene at 50 Hz ticks and a 0.25 ms physics step (the
    stable step of its stiff traps on the robots' interacting-sphere mobility is 0.255 ms)."""
    return sc.SceneConfig(**{"kind": "transport", "dt_s": 2.5e-4, "control_period_s": 0.02, **overrides})


@dataclasses.dataclass(frozen=True)
class InteractiveConfig:
    scene: sc.SceneConfig = dataclasses.field(default_factory=interactive_scene)
    start_um: str | tuple[float, float] = "start"  # a site of the chip's sidecar, or (x, y) um
    goal_um: str | tuple[float, float] = "goal"
    approach_gap_um: float = 1.5
    grip_gap_um: float = 0.3
    goal_tolerance_um: float = 3.0
    time_limit_s: float = 300.0
    encounter_gap_um: float = 20.0
    scenario: ScenarioConfig = ScenarioConfig()

    def __post_init__(self):
        for name in ("approach_gap_um", "grip_gap_um", "goal_tolerance_um", "time_limit_s", "encounter_gap_um"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and np.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive number, got {value!r}")
        if self.scene.kind != "transport":
            raise ValueError(f"the interactive task needs a transport scene, got kind {self.scene.kind!r}")
        if self.scene.n_obstacles != self.scenario.n_obstacles:
            raise ValueError(f"scene has {self.scene.n_obstacles} obstacles, scenario {self.scenario.n_obstacles}")

    @property
    def tick_s(self) -> float:
        return self.scene.control_period_s


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


_reset_one = jax.jit(sc.reset_at)
"""``sc.reset_at`` compiled whole (bitwise the op-by-op result, without compiling each op)."""
_reset_batch = jax.jit(jax.vmap(sc.reset_at, in_axes=(None, 0, None, None)))
"""``sc.reset_at`` for a batch of keys, compiled whole."""
_start_heading = jax.jit(lambda route: fm.heading_at(route, 0.0))
"""The route's heading at its start (rad), one compiled program instead of a dozen eager ones."""
_formation_offsets = jax.jit(fm.formation_offsets)


class InteractiveTask:
    """The task on one chip: scene, route, formation; ``reset``/``step`` over E environments."""

    def __init__(self, config: InteractiveConfig = InteractiveConfig()):
        self.config = config
        self.scene = sc.build_scene(config.scene)
        chip = config.scene.chip if isinstance(config.scene.chip, Chip) else load_chip(config.scene.chip)
        self.chip = chip
        plan = plan_path(
            chip.image,
            chip.pixel_size_um,
            chip.site_um(config.start_um),
            chip.site_um(config.goal_um),
            robot_radius_um=self.scene.assembly_radius_um,
            threshold=0.5,
        )
        self.route = fm.dense_path(plan.smoothed_um)
        self.route_um = np.asarray(self.route.points_um, float)
        self.route_arc_um = np.asarray(self.route.arc_um, float)
        heading = _start_heading(self.route)
        gripped = _reset_one(self.scene, jax.random.PRNGKey(0), self.route.points_um[0], heading)
        self.offsets_um = np.asarray(_formation_offsets(gripped.physics.trap_xy_um, self.route.points_um[0], heading))
        model = self.scene.model
        self.trap_sphere = np.asarray(model.trap_sphere, int)
        self.trap_robot = np.asarray([model.sphere_body[s] for s in self.trap_sphere], int)  # (T,) robot of each trap
        # largest translational drag of each body (any direction): the escape speed is a lower bound
        drag = np.linalg.eigvalsh(np.asarray(model.body_translational_resistance_pn_s_per_um))[:, -1]
        payload_drag = float(drag[list(self.scene.robots) + [self.scene.payload]].sum())
        self.escape_speed_um_s = model.n_traps * config.scene.trap_law.max_force_pn / payload_drag
        """Speed at which the traps' largest force no longer drags the assembly (the
        trap-speed clamp of teleoperation stays below it)."""
        self._step = jax.jit(functools.partial(_advance, config=config))
        self._measure_jit = jax.jit(functools.partial(_measure, config=config))
        self._distance_jit = jax.jit(lambda walls, points: walls.distance_and_normal(points)[0])

    @property
    def n_traps(self) -> int:
        return self.scene.model.n_traps

    def scenario(self, seed: int) -> Scenario:
        return make_scenario(
            seed,
            self.route_um,
            self.route_arc_um,
            self.wall_distance_um,
            self.config.scene.obstacle_radius_um,
            self.config.scenario,
        )

    def wall_distance_um(self, points_um) -> np.ndarray:
        """Wall distance (n,) at points (n, 2) (what the microscope shows of the chip), padded to a power of two so that one
        compiled sampler serves every track length."""
        points = np.asarray(points_um, np.float32)
        size = 1 << max(int(np.ceil(np.log2(max(len(points), 1)))), 4)
        padded = np.zeros((size, 2), np.float32)
        padded[: len(points)] = points
        return np.asarray(self._distance_jit(self.scene.model.walls, jnp.asarray(padded)))[: len(points)]

    def reset(self, scenarios: list[Scenario], key) -> TaskState:
        """E environments, one per scenario: the cell at the route's start, the robots
        ``approach_gap_um`` out from their grip, the obstacles at their tracks' starts."""
        n_env = len(scenarios)
        heading = _start_heading(self.route)
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


def _measure(scene: sc.Scene, scene_state: sc.SceneState, config: InteractiveConfig):
    """Positions, gaps and forces of a batch of scene states (jnp)."""
    model = scene.model
    pose = scene_state.physics.pose
    xy = ph.sphere_positions_um(model, pose)  # (E, S, 2)
    radius = model.sphere_radius_um
    trap_sphere = np.asarray(model.trap_sphere, int)
    handles = xy[:, trap_sphere]
    traps = scene_state.physics.trap_xy_um
    bodies = np.asarray(model.sphere_body)
    payload = np.flatnonzero(bodies <= scene.payload)
    obstacles = np.asarray(scene.obstacles, int)
    obstacle_spheres = np.asarray([np.flatnonzero(bodies == o)[0] for o in obstacles], int)
    between = jnp.linalg.norm(xy[:, payload, None] - xy[:, None, obstacle_spheres], axis=-1)  # (E, P, K)
    gap = jnp.min(between - radius[payload][:, None] - radius[obstacle_spheres][None], axis=1)
    grippers = xy[:, np.asarray(scene.gripper_spheres)]  # (E, R, 2, 2)
    cell = pose[:, scene.payload, :2]
    surface = (
        jnp.linalg.norm(grippers - cell[:, None, None], axis=-1)
        - config.scene.cell_radius_um
        - radius[scene.gripper_spheres[0][0]]
    )
    return {
        "sphere_xy_um": xy,
        "cell_xy_um": cell,
        "trap_xy_um": traps,
        "handle_xy_um": handles,
        "robot_xy_um": pose[:, np.asarray(scene.robots), :2],
        "obstacle_xy_um": pose[:, obstacles, :2],
        "obstacle_gap_um": gap,
        "cell_gap_um": jnp.min(surface, axis=-1),
        "trap_distance_um": jnp.linalg.norm(handles - traps, axis=-1),
        "contact_force_pn": jnp.zeros((pose.shape[0], len(scene.robots)), pose.dtype),  # set by _advance
        "obstacle_touched": jnp.zeros((pose.shape[0], len(obstacles)), bool),
    }  # set by _advance


def _advance(scene: sc.Scene, scene_state: sc.SceneState, increment_um, key, tracks, config: InteractiveConfig):
    obstacles = np.asarray(scene.obstacles, int)
    obstacle_xy = scene_state.physics.pose[:, obstacles, :2]
    flow = jax.vmap(scene.model.flow.velocity_um_s)(obstacle_xy)
    propulsion = propulsion_um_s(tracks, scene_state.time_s, obstacle_xy, flow, config.scenario)
    new_state, events = sc.step_batch(scene, scene_state, increment_um / config.tick_s, key, propulsion)
    measured = _measure(scene, new_state, config)
    measured["contact_force_pn"] = events.contact_force_pn
    measured["obstacle_touched"] = events.obstacle_touched
    return new_state, measured
