"""The interactive task's functional core (paper section III-C): its config, the
params made once per chip (scene, route, formation), and the pure, jittable tick:
``advance`` moves the traps by an increment, propels the scenario's obstacles along
their tracks (``otgym.tasks.transport.scenario``) and steps the scene; ``measure``
reads the positions, gaps and forces a tick shows. ``otgym.task.task.InteractiveTask``
is its host wrapper (numpy in and out: phases, trial tallies, real time).

The scene is the ``transport`` scene with literature physics (``SceneConfig``'s
defaults: Gaussian traps of 50 pN/um and 0.6 um waist, water at 25 C, the chip's full
flow) at a 0.25 ms physics step (80 steps of a 50 Hz tick; the scene's stability
checks accept it).
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np

from otgym import physics as ph
from otgym.planning import formation as fm
from otgym.sim import scene as sc
from otgym.sim.chip import Chip
from otgym.tasks.transport.route_start import route_start
from otgym.tasks.transport.scenario import ScenarioConfig, propulsion_um_s


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


@dataclasses.dataclass(frozen=True)
class InteractiveParams:
    """What ``make_params`` builds once per config: the scene, its chip, the route
    (dense path and its points and arc lengths, um), its heading at the start, the
    scene at rest there with the assembly gripped (``RouteStart.gripped``), the
    formation's trap offsets (T, 2) um, and the robot each trap holds (T,)."""

    scene: sc.Scene
    chip: Chip
    route: fm.DensePath
    route_um: np.ndarray
    route_arc_um: np.ndarray
    heading_rad: jnp.ndarray
    gripped: sc.SceneState
    offsets_um: np.ndarray
    trap_robot: np.ndarray


def make_params(config: InteractiveConfig) -> InteractiveParams:
    """Build the scene and plan the route between the config's sites
    (``otgym.tasks.transport.route_start``)."""
    scene = sc.build_scene(config.scene)
    start = route_start(scene, config.scene, config.start_um, config.goal_um)
    model = scene.model
    trap_robot = np.asarray([model.sphere_body[s] for s in np.asarray(model.trap_sphere, int)], int)
    return InteractiveParams(
        scene,
        start.chip,
        start.path,
        np.asarray(start.path.points_um, float),
        np.asarray(start.path.arc_um, float),
        start.heading_rad,
        start.gripped,
        np.asarray(start.offsets_um),
        trap_robot,
    )


_wall_distance = jax.jit(lambda walls, points: walls.distance_and_normal(points)[0])


def wall_distance_um(scene: sc.Scene, points_um) -> np.ndarray:
    """Wall distance (n,) at points (n, 2) um (what the microscope shows of the chip),
    padded to a power of two so that one compiled sampler serves every track length."""
    points = np.asarray(points_um, np.float32)
    size = 1 << max(int(np.ceil(np.log2(max(len(points), 1)))), 4)
    padded = np.zeros((size, 2), np.float32)
    padded[: len(points)] = points
    # the numpy array goes to the device with the call (jnp.asarray first dispatches a conversion of its own)
    return np.asarray(_wall_distance(scene.model.walls, padded))[: len(points)]


def escape_speed_um_s(scene: sc.Scene, config: InteractiveConfig) -> float:
    """Speed at which the traps' largest force no longer drags the assembly: every trap's
    largest force over the assembly's largest translational drag (any direction; a lower
    bound). Teleoperation's trap-speed clamp stays below it."""
    model = scene.model
    drag = np.linalg.eigvalsh(np.asarray(model.body_translational_resistance_pn_s_per_um))[:, -1]
    payload_drag = float(drag[list(scene.robots) + [scene.payload]].sum())
    return model.n_traps * config.scene.trap_law.max_force_pn / payload_drag


def measure(scene: sc.Scene, scene_state: sc.SceneState, config: InteractiveConfig) -> dict:
    """Positions, gaps and forces of a batch of scene states (jnp, leading axis E):
    every sphere's centre, the cell, traps, handles, robots and obstacles (um), each
    obstacle's gap to the assembly's spheres, each gripper's gap to the cell's surface,
    each handle's distance from its trap; the contact force and obstacle touches are
    zero here (``advance`` sets them from the step's events)."""
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
        "contact_force_pn": jnp.zeros((pose.shape[0], len(scene.robots)), pose.dtype),
        "obstacle_touched": jnp.zeros((pose.shape[0], len(obstacles)), bool),
    }


def advance(scene: sc.Scene, scene_state: sc.SceneState, increment_um, key, tracks, config: InteractiveConfig):
    """One tick of E environments: each trap moves by ``increment_um`` (E, T, 2) um at a
    constant speed over the tick, the obstacles follow ``tracks`` (the scenarios'
    stacked tracks, ``otgym.tasks.transport.scenario.stack_tracks``). Returns the new
    scene state and its ``measure`` with the tick's contact forces and touches."""
    obstacles = np.asarray(scene.obstacles, int)
    obstacle_xy = scene_state.physics.pose[:, obstacles, :2]
    flow = jax.vmap(scene.model.flow.velocity_um_s)(obstacle_xy)
    propulsion = propulsion_um_s(tracks, scene_state.time_s, obstacle_xy, flow, config.scenario)
    new_state, events = sc.step_batch(scene, scene_state, increment_um / config.tick_s, key, propulsion)
    measured = measure(scene, new_state, config)
    measured["contact_force_pn"] = events.contact_force_pn
    measured["obstacle_touched"] = events.obstacle_touched
    return new_state, measured
