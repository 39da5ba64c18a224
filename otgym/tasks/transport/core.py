"""The transport task core shared by ``SpeedControl`` and ``CellTransport`` (paper
section II-C): two robots pinching a cell follow a segment of the planned path
through the chip, in the ``transport`` scene (``otgym.sim.scene``).

Everything here is batched over a leading environment axis E and built on
``scene.step_batch`` (one noise key per batch, the physics core's fast layout); the
single-environment API is the batch of one. Pure and jittable: ``params`` is a
pytree (scene, dense path, formation offsets) with the ``TaskConfig`` static.

Observation (21 values, in the path frame at the commanded progress, normalised to
order one): segment progress; commanded speed over the fastest level; cell offset
from the formation centre (um); the four handle-to-trap vectors over the trap's escape
distance; the two robot-cell contact forces over the band's top (10 pN); the local
flow at the cell over the fastest level; the path's turn over the next 5 um (rad);
the nearest obstacle's position (over 50 um) and velocity (over the fastest level).
This extends the original release's 5 values (progress, step size, robot-cell
distance, yaw error, robot separation) with what the paper's text lists (robot, cell
and obstacle positions) and the trap and flow state that decide trap loss.

Reward per step (weights in ``RewardWeights``; terms of the paper and its release):
time cost; speed bonus proportional to speed; contact force inside the safe band
(0.05-10 pN) rewarded, outside penalised per robot; the fraction of handles farther
than ``deviation_limit_um`` from their traps penalised; a failure (trap loss, cell
detached, obstacle or wall collision) penalised and ending the episode; a goal bonus.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from otgym import physics as ph
from otgym.physics import light_dose as ld
from otgym.planning import formation as fm
from otgym.sim import scene as sc
from otgym.tasks.transport.presets import TaskConfig
from otgym.tasks.transport.route_start import route_start

OBS_SIZE = 21
LOOKAHEAD_UM = 5.0
OBSTACLE_SCALE_UM = 50.0
OBSTACLE_SPOTS = 1024
"""Obstacles start at one of this many spots drawn once (seeded) from the scene's
free spots: drawing from all of them (about 40,000 on the default chip) made a
reset 30 times costlier than a control step."""


@struct.dataclass
class TransportParams:
    scene: sc.Scene
    path: fm.DensePath
    offsets_um: jnp.ndarray  # (T, 2) trap positions in the formation frame
    config: TaskConfig = struct.field(pytree_node=False)


@struct.dataclass
class TransportState:
    scene: sc.SceneState
    start_arc_um: jnp.ndarray  # segment start on the path
    arc_um: jnp.ndarray  # progress: commanded (SpeedControl) or the cell's (CellTransport)
    speed_um_s: jnp.ndarray  # last commanded speed along the path
    contact_force_pn: jnp.ndarray  # (2,) robot-cell contact forces of the last step
    steps: jnp.ndarray  # int32 control steps in this episode
    light_dose_mj_per_um2: jnp.ndarray  # the cell's light dose so far this episode (``otgym.physics.light_dose``)


def make_params(config: TaskConfig) -> TransportParams:
    """Build the scene and plan the path (A* + B-spline on the chip image, for the
    whole assembly); raises ValueError if the route is shorter than a segment."""
    scene = sc.build_scene(config.scene)
    spots = np.asarray(scene.obstacle_candidates_um)
    if len(spots) > OBSTACLE_SPOTS:
        chosen = np.random.default_rng(0).choice(len(spots), OBSTACLE_SPOTS, replace=False)
        scene = scene.replace(obstacle_candidates_um=jnp.asarray(spots[np.sort(chosen)]))
    start = route_start(scene, config.scene, config.start_um, config.goal_um)
    path = start.path
    if float(path.length_um) < config.segment_um:
        raise ValueError(
            f"planned path ({float(path.length_um):.1f} um) is shorter than segment_um={config.segment_um}"
        )
    return TransportParams(scene, path, start.offsets_um, config)


def segment_end(params: TransportParams, state: TransportState):
    return jnp.minimum(state.start_arc_um + params.config.segment_um, params.path.length_um)


def reset_batch(key, params: TransportParams, n_envs: int):
    """``n_envs`` fresh episodes: each a random segment of the path, the assembly
    placed on its start facing along it. Returns (obs (E, 21), state)."""
    start_key, scene_key = jax.random.split(key)
    room = params.path.length_um - params.config.segment_um
    starts = jax.random.uniform(start_key, (n_envs,), params.path.arc_um.dtype) * room
    scene_state = jax.vmap(
        lambda k, s: sc.reset_at(params.scene, k, fm.point_at(params.path, s), fm.heading_at(params.path, s))
    )(jax.random.split(scene_key, n_envs), starts)
    zeros = jnp.zeros_like(starts)
    state = TransportState(
        scene_state, starts, starts, zeros, jnp.zeros((n_envs, 2), starts.dtype), jnp.zeros(n_envs, jnp.int32), zeros
    )
    return observe_batch(params, state), state


def _rotate(vectors, angle):
    cos, sin = jnp.cos(angle), jnp.sin(angle)
    return jnp.stack(
        [cos * vectors[..., 0] + sin * vectors[..., 1], -sin * vectors[..., 0] + cos * vectors[..., 1]], axis=-1
    )  # into a frame at ``angle``


def _observe(params: TransportParams, state: TransportState):
    config, scene, path = params.config, params.scene, params.path
    model = scene.model
    top_speed = max(config.speed_levels_um_s)
    pose = state.scene.physics.pose
    centre = fm.point_at(path, state.arc_um)
    heading = fm.heading_at(path, state.arc_um)
    cell_xy = pose[scene.payload, :2]
    handles = ph.sphere_positions_um(model, pose)[np.asarray(model.trap_sphere, int)]
    trap_vectors = _rotate(handles - state.scene.physics.trap_xy_um, heading) / config.scene.trap_law.escape_distance
    flow = _rotate(model.flow.velocity_um_s(cell_xy[None])[0], heading) / top_speed
    turn = fm.heading_at(path, state.arc_um + LOOKAHEAD_UM) - heading
    turn = jnp.arctan2(jnp.sin(turn), jnp.cos(turn))
    if scene.obstacles:
        obstacles = np.asarray(scene.obstacles)
        relative = pose[obstacles, :2] - cell_xy
        nearest = jnp.argmin(jnp.linalg.norm(relative, axis=-1))
        velocity = (
            state.scene.obstacle_propulsion_um_s[nearest]
            + model.flow.velocity_um_s(pose[obstacles[0] + nearest, None, :2])[0]
        )
        obstacle = jnp.concatenate(
            [
                jnp.clip(_rotate(relative[nearest], heading) / OBSTACLE_SCALE_UM, -1, 1),
                _rotate(velocity, heading) / top_speed,
            ]
        )
    else:
        obstacle = jnp.zeros(4, pose.dtype)
    progress = (state.arc_um - state.start_arc_um) / config.segment_um
    return jnp.concatenate(
        [
            jnp.stack([progress, state.speed_um_s / top_speed]),
            _rotate(cell_xy - centre, heading),
            trap_vectors.reshape(-1),
            state.contact_force_pn / config.force_band_pn[1],
            flow,
            turn[None],
            obstacle,
        ]
    ).astype(jnp.float32)


def observe_batch(params: TransportParams, state: TransportState):
    return jax.vmap(lambda s: _observe(params, s))(state)


def reward_terms(config: TaskConfig, events: sc.SceneEvents, speed, failed, goal, cell_behind_um=None) -> dict:
    """Each term of the per-step reward (E,), weighted, by name; they sum to the reward.
    ``cell_behind_um`` (E,): how far the cell sits behind the formation's centre along
    the path after the step (observation entry 2, negated); None counts as 0."""
    weights = config.reward
    low, high = config.force_band_pn
    force = events.contact_force_pn
    in_band = (force >= low) & (force <= high)
    deviation = jnp.mean(events.trap_distance_um > config.deviation_limit_um, axis=-1)
    fraction = events.trap_distance_um / config.scene.trap_law.escape_distance
    margin = jnp.sum(jnp.maximum(fraction - weights.trap_margin_fraction, 0.0), axis=-1) / 0.1
    zeros = jnp.zeros(force.shape[:-1], force.dtype)
    behind = zeros if cell_behind_um is None else cell_behind_um
    cell_margin = jnp.maximum(behind - weights.cell_margin_um, 0.0) / 0.1
    return {
        "time": zeros + weights.time,
        "speed": zeros + weights.speed * speed / max(config.speed_levels_um_s),
        "force_in_band": weights.force_in_band * jnp.all(in_band, axis=-1),
        "force_out_of_band": weights.force_out_of_band * jnp.sum(~in_band, axis=-1),
        "handle_deviation": weights.handle_deviation * deviation,
        "trap_margin": weights.trap_margin * margin,
        "cell_margin": weights.cell_margin * cell_margin,
        "failure": jnp.where(failed, weights.failure, 0.0),
        "goal": jnp.where(goal, weights.goal, 0.0),
    }


def _reward(config: TaskConfig, events: sc.SceneEvents, speed, failed, goal, cell_behind_um):
    return sum(reward_terms(config, events, speed, failed, goal, cell_behind_um).values())


def cell_intensity_mw_per_um2(params: TransportParams, scene_state: sc.SceneState):
    """The light intensity (E,) on the carried cell from the four handle traps, each a
    beam of the scene's trap law (``otgym.physics.light_dose``)."""
    scene_config = params.config.scene
    beam = ld.TrapBeam.of_trap_law(scene_config.trap_law)
    physics = scene_state.physics
    cell_xy = physics.pose[:, params.scene.payload, :2]
    return ld.cell_intensity_mw_per_um2(beam, physics.trap_xy_um, cell_xy, scene_config.cell_radius_um)


