"""The ``orient`` task core: two robots gripping a cell (the ``transport`` scene of
``otgym.sim.scene``, reused as it is) turn it in place to a target angle without
losing the grip, e.g. to image it from another side.

Each control step the action picks an angular speed (clockwise, counter-clockwise or
hold); the four traps turn as one rigid formation about the point where the cell
started (the formation's centre), every trap commanded the constant velocity that
brings it to its place in the turned formation within the step (as
``otgym.planning.formation`` does along a path). The physics runs its sub-steps in
between.

The cell's orientation. The cell is one sphere and contact is frictionless (normal
forces through its centre, ``otgym.physics.interactions``), so the grip cannot turn
the simulated body: its angle only diffuses. The task therefore measures the angle
the cell is held at, assuming it turns with the grip without slipping: the turn of the
axis from robot a's centre to robot b's centre since the episode began. The target is
a turn drawn per episode, of magnitude uniform in [``target_min_deg``,
``target_max_deg``] and random sign.

Observation (17 values, vectors in the commanded formation frame, normalised to order
one): sin and cos of the angle error (target minus turn); the commanded angular speed
over the fastest; the four handle-to-trap vectors over the trap's escape distance; the
two robot-cell contact forces over the force band's top (10 pN); the cell's offset
from the formation centre over the cell radius; the fraction of ``hold_steps`` spent
within the tolerance so far; the episode's elapsed fraction.

Reward per step (``OrientReward``): a time cost; progress (the decrease of the absolute
angle error, per radian); a failure (trap loss, cell detached, wall or obstacle
collision) penalised and ending the episode; a goal bonus once the error has stayed
within ``tolerance_deg`` for ``hold_steps`` consecutive steps, which ends the episode.

Pure and jittable, batched over a leading environment axis E on ``scene.step_batch``;
``params`` is a pytree with the ``OrientConfig`` static.
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from otgym import physics as ph
from otgym.physics import light_dose as ld
from otgym.physics.validation import require_positive_scalar
from otgym.sim import scene as sc
from otgym.sim.scene import SceneConfig

OBS_SIZE = 17
FORCE_SCALE_PN = 10.0


@dataclasses.dataclass(frozen=True)
class OrientReward:
    """Per-step reward weights: ``time`` each step, ``progress`` per radian of
    absolute angle error removed (negative when it grows), ``failure`` and ``goal``
    once."""

    time: float = -0.02
    progress: float = 10.0
    failure: float = -50.0
    goal: float = 10.0


@dataclasses.dataclass(frozen=True)
class OrientConfig:
    """An orient task: the scene, the turning speeds (deg/s; the actions are each of
    them clockwise and counter-clockwise, and hold), the target's range, the goal's
    tolerance and hold, the episode's length and the reward."""

    name: str
    scene: SceneConfig
    turn_speeds_deg_s: tuple[float, ...] = (1.5, 5.0)
    target_min_deg: float = 10.0
    target_max_deg: float = 90.0
    tolerance_deg: float = 2.0
    hold_steps: int = 10
    max_steps: int = 200
    reward: OrientReward = OrientReward()

    def __post_init__(self):
        if self.scene.kind != "transport":
            raise ValueError(f"orient needs the transport scene, got kind {self.scene.kind!r}")
        speeds = self.turn_speeds_deg_s
        if not speeds or any(not (v > 0) for v in speeds) or list(speeds) != sorted(set(speeds)):
            raise ValueError(f"turn_speeds_deg_s must be increasing positive speeds, got {speeds}")
        require_positive_scalar("target_max_deg", self.target_max_deg)
        require_positive_scalar("tolerance_deg", self.tolerance_deg)
        if not 0 <= self.target_min_deg <= self.target_max_deg <= 180:
            raise ValueError(
                f"need 0 <= target_min_deg <= target_max_deg <= 180, got {self.target_min_deg}, {self.target_max_deg}"
            )
        for name in ("hold_steps", "max_steps"):
            value = getattr(self, name)
            if not isinstance(value, int) or value < 1:
                raise ValueError(f"{name} must be a positive integer, got {value!r}")

    @property
    def n_actions(self) -> int:
        return 2 * len(self.turn_speeds_deg_s) + 1

    @property
    def hold_action(self) -> int:
        return len(self.turn_speeds_deg_s)

    def angular_speeds_rad_s(self) -> np.ndarray:
        """The angular speed of each action: fastest clockwise (negative) first, hold in
        the middle, fastest counter-clockwise (positive) last. Angles are in chip
        coordinates (x right, y down), so a positive turn is clockwise on screen."""
        speeds = np.deg2rad(np.asarray(self.turn_speeds_deg_s, float))
        return np.concatenate([-speeds[::-1], [0.0], speeds])


