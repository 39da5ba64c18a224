"""Scenes built from a chip: bodies, traps, walls, flow and moving obstacles, with the
events the tasks need (paper section II-B).

Kinds:
* ``transport``: the paper's cooperative transport. Two two-handle microrobots (four
  traps) pinch one cell from both sides; the cell moves only through contact. Their
  traps start shifted by ``grip_squeeze_um`` towards the cell, so the traps press the
  robots' tips onto it (the grip force).
* ``navigation``: one robot (``robot``: any registered design) in its traps.
* ``bead``: one calibration bead in one trap.
All kinds add ``n_obstacles`` self-propelled obstacles (``otgym.sim.obstacles``).

A ``Scene`` is a pytree; ``reset``/``step`` are pure functions of it and of PRNG keys,
jittable, with ``step_batch`` stepping E environments at once in the physics core's
fast batched layout. Positions are um in chip coordinates (origin at the image's
top-left corner, x right, y down).
"""

from __future__ import annotations

import dataclasses
import functools

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct
from jax.custom_batching import custom_vmap

from otgym import physics as ph
from otgym import registry
from otgym.physics.batching import batch_through
from otgym.physics.robots import RobotSpec
from otgym.physics.validation import require_non_negative, require_positive_scalar
from otgym.sim.chip import Chip, load_chip
from otgym.sim.fields import chip_fields
from otgym.sim.obstacles import ObstacleMotion, next_propulsion

SCENE_KINDS = ("transport", "navigation", "bead")
PLACEMENT_MARGIN_UM = 0.5
PORT_ZONE_UM = 15.0
"""An obstacle within this distance of an outlet has left the chip: it re-enters at a
random spot within this distance of an inlet (debris keeps flowing in)."""


@dataclasses.dataclass(frozen=True)
class SceneConfig:
    """Everything that defines a scene; defaults are the ``realistic`` literature values
    (Gaussian traps of 50 pN/um, 0.6 um waist; water at 25 C)."""

    kind: str = "transport"
    chip: str | Chip = "default"
    robot: str = "two-handle"  # a registered robot (``otgym list robots``); transport needs one that grips
    trap_law: ph.TrapLaw = ph.TrapLaw("gaussian", stiffness_pn_per_um=50.0, waist_um=0.6)
    dt_s: float = 1e-4
    control_period_s: float = 0.2
    temperature_k: float = 298.15
    viscosity_pa_s: float = 8.9e-4
    flow_scale: float = 1.0
    n_obstacles: int = 4
    obstacle_radius_um: float = 3.0
    obstacle_motion: ObstacleMotion = ObstacleMotion()
    min_obstacle_distance_um: float = 25.0
    cell_radius_um: float = 4.0
    bead_radius_um: float = 0.5
    grip_squeeze_um: float = 0.05
    detach_distance_um: float = 1.0
    adhesion: ph.Adhesion = ph.Adhesion()
    """Van der Waals between the scene's materials (``otgym.physics.adhesion``)."""
    field_refresh_substeps: int = 10
    """Sample flow and walls every this many physics steps (1 ms at the default step);
    the largest divisor of ``substeps`` not above it is used."""
    contact_overlap_cap: float | None = None
    """None: penalty contact alone (default). A fraction c in (0, 1): no overlap deeper
    than c times the smaller radius of its pair (``otgym.physics.projection``; it costs
    physics time, see benchmarks/README.md)."""

    def __post_init__(self):
        if self.kind not in SCENE_KINDS:
            raise ValueError(f"kind must be one of {SCENE_KINDS}, got {self.kind!r}")
        registry.check("robots", self.robot)
        require_positive_scalar("control_period_s", self.control_period_s)
        require_positive_scalar("dt_s", self.dt_s)
        if self.dt_s > self.control_period_s:
            raise ValueError(f"dt_s={self.dt_s} must not exceed control_period_s={self.control_period_s}")
        require_non_negative("flow_scale", self.flow_scale)
        if not isinstance(self.n_obstacles, int) or self.n_obstacles < 0:
            raise ValueError(f"n_obstacles must be a non-negative integer, got {self.n_obstacles!r}")
        for name in ("obstacle_radius_um", "cell_radius_um", "bead_radius_um", "detach_distance_um"):
            require_positive_scalar(name, getattr(self, name))
        require_non_negative("grip_squeeze_um", self.grip_squeeze_um)
        require_non_negative("min_obstacle_distance_um", self.min_obstacle_distance_um)
        if not isinstance(self.field_refresh_substeps, int) or self.field_refresh_substeps < 1:
            raise ValueError(f"field_refresh_substeps must be a positive integer, got {self.field_refresh_substeps!r}")

    @property
    def substeps(self) -> int:
        return max(1, int(round(self.control_period_s / self.dt_s)))

    @property
    def field_refresh(self) -> int:
        return max(d for d in range(1, self.field_refresh_substeps + 1) if self.substeps % d == 0)


