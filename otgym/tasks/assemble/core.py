"""The ``assemble`` task's functional core: N beads held by N holographic traps are
moved into a target pattern (``otgym.tasks.assemble.config`` for the hardware limits
and their sources, ``otgym.tasks.assemble.plan`` for the patterns and the plan).

Physics: otgym's overdamped Brownian dynamics (``otgym.physics``): each bead a
``bead`` body (a polystyrene sphere, Stokes drag, thermal noise from the
fluctuation-dissipation theorem), bead-bead contact and van der Waals, the Gaussian
trap law with the per-trap stiffness of the shared power. The field is open fluid at
rest (no walls, no flow: a closed sample chamber away from its surfaces).

An episode: beads start in distinct random cells of the field (``start_cell_um``,
jittered, at least ``min_separation_um`` apart), each in its own trap; the pattern is
placed at the field's centre at a random angle; the beads are assigned to its targets
(swap-stable, ``plan.swap_stable_assignment``). Each control step is one SLM frame:
the agent picks a pace (``pace_levels_um``: how far the trap with the longest way
jumps), every trap jumps at the frame's start to ``start + s (goal - start)`` at the
new common progress s, and the physics runs the frame with the traps still (trap
velocity zero). The episode ends when s reaches 1 (success if the RMS bead-target
error is below ``placement_tolerance_um`` and nothing failed) or on a failure: a bead
farther than ``lost_distance`` from its trap at a frame's end (lost), or two beads
touching during a frame (a collision). It is truncated after ``max_steps``.

Observation (``OBS_SIZE`` = 9 values, the same for any N): progress s; the longest
remaining way (um / 10); the last pace over the largest level; the mean and the
largest bead-trap distance over the waist; the RMS bead-target error (um); the
smallest bead-bead surface gap over the bead diameter (clipped at 2); the per-trap
stiffness (pN/um / 10); the elapsed fraction of ``max_steps``.

Info (leading axis E): ``success``, ``failed``, ``progress``, ``time_s``,
``rms_error_um`` (RMS bead-target distance), ``beads_lost`` and ``collisions`` (this
episode's counts: beads lost, bead pairs that touched), ``max_trap_distance_um`` (the
largest bead-trap distance during the frame: right after a jump, the jump).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from otgym import physics as ph
from otgym.tasks.assemble import plan
from otgym.tasks.assemble.config import AssembleConfig

OBS_SIZE = 9


@struct.dataclass
class AssembleParams:
    model: ph.Model
    pattern_um: jnp.ndarray  # (N, 2) targets about the origin
    config: AssembleConfig = struct.field(pytree_node=False)


@struct.dataclass
class AssembleState:
    physics: ph.PhysicsState  # bead poses (N, 3) and trap centres (N, 2)
    start_um: jnp.ndarray  # (N, 2) trap positions at the episode's start
    goal_um: jnp.ndarray  # (N, 2) each trap's assigned target
    progress: jnp.ndarray  # () common progress s of the synchronised moves
    pace_um: jnp.ndarray  # () last pace
    beads_lost: jnp.ndarray  # () int32
    collisions: jnp.ndarray  # () int32
    steps: jnp.ndarray  # () int32


def build_model(config: AssembleConfig) -> ph.Model:
    """The physics model: ``n_beads`` beads, one trap on each, at the shared power."""
    bodies = [ph.bead(f"bead_{i}", radius_um=config.bead_radius_um) for i in range(config.n_beads)]
    physics = ph.PhysicsConfig(
        dt_s=config.frame_period_s / config.substeps,
        substeps=config.substeps,
        temperature_k=config.temperature_k,
        viscosity_pa_s=config.viscosity_pa_s,
        trap_law=config.trap_law,
    )
    return ph.build_model(bodies, physics)


def make_params(config: AssembleConfig) -> AssembleParams:
    model = build_model(config)
    pattern = plan.pattern_um(config.pattern, config.n_beads, config.target_spacing_um)
    extent = np.max(np.linalg.norm(pattern, axis=1)) + config.bead_radius_um
    if 2 * extent > config.arena_um:
        raise ValueError(f"the {config.pattern} of {config.n_beads} beads does not fit in arena_um={config.arena_um}")
    return AssembleParams(model, jnp.asarray(pattern, model.sphere_radius_um.dtype), config)


def _starts(key, config: AssembleConfig, dtype):
    """N bead centres in distinct jittered cells, at least ``min_separation_um`` apart."""
    cells = config.cells_per_side
    cell_key, jitter_key = jax.random.split(key)
    chosen = jax.lax.top_k(jax.random.uniform(cell_key, (cells * cells,)), config.n_beads)[1]  # distinct cells
    corner = (config.arena_um - cells * config.start_cell_um) / 2
    centre = corner + (jnp.stack([chosen % cells, chosen // cells], axis=-1).astype(dtype) + 0.5) * config.start_cell_um
    half = 0.5 * (config.start_cell_um - config.min_separation_um) * 0.999
    return centre + jax.random.uniform(jitter_key, centre.shape, dtype, -half, half)


def reset_one(key, params: AssembleParams):
    config = params.config
    dtype = params.pattern_um.dtype
    start_key, angle_key = jax.random.split(key)
    start = _starts(start_key, config, dtype)
    angle = jax.random.uniform(angle_key, (), dtype, -jnp.pi, jnp.pi)
    cos, sin = jnp.cos(angle), jnp.sin(angle)
    rotated = params.pattern_um @ jnp.array([[cos, sin], [-sin, cos]], dtype)
    targets = rotated + config.arena_um / 2
    goal = targets[plan.swap_stable_assignment(start, targets)]
    pose = jnp.concatenate([start, jnp.zeros((config.n_beads, 1), dtype)], axis=1)
    zero = jnp.zeros((), dtype)
    count = jnp.zeros((), jnp.int32)
    return AssembleState(ph.PhysicsState(pose, start), start, goal, zero, zero, count, count, count)


def reset_batch(key, params: AssembleParams, n_envs: int):
    state = jax.vmap(lambda k: reset_one(k, params))(jax.random.split(key, n_envs))
    return observe_batch(params, state), state


def _bead_xy(state: AssembleState):
    return state.physics.pose[..., :2]


def rms_error_um(state: AssembleState):
    """RMS distance (E,) of the beads from their assigned targets."""
    return jnp.sqrt(jnp.mean(jnp.sum((_bead_xy(state) - state.goal_um) ** 2, axis=-1), axis=-1))


def _min_gap_um(params: AssembleParams, xy):
    n = params.config.n_beads
    if n < 2:
        return jnp.full(xy.shape[:-2], jnp.inf, xy.dtype)
    i, j = np.triu_indices(n, 1)
    distance = jnp.linalg.norm(xy[..., i, :] - xy[..., j, :], axis=-1)
    return jnp.min(distance, axis=-1) - 2 * params.config.bead_radius_um


def remaining_um(state: AssembleState):
    """The longest remaining way (E,) of any trap."""
    way = jnp.max(jnp.linalg.norm(state.goal_um - state.start_um, axis=-1), axis=-1)
    return way * (1 - state.progress)


def observe_batch(params: AssembleParams, state: AssembleState):
    config = params.config
    xy = _bead_xy(state)
    to_trap = jnp.linalg.norm(xy - state.physics.trap_xy_um, axis=-1)
    diameter = 2 * config.bead_radius_um
    stiffness = jnp.full_like(state.progress, config.trap_stiffness_pn_per_um / 10)
    return jnp.stack(
        [
            state.progress,
            remaining_um(state) / 10,
            state.pace_um / max(config.pace_levels_um),
            jnp.mean(to_trap, axis=-1) / config.waist_um,
            jnp.max(to_trap, axis=-1) / config.waist_um,
            rms_error_um(state),
            jnp.clip(_min_gap_um(params, xy) / diameter, 0.0, 2.0),
            stiffness,
            state.steps / config.max_steps,
        ],
        axis=-1,
    ).astype(jnp.float32)


def step_traps(key, params: AssembleParams, state: AssembleState, trap_xy_um, progress, pace_um):
    """One SLM frame for E environments: the traps jump to ``trap_xy_um`` (E, N, 2) at
    the frame's start and stand still through it. Returns obs, state, reward,
    terminated, truncated, info (see the module docstring)."""
    config, model = params.config, params.model
    dtype = state.physics.pose.dtype
    n_env = state.physics.pose.shape[0]
    jumped = state.physics.replace(trap_xy_um=jnp.asarray(trap_xy_um, dtype))
    physics, report = ph.control_step_batch(model, jumped, ph.Controls.zeros(model, n_env), key)
    lost_now = jnp.sum(report.trap_distance_um > config.lost_distance, axis=-1).astype(jnp.int32)
    touched = jnp.sum(report.contact, axis=-1).astype(jnp.int32)
    new = AssembleState(
        physics,
        state.start_um,
        state.goal_um,
        progress,
        pace_um,
        state.beads_lost + lost_now,
        state.collisions + touched,
        state.steps + 1,
    )
    error = rms_error_um(new)
    failed = (lost_now > 0) | (touched > 0)
    arrived = progress >= 1.0
    success = (
        arrived & ~failed & (error < config.placement_tolerance_um) & (new.beads_lost == 0) & (new.collisions == 0)
    )
    terminated = failed | arrived
    truncated = (new.steps >= config.max_steps) & ~terminated
    weights = config.reward
    reward = (
        weights.time
        + weights.progress * (progress - state.progress)
        + jnp.where(success, weights.success, 0.0)
        + jnp.where(failed, weights.failure, 0.0)
    )
    info = {
        "success": success,
        "failed": failed,
        "progress": progress,
        "time_s": new.steps.astype(dtype) * config.frame_period_s,
        "rms_error_um": error,
        "beads_lost": new.beads_lost,
        "collisions": new.collisions,
        "max_trap_distance_um": jnp.max(report.trap_distance_max_um, axis=-1),
    }
    return observe_batch(params, new), new, reward.astype(jnp.float32), terminated, truncated, info


def step_batch(key, state: AssembleState, action, params: AssembleParams):
    """One SLM frame with pace levels ``action`` (E,) int (clipped to the levels)."""
    config = params.config
    dtype = state.physics.pose.dtype
    levels = jnp.asarray(config.pace_levels_um, dtype)
    pace = levels[jnp.clip(jnp.asarray(action, jnp.int32), 0, config.n_actions - 1)]
    way = jnp.max(jnp.linalg.norm(state.goal_um - state.start_um, axis=-1), axis=-1)
    progress = jnp.minimum(state.progress + pace / jnp.maximum(way, 1e-6), 1.0)
    trap_xy = state.start_um + progress[:, None, None] * (state.goal_um - state.start_um)
    return step_traps(key, params, state, trap_xy, progress, pace)