@struct.dataclass
class OrientParams:
    scene: sc.Scene
    offsets_um: jnp.ndarray  # (T, 2) trap positions about the formation centre at heading 0
    config: OrientConfig = struct.field(pytree_node=False)


@struct.dataclass
class OrientState:
    scene: sc.SceneState
    centre_um: jnp.ndarray  # (2,) the formation's centre: where the cell started
    heading_rad: jnp.ndarray  # the formation's heading at the start
    grip_start_rad: jnp.ndarray  # the robot a -> robot b axis at the start
    target_rad: jnp.ndarray  # the wanted turn
    command_rad: jnp.ndarray  # the formation's commanded turn
    turn_rad_s: jnp.ndarray  # the last commanded angular speed
    error_rad: jnp.ndarray  # target minus measured turn, wrapped to (-pi, pi]
    contact_force_pn: jnp.ndarray  # (2,)
    within_steps: jnp.ndarray  # int32 consecutive steps within the tolerance
    steps: jnp.ndarray  # int32
    light_dose_mj_per_um2: jnp.ndarray  # the cell's light dose so far this episode (``otgym.physics.light_dose``)


def wrap(angle):
    return jnp.arctan2(jnp.sin(angle), jnp.cos(angle))


def _rotate(vectors, angle):
    """Rotate (..., 2) vectors by ``angle`` (counter-clockwise in x-right, y-up terms)."""
    cos, sin = jnp.cos(angle), jnp.sin(angle)
    return jnp.stack(
        [cos * vectors[..., 0] - sin * vectors[..., 1], sin * vectors[..., 0] + cos * vectors[..., 1]], axis=-1
    )


def make_params(config: OrientConfig) -> OrientParams:
    """Build the scene (host work, once) and the formation's trap offsets."""
    scene = sc.build_scene(config.scene)
    centre = scene.start_candidates_um[0]
    state = sc.reset_at(scene, jax.random.PRNGKey(0), centre, 0.0)
    return OrientParams(scene, state.physics.trap_xy_um - centre, config)


def grip_angle(params: OrientParams, pose):
    """The angle of the axis from robot a's centre to robot b's (pose (..., N, 3))."""
    a, b = params.scene.robots
    axis = pose[..., b, :2] - pose[..., a, :2]
    return jnp.arctan2(axis[..., 1], axis[..., 0])


def _reset_one(key, params: OrientParams):
    config, scene = params.config, params.scene
    place_key, heading_key, size_key, sign_key, scene_key = jax.random.split(key, 5)
    dtype = scene.start_candidates_um.dtype
    centre = scene.start_candidates_um[jax.random.randint(place_key, (), 0, scene.start_candidates_um.shape[0])]
    heading = jax.random.uniform(heading_key, (), dtype, -jnp.pi, jnp.pi)
    low, high = np.deg2rad(config.target_min_deg), np.deg2rad(config.target_max_deg)
    size = jax.random.uniform(size_key, (), dtype, low, high)
    target = jnp.where(jax.random.bernoulli(sign_key), size, -size)
    scene_state = sc.reset_at(scene, scene_key, centre, heading)
    zero = jnp.zeros((), dtype)
    return OrientState(
        scene=scene_state,
        centre_um=centre,
        heading_rad=heading,
        grip_start_rad=grip_angle(params, scene_state.physics.pose),
        target_rad=target,
        command_rad=zero,
        turn_rad_s=zero,
        error_rad=target,
        contact_force_pn=jnp.zeros(2, dtype),
        within_steps=jnp.zeros((), jnp.int32),
        steps=jnp.zeros((), jnp.int32),
        light_dose_mj_per_um2=zero,
    )


def reset_batch(key, params: OrientParams, n_envs: int):
    """``n_envs`` fresh episodes: the gripped cell at a random place with room for the
    assembly, at a random heading, with a random target turn. Returns (obs (E, 17), state)."""
    state = jax.vmap(lambda k: _reset_one(k, params))(jax.random.split(key, n_envs))
    return observe_batch(params, state), state