@struct.dataclass
class Scene:
    model: ph.Model
    start_candidates_um: jnp.ndarray  # (M, 2) payload centres with room for the assembly
    obstacle_candidates_um: jnp.ndarray  # (K, 2) obstacle centres clear of the walls
    outlets_um: jnp.ndarray  # (O, 2) outlet positions (O may be 0)
    inlet_spawns_um: jnp.ndarray  # (S, 2) re-entry spots near the inlets
    config: SceneConfig = struct.field(pytree_node=False)
    assembly_radius_um: float = struct.field(pytree_node=False, default=0.0)
    robots: tuple = struct.field(pytree_node=False, default=())
    payload: int = struct.field(pytree_node=False, default=0)
    obstacles: tuple = struct.field(pytree_node=False, default=())
    gripper_spheres: tuple = struct.field(pytree_node=False, default=())  # (R, 2)

    @property
    def n_traps(self) -> int:
        return self.model.n_traps


@struct.dataclass
class SceneState:
    physics: ph.PhysicsState
    obstacle_propulsion_um_s: jnp.ndarray  # (K, 2)
    time_s: jnp.ndarray  # ()


@struct.dataclass
class SceneEvents:
    """What the tasks read after a step (leading batch axis when batched)."""

    trap_lost: jnp.ndarray  # (T,) bool
    trap_distance_um: jnp.ndarray  # (T,)
    contact_force_pn: jnp.ndarray  # (R,) robot-cell contact force, transport only
    cell_gap_um: jnp.ndarray  # (R,) gap between each robot's gripper and the cell surface
    cell_detached: jnp.ndarray  # () bool, a gripper left the cell by more than detach_distance_um
    obstacle_collision: jnp.ndarray  # () bool, a robot, cell or bead touched an obstacle
    obstacle_touched: jnp.ndarray  # (K,) bool, a robot, cell or bead touched obstacle k during the step
    wall_collision: jnp.ndarray  # () bool, a robot, cell or bead touched a wall

    @property
    def failed(self):
        return jnp.any(self.trap_lost, axis=-1) | self.cell_detached | self.obstacle_collision | self.wall_collision


def robot_spec(config: SceneConfig) -> RobotSpec:
    """The scene's robot design, from the registry (ValueError: unknown, or one that
    cannot grip in the transport scene)."""
    spec = registry.load("robots", config.robot)
    if config.kind == "transport" and (not spec.can_grip or spec.n_handles != 2):
        raise ValueError(
            f"robot {config.robot!r} cannot carry a cell in the transport scene: it needs two handles and "
            "grip_spheres (a gripper notch)"
        )
    return spec


def _bodies(config: SceneConfig):
    spec = robot_spec(config)
    if config.kind == "transport":
        bodies = [spec.body("robot_a"), spec.body("robot_b"), ph.cell("cell", radius_um=config.cell_radius_um)]
    elif config.kind == "navigation":
        bodies = [spec.body("robot")]
    else:
        bodies = [ph.bead("bead", radius_um=config.bead_radius_um)]
    bodies += [
        ph.obstacle(f"obstacle_{i}", radius_um=config.obstacle_radius_um, kinematic=False)
        for i in range(config.n_obstacles)
    ]
    return bodies