def advance_batch(key, params: TransportParams, state: TransportState, trap_velocity_um_s, arc_of, speed_um_s):
    """Step the scenes with trap velocities (E, T, 2); ``arc_of(new_scene_state)``
    gives the new progress (E,). Returns obs, state, reward, terminated, truncated,
    info (a dict of (E,) arrays and the step's SceneEvents)."""
    scene_state, events = sc.step_batch(params.scene, state.scene, trap_velocity_um_s, key)
    arc = arc_of(scene_state)
    dose = state.light_dose_mj_per_um2 + params.config.scene.control_period_s * cell_intensity_mw_per_um2(
        params, scene_state
    )
    new = TransportState(
        scene_state, state.start_arc_um, arc, speed_um_s, events.contact_force_pn, state.steps + 1, dose
    )
    failed = events.failed
    goal = (arc >= segment_end(params, new) - 1e-3) & ~failed
    terminated = failed | goal
    truncated = (new.steps >= params.config.max_steps) & ~terminated
    obs = observe_batch(params, new)
    reward = _reward(params.config, events, speed_um_s, failed, goal, -obs[:, 2])
    info = {
        "success": goal,
        "failed": failed,
        "progress": (arc - state.start_arc_um) / params.config.segment_um,
        "time_s": new.steps * params.config.scene.control_period_s,
        "light_dose_mj_per_um2": dose,
        "events": events,
    }
    return obs, new, reward.astype(jnp.float32), terminated, truncated, info


def auto_reset(key, params: TransportParams, obs, state: TransportState, done):
    """Replace finished environments by fresh episodes (computed only when any is done)."""

    def fresh(_):
        new_obs, new_state = reset_batch(key, params, done.shape[0])
        pick = lambda a, b: jnp.where(done.reshape(done.shape + (1,) * (a.ndim - 1)), a, b)  # noqa: E731
        return pick(new_obs, obs), jax.tree.map(pick, new_state, state)

    return jax.lax.cond(jnp.any(done), fresh, lambda _: (obs, state), None)


def single_environment(reset_batch, step_batch):
    """The one-environment ``reset(key, params)`` and ``step(key, state, action, params)``
    of a task, as its batched functions run on a batch of one."""

    def reset(key, params: TransportParams):
        obs, state = reset_batch(key, params, 1)
        return obs[0], jax.tree.map(lambda a: a[0], state)

    def step(key, state: TransportState, action, params: TransportParams):
        batch = jax.tree.map(lambda a: a[None], state)
        out = step_batch(key, batch, jnp.asarray(action)[None], params)
        return jax.tree.map(lambda a: a[0], out)

    return reset, step