def _observe(params: OrientParams, state: OrientState):
    config, scene = params.config, params.scene
    model = scene.model
    frame = state.heading_rad + state.command_rad
    pose = state.scene.physics.pose
    handles = ph.sphere_positions_um(model, pose)[np.asarray(model.trap_sphere, int)]
    trap_vectors = _rotate(handles - state.scene.physics.trap_xy_um, -frame) / config.scene.trap_law.escape_distance
    offset = _rotate(pose[scene.payload, :2] - state.centre_um, -frame) / config.scene.cell_radius_um
    fastest = np.deg2rad(max(config.turn_speeds_deg_s))
    return jnp.concatenate(
        [
            jnp.stack([jnp.sin(state.error_rad), jnp.cos(state.error_rad), state.turn_rad_s / fastest]),
            trap_vectors.reshape(-1),
            state.contact_force_pn / FORCE_SCALE_PN,
            offset,
            jnp.stack([state.within_steps / config.hold_steps, state.steps / config.max_steps]),
        ]
    ).astype(jnp.float32)


def observe_batch(params: OrientParams, state: OrientState):
    return jax.vmap(lambda s: _observe(params, s))(state)


def step_batch(key, state: OrientState, action, params: OrientParams):
    """Step E environments with integer actions (E,) (clipped to the action range).
    Returns obs, state, reward, terminated, truncated, info (flat, (E,) arrays)."""
    config = params.config
    period = config.scene.control_period_s
    dtype = state.command_rad.dtype
    speeds = jnp.asarray(config.angular_speeds_rad_s(), dtype)
    turn = speeds[jnp.clip(jnp.asarray(action, jnp.int32), 0, config.n_actions - 1)]
    command = state.command_rad + turn * period
    frame = state.heading_rad + command
    target_xy = state.centre_um[:, None] + _rotate(params.offsets_um[None], frame[:, None])
    velocity = (target_xy - state.scene.physics.trap_xy_um) / period
    scene_state, events = sc.step_batch(params.scene, state.scene, velocity, key)
    measured = wrap(grip_angle(params, scene_state.physics.pose) - state.grip_start_rad)
    error = wrap(state.target_rad - measured)
    failed = events.failed
    beam = ld.TrapBeam.of_trap_law(config.scene.trap_law)
    intensity = ld.cell_intensity_mw_per_um2(
        beam,
        scene_state.physics.trap_xy_um,
        scene_state.physics.pose[:, params.scene.payload, :2],
        config.scene.cell_radius_um,
    )
    dose = state.light_dose_mj_per_um2 + period * intensity
    within = jnp.where(jnp.abs(error) <= np.deg2rad(config.tolerance_deg), state.within_steps + 1, 0)
    goal = (within >= config.hold_steps) & ~failed
    steps = state.steps + 1
    terminated = failed | goal
    truncated = (steps >= config.max_steps) & ~terminated
    new = OrientState(
        scene_state,
        state.centre_um,
        state.heading_rad,
        state.grip_start_rad,
        state.target_rad,
        command,
        turn,
        error,
        events.contact_force_pn,
        within.astype(jnp.int32),
        steps,
        dose,
    )
    weights = config.reward
    reward = (
        weights.time
        + weights.progress * (jnp.abs(state.error_rad) - jnp.abs(error))
        + jnp.where(failed, weights.failure, 0.0)
        + jnp.where(goal, weights.goal, 0.0)
    )
    info = {
        "success": goal,
        "failed": failed,
        "angle_error_rad": error,
        "turn_rad": measured,
        "time_s": steps * period,
        "light_dose_mj_per_um2": dose,
        "contact_force_pn": events.contact_force_pn,
        "trap_distance_um": events.trap_distance_um,
    }
    return observe_batch(params, new), new, reward.astype(jnp.float32), terminated, truncated, info


def auto_reset(key, params: OrientParams, obs, state: OrientState, done):
    """Replace finished environments by fresh episodes (computed only when any is done)."""

    def fresh(_):
        new_obs, new_state = reset_batch(key, params, done.shape[0])
        pick = lambda a, b: jnp.where(done.reshape(done.shape + (1,) * (a.ndim - 1)), a, b)  # noqa: E731
        return pick(new_obs, obs), jax.tree.map(pick, new_state, state)

    return jax.lax.cond(jnp.any(done), fresh, lambda _: (obs, state), None)