def _assembly_pose(scene_model: ph.Model, config: SceneConfig, centre, heading):
    """Poses (P, 3) of the payload bodies for a payload centre and heading (jnp)."""
    normal = jnp.array([-jnp.sin(heading), jnp.cos(heading)])
    if config.kind != "transport":
        return jnp.concatenate([centre, heading[None]])[None]
    grip = robot_spec(config).grip_spheres
    gripper = scene_model.sphere_offset_um[grip[0]]  # (-spacing/2, y) about the hydrodynamic centre
    contact = config.cell_radius_um + scene_model.sphere_radius_um[grip[0]]
    reach = gripper[1] + jnp.sqrt(contact**2 - gripper[0] ** 2)  # cell touching both gripper spheres
    robot_a = jnp.concatenate([centre - reach * normal, heading[None]])
    robot_b = jnp.concatenate([centre + reach * normal, (heading + jnp.pi)[None]])
    cell = jnp.concatenate([centre, jnp.zeros(1)])
    return jnp.stack([robot_a, robot_b, cell])


def _assembly_radius_um(model: ph.Model, config: SceneConfig, n_payload: int) -> float:
    pose = np.asarray(jax.jit(lambda m, c, h: _assembly_pose(m, config, c, h))(model, jnp.zeros(2), jnp.zeros(())))
    full = np.zeros((model.n_bodies, 3))
    full[:n_payload] = pose
    full[n_payload:, :2] = 1e6
    xy = np.asarray(jax.jit(ph.sphere_positions_um)(model, jnp.asarray(full.astype(model.sphere_radius_um.dtype))))
    radii = np.asarray(model.sphere_radius_um)
    payload = np.array([b < n_payload for b in model.sphere_body])
    return float(np.max(np.linalg.norm(xy[payload], axis=1) + radii[payload]))


def grip_geometry_um(config: SceneConfig) -> tuple[np.ndarray, np.ndarray]:
    """The transport assembly about a cell at the origin, heading 0 (no chip needed): the
    trap positions (T, 2) on the robots' handles (without the grip squeeze) and the
    radii (S,) of the robots' spheres. For tasks that need the grip's geometry without
    simulating it (the light dose a carried cell gets, the assembly's drag)."""
    traps, _, radii, _, _ = _grip_geometry(dataclasses.replace(config, kind="transport", n_obstacles=0))
    return traps.copy(), radii.copy()


def grip_robots_um(config: SceneConfig) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The robots of the transport assembly about a cell at the origin, heading 0 (robot
    a above the cell, at negative y; robot b below): each robot sphere's centre (S, 2),
    radius (S,), robot (S,: 0 for a, 1 for b) and whether it is a handle (S,). For tasks
    that draw the grip without simulating it."""
    _, xy, radii, robot, handle = _grip_geometry(dataclasses.replace(config, kind="transport", n_obstacles=0))
    return xy.copy(), radii.copy(), robot.copy(), handle.copy()


@functools.lru_cache(maxsize=16)
def _grip_geometry(transport: SceneConfig):
    model = ph.build_model(_bodies(transport), ph.PhysicsConfig(substeps=1))

    @jax.jit
    def spheres_of(model):  # one program, not one per primitive
        pose = _assembly_pose(model, transport, jnp.zeros(2), jnp.zeros(()))
        return ph.sphere_positions_um(model, pose)

    xy = np.asarray(spheres_of(model), float)
    robot_spheres = [i for i, b in enumerate(model.sphere_body) if b < 2]
    handle = np.isin(np.arange(len(model.sphere_body)), np.asarray(model.trap_sphere, int))
    return (
        xy[np.asarray(model.trap_sphere, int)],
        xy[robot_spheres],
        np.asarray(model.sphere_radius_um, float)[robot_spheres],
        np.asarray(model.sphere_body, int)[robot_spheres],
        handle[robot_spheres],
    )


def build_scene(config: SceneConfig = SceneConfig()) -> Scene:
    """Load the chip, derive (or read from the cache) its walls and flow, and compile the
    physics model of the scene. Raises ValueError if the chip has no room for it."""
    robot_spec(config)  # a robot that cannot serve the scene is refused before the fields are solved
    chip = config.chip if isinstance(config.chip, Chip) else load_chip(config.chip)
    flow, walls = chip_fields(chip)
    flow = flow.scaled(config.flow_scale)
    bodies = _bodies(config)
    physics_config = ph.PhysicsConfig(
        dt_s=config.control_period_s / config.substeps,
        substeps=config.substeps,
        temperature_k=config.temperature_k,
        viscosity_pa_s=config.viscosity_pa_s,
        trap_law=config.trap_law,
        adhesion=config.adhesion,
        field_refresh_substeps=config.field_refresh,
        contact_overlap_cap=config.contact_overlap_cap,
    )
    model = ph.build_model(bodies, physics_config, flow=flow, walls=walls)
    n_payload = len(bodies) - config.n_obstacles
    distance = np.asarray(walls.distance)
    rows, cols = np.nonzero(distance > 0)
    centres = np.column_stack([(cols + 0.5), (rows + 0.5)]) * chip.pixel_size_um
    free = distance[rows, cols]
    clearance = _assembly_radius_um(model, config, n_payload) + PLACEMENT_MARGIN_UM
    starts = centres[free > clearance]
    if starts.size == 0:
        raise ValueError(f"chip {chip.name!r} has no place {2 * clearance:.1f} um wide for the {config.kind} assembly")
    obstacle_spots = centres[free > config.obstacle_radius_um + 2 * config.obstacle_motion.wall_margin_um]
    if config.n_obstacles and obstacle_spots.size == 0:
        raise ValueError(f"chip {chip.name!r} has no room for obstacles of radius {config.obstacle_radius_um} um")
    ports = {
        kind: np.array([p.xy_um for p in chip.ports if p.kind == kind]).reshape(-1, 2) for kind in ("inlet", "outlet")
    }
    near_inlet = np.zeros(len(obstacle_spots), bool)
    for inlet in ports["inlet"]:
        near_inlet |= np.linalg.norm(obstacle_spots - inlet, axis=1) < PORT_ZONE_UM
    spawns = obstacle_spots[near_inlet]
    robots = tuple(range(2)) if config.kind == "transport" else ((0,) if config.kind == "navigation" else ())
    sphere_start = [model.sphere_body.index(r) for r in robots]
    dtype = model.sphere_radius_um.dtype
    return Scene(
        model=model,
        start_candidates_um=jnp.asarray(starts, dtype),
        obstacle_candidates_um=jnp.asarray(obstacle_spots if obstacle_spots.size else np.zeros((1, 2)), dtype),
        outlets_um=jnp.asarray(ports["outlet"] if len(spawns) else np.zeros((0, 2)), dtype),
        inlet_spawns_um=jnp.asarray(spawns if len(spawns) else np.zeros((1, 2)), dtype),
        config=config,
        assembly_radius_um=clearance - PLACEMENT_MARGIN_UM,
        robots=robots,
        payload=2 if config.kind == "transport" else 0,
        obstacles=tuple(range(n_payload, len(bodies))),
        gripper_spheres=tuple(tuple(s + g for g in (robot_spec(config).grip_spheres or ())) for s in sphere_start),
    )


def reset_at(scene: Scene, key, start_um, heading_rad) -> SceneState:
    """A state with the payload centred at ``start_um`` facing ``heading_rad`` (traps
    on their handles, shifted ``grip_squeeze_um`` towards the cell to press the robots'
    grippers onto it), and the obstacles
    at random spots at least ``min_obstacle_distance_um`` away."""
    config, model = scene.config, scene.model
    dtype = model.sphere_radius_um.dtype
    start = jnp.asarray(start_um, dtype)
    heading = jnp.asarray(heading_rad, dtype)
    payload_pose = _assembly_pose(model, config, start, heading).astype(dtype)
    n_obstacles = len(scene.obstacles)
    pick_key, drift_key = jax.random.split(key)
    chosen = _spots_away_from(
        pick_key, scene.obstacle_candidates_um, start, config.min_obstacle_distance_um, n_obstacles
    )
    obstacle_pose = jnp.concatenate([chosen, jnp.zeros((n_obstacles, 1), dtype)], axis=1)
    pose = jnp.concatenate([payload_pose, obstacle_pose])
    trap_xy = ph.sphere_positions_um(model, pose)[np.asarray(model.trap_sphere, int)]
    if config.kind == "transport":
        normal = jnp.array([-jnp.sin(heading), jnp.cos(heading)])
        towards_cell = jnp.stack([normal, normal, -normal, -normal])  # traps of robot a, then b
        trap_xy = trap_xy + config.grip_squeeze_um * towards_cell
    propulsion = config.obstacle_motion.speed_um_s * jax.random.normal(drift_key, (n_obstacles, 2), dtype)
    return SceneState(ph.PhysicsState(pose, trap_xy), propulsion, jnp.zeros((), dtype))


def _spots_away_from(key, spots, centre, distance_um, count):
    """``count`` random rows of ``spots`` farther than ``distance_um`` from ``centre``
    (any row if none is that far)."""
    far = jnp.linalg.norm(spots - centre, axis=-1) > distance_um
    logits = jnp.where(jnp.any(far), jnp.where(far, 0.0, -jnp.inf), 0.0)
    return spots[jax.random.categorical(key, logits, shape=(count,))]


def _at_exit(scene: Scene, pose):
    """Which obstacles of ``pose`` (..., B, 3) are within ``PORT_ZONE_UM`` of an outlet (..., K)."""
    xy = pose[..., np.asarray(scene.obstacles), :2]
    return jnp.min(jnp.linalg.norm(xy[..., :, None, :] - scene.outlets_um, axis=-1), axis=-1) < PORT_ZONE_UM


def _recirculate(scene: Scene, key, pose):
    """Obstacles that reached an outlet re-enter near an inlet, away from the payload."""
    obstacles = np.asarray(scene.obstacles)
    xy = pose[obstacles, :2]
    at_exit = _at_exit(scene, pose)
    fresh = _spots_away_from(
        key, scene.inlet_spawns_um, pose[scene.payload, :2], scene.config.min_obstacle_distance_um, len(obstacles)
    )
    return pose.at[obstacles, :2].set(jnp.where(at_exit[:, None], fresh, xy))


def _recirculate_batch(scene: Scene, key, pose):
    """``_recirculate`` for each environment of ``pose`` (E, B, 3), with environment i's
    key ``jax.random.split(key, E)[i]``. The re-entry spots are drawn only when some
    obstacle of the batch is at an outlet (a draw over every spawn spot per obstacle and
    environment is a good part of a small batch's step); the result is that of drawing
    them always."""
    return jax.lax.cond(
        jnp.any(_at_exit(scene, pose)),
        lambda p: jax.vmap(lambda k, q: _recirculate(scene, k, q))(jax.random.split(key, p.shape[0]), p),
        lambda p: p,
        pose,
    )


def reset(scene: Scene, key) -> SceneState:
    """A random state: payload at a random spot with room for it, heading along the
    local flow (the channel's axis) or at random where there is no flow."""
    place_key, heading_key, rest_key = jax.random.split(key, 3)
    start = scene.start_candidates_um[jax.random.randint(place_key, (), 0, scene.start_candidates_um.shape[0])]
    velocity = scene.model.flow.velocity_um_s(start[None])[0]
    random_heading = jax.random.uniform(heading_key, (), start.dtype, -jnp.pi, jnp.pi)
    heading = jnp.where(jnp.linalg.norm(velocity) > 1e-3, jnp.arctan2(velocity[1], velocity[0]), random_heading)
    return reset_at(scene, rest_key, start, heading)


def step_batch(scene: Scene, state: SceneState, trap_velocity_um_s, key, obstacle_propulsion_um_s=None):
    """Advance E scenes (leading batch axis) by one control step with the given trap
    velocities (E, T, 2) in um/s; returns (state, SceneEvents). The obstacles propel
    themselves by their random walk, or by ``obstacle_propulsion_um_s`` (E, K, 2) when
    given (scripted scenarios); either way walls and bodies stop them."""
    config, model = scene.config, scene.model
    n_env = state.physics.pose.shape[0]
    obstacle_key, physics_key, spawn_key = jax.random.split(key, 3)
    dtype = state.physics.pose.dtype
    external = jnp.zeros((n_env, model.n_bodies, 3), dtype)
    propulsion = state.obstacle_propulsion_um_s
    if scene.obstacles:
        obstacles = np.asarray(scene.obstacles)
        keys = jax.random.split(obstacle_key, n_env)
        propulsion = (
            jnp.asarray(obstacle_propulsion_um_s, dtype)
            if obstacle_propulsion_um_s is not None
            else jax.vmap(
                lambda k, xy, u: next_propulsion(
                    k, xy, u, config.obstacle_radius_um, model.walls, config.obstacle_motion, config.control_period_s
                )
            )(keys, state.physics.pose[:, obstacles, :2], propulsion)
        )
        force = ph.drag_force_pn(
            model, state.physics.pose, jnp.zeros_like(state.physics.pose[..., :2]).at[:, obstacles].set(propulsion)
        )
        external = external.at[:, obstacles, :2].set(force[:, obstacles])
    controls = ph.Controls(
        trap_velocity_um_s=jnp.asarray(trap_velocity_um_s, dtype),
        body_velocity=jnp.zeros_like(external),
        external_force=external,
    )
    physics, report = ph.control_step_batch(model, state.physics, controls, physics_key)
    if scene.obstacles and scene.outlets_um.shape[0] and obstacle_propulsion_um_s is None:
        physics = physics.replace(pose=_recirculate_batch(scene, spawn_key, physics.pose))
    new_state = SceneState(physics, propulsion, state.time_s + config.control_period_s)
    return new_state, _events(scene, physics, report)


def _step_one(scene: Scene, state: SceneState, trap_velocity_um_s, key):
    expand = lambda tree: jax.tree.map(lambda a: a[None], tree)  # noqa: E731
    new_state, events = step_batch(scene, expand(state), jnp.asarray(trap_velocity_um_s)[None], key)
    squeeze = lambda tree: jax.tree.map(lambda a: a[0], tree)  # noqa: E731
    return squeeze(new_state), squeeze(events)


@custom_vmap
def step(scene: Scene, state: SceneState, trap_velocity_um_s, key):
    """One scene, one control step (see ``step_batch``). Under ``jax.vmap`` over states,
    velocities and keys it runs ``step_batch`` (one noise draw for the batch, from a
    key derived from all the batch's keys)."""
    return _step_one(scene, state, trap_velocity_um_s, key)


step.def_vmap(batch_through(_step_one, step_batch))


def _events(scene: Scene, physics: ph.PhysicsState, report: ph.StepReport) -> SceneEvents:
    model, config = scene.model, scene.config
    n_env = physics.pose.shape[0]
    dtype = physics.pose.dtype
    dynamic = [b for b in range(model.n_bodies) if b not in scene.obstacles]
    obstacle_pairs = [model.body_pair_index(d, o) for d in dynamic for o in scene.obstacles]
    obstacle_collision = (
        jnp.any(report.contact[:, np.asarray(obstacle_pairs, int)], axis=-1)
        if obstacle_pairs
        else jnp.zeros(n_env, bool)
    )
    touched = (
        [
            jnp.any(report.contact[:, np.asarray([model.body_pair_index(d, o) for d in dynamic], int)], axis=-1)
            for o in scene.obstacles
        ]
        if dynamic
        else []
    )
    obstacle_touched = jnp.stack(touched, axis=-1) if touched else jnp.zeros((n_env, 0), bool)
    wall_collision = jnp.any(report.wall_contact[:, np.asarray(dynamic)], axis=-1)
    if config.kind == "transport":
        cell_pairs = np.asarray([model.body_pair_index(r, scene.payload) for r in scene.robots])
        force = report.contact_force_pn[:, cell_pairs]
        xy = ph.sphere_positions_um(model, physics.pose)
        grippers = xy[:, np.asarray(scene.gripper_spheres)]  # (E, R, 2, 2)
        cell_xy = physics.pose[:, scene.payload, None, None, :2]
        gripper_radius = model.sphere_radius_um[scene.gripper_spheres[0][0]]
        surface_gap = jnp.linalg.norm(grippers - cell_xy, axis=-1) - config.cell_radius_um - gripper_radius
        gap = jnp.min(surface_gap, axis=-1)
        detached = jnp.any(gap > config.detach_distance_um, axis=-1)
    else:
        force = gap = jnp.zeros((n_env, 0), dtype)
        detached = jnp.zeros(n_env, bool)
    return SceneEvents(
        trap_lost=report.trap_lost,
        trap_distance_um=report.trap_distance_um,
        contact_force_pn=force,
        cell_gap_um=gap,
        cell_detached=detached,
        obstacle_collision=obstacle_collision,
        obstacle_touched=obstacle_touched,
        wall_collision=wall_collision,
    )
