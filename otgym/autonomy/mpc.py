"""Model-predictive navigation of the interactive task, in pure JAX, with the scene's
own batched step as its model. The model's grip is calibrated to the real one's contact
force (``otgym.autonomy.grip_calibration``).

Method: predictive sampling (Howell, Gileadi, Tunyasuvunakool, Zakka, Erez, Tassa,
"Predictive Sampling: Real-time Behaviour Synthesis with MuJoCo", arXiv:2212.00541,
2022), the sampling-based MPC of MuJoCo MPC. The plan is a sequence of formation
actions, one per model step; each replan rolls out the warm-started plan (the last
plan shifted by one step), a few fixed manoeuvres (hold, back off, cruise on the
route) and noisy copies of the plan (Gaussian noise on knots every ``knot_steps``,
linearly interpolated), all as one batch of environments of the scene's
``step_batch``, and keeps the cheapest. Unlike MPPI's weighted average, the plan kept
is one that the model has rolled out: an average of "pass left" and "pass right" is
never executed.

Action per step (the formation's motion): speed along the route (um/s), lateral
offset of the formation's centre from the route (um; clipped to the free room of the
channel on each side), and rotation of the formation from the route's heading (rad).
The traps' places are the task's formation (``InteractiveTask.offsets_um``) at that
pose, and each trap moves at the constant velocity that reaches its place at the end
of the step, capped at the trap-speed limit: the navigator's increments, at the
model's step.

The model (``model_scene_config``): the task's scene with
* a deterministic step (temperature 0: no Brownian noise; one rollout per candidate);
* a coarser physics step, ``model_dt_s`` = 2 ms instead of 0.25 ms, which the scene's
  stability rules (``otgym.physics.model.max_stable_dt_s``) accept only with softer
  traps: a Gaussian law of 5 pN/um and 2 um waist, whose largest force (3.0 pN) is a
  third of the real traps' (9.1 pN). Handles are placed so that each starts with the
  force it has in the task (``model_trap_xy_um``): at the 20 ms scale of a tick the
  traps' 0.25 and 2.5 ms relaxation times are both instant, so forces, not offsets,
  carry over. A handle that the model loses has reached a third of the real escape
  force: the model's trap loss is the margin to the law's bend;
* the model's control step is the replan period ``step_s`` (0.1 s: 50 physics steps
  of 2 ms); 8x fewer physics steps per simulated second than the task's 0.25 ms.
Obstacles move in the model by the task's bounded propulsion along tracks predicted
from their observed motion (``otgym.autonomy.obstacle_prediction``), never along the
scenario's own tracks.

Costs per rollout (``MPCCosts``; summed over the steps of the horizon): the cell's
progress along the route (a reward: mean arc gained over the horizon); obstacle
clearance (quadratic below a margin, and a large cost per step of contact); wall
clearance of the assembly's spheres (quadratic below a margin; wall contact);
handle-to-trap distance relative to the model law's bend (quadratic above a fraction
of it; trap loss); robot-cell contact force above a limit (quadratic); the cell
leaving the grip; lateral offset and rotation (small, so the formation returns to the
route); smoothness (squared change of each action from step to step, the first
against the step already committed).

Latency: the replan that starts at one replan tick from that tick's observation is
executed from the next replan tick on; the step in between is the previous plan's
first step, which every rollout shares (``committed``). So a replan may take a whole
replan period of computing without the robots waiting for it.
"""

from __future__ import annotations

import dataclasses
import functools

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from otgym import physics as ph
from otgym.autonomy.route_frame import RouteData, cell_arc_um, clip_lateral, formation_places
from otgym.sim import scene as sc
from otgym.tasks.transport.scenario import ScenarioConfig, propulsion_um_s

PASS_OFFSETS_UM = (-6.0, -3.0, 3.0, 6.0)
"""Lateral offsets of the passing manoeuvres (cruise beside the route)."""
N_FIXED_MANOEUVRES = 7 + len(PASS_OFFSETS_UM)
"""Candidates: the warm-started plan, hold, back off, cruise on the route, dash along
it, step aside to either side while holding, and cruise at each passing offset."""
SIDE_STEP_UM = 6.0
MOBILE_SPEED_UM_S = 1.0
"""An obstacle predicted this fast or faster counts as fully mobile in the margin's growth."""
ACTIONS = ("speed_um_s", "lateral_um", "rotation_rad")


@dataclasses.dataclass(frozen=True)
class MPCConfig:
    """Sizes and limits of the controller (static under jit)."""

    n_rollouts: int = 32
    plan_steps: int = 24
    """Steps of the plan after the committed one: the horizon is (1 + plan_steps) * step_s."""
    step_s: float = 0.1
    """The model's control step and the replan period (a whole number of task ticks)."""
    knot_steps: int = 4
    """Noise is drawn on knots this many steps apart and interpolated linearly."""
    model_dt_s: float = 2e-3
    model_trap_stiffness_pn_per_um: float = 5.0
    model_trap_waist_um: float = 2.0
    cruise_speed_um_s: float = 6.0
    """Speed of the cruise manoeuvre and of the first plan after the grip."""
    min_speed_um_s: float = -8.0
    max_speed_um_s: float = 10.0
    max_lateral_um: float = 40.0
    max_rotation_rad: float = 0.25
    max_lateral_speed_um_s: float = 4.0
    max_rotation_speed_rad_s: float = 0.2
    noise_speed_um_s: float = 2.5
    noise_lateral_um: float = 3.0
    noise_rotation_rad: float = 0.05
    max_trap_speed_um_s: float = 20.0
    room_margin_um: float = 0.5
    """The lateral offset keeps the assembly's bounding circle this far from the walls."""
    far_gap_um: float = 30.0
    far_replan_steps: int = 5
    """With every obstacle farther than ``far_gap_um`` from the assembly, an environment
    samples new plans only every this many steps and otherwise goes on with its last
    plan, shifted (it still replans at once when an obstacle comes within the gap)."""

    def __post_init__(self):
        if not (isinstance(self.n_rollouts, int) and self.n_rollouts > N_FIXED_MANOEUVRES):
            raise ValueError(f"n_rollouts must be an integer above {N_FIXED_MANOEUVRES}, got {self.n_rollouts!r}")
        for name in ("plan_steps", "knot_steps", "far_replan_steps"):
            value = getattr(self, name)
            if not (isinstance(value, int) and value >= 1):
                raise ValueError(f"{name} must be a positive integer, got {value!r}")
        for name in (
            "step_s",
            "model_dt_s",
            "model_trap_stiffness_pn_per_um",
            "model_trap_waist_um",
            "cruise_speed_um_s",
            "max_speed_um_s",
            "max_lateral_um",
            "max_rotation_rad",
            "max_lateral_speed_um_s",
            "max_rotation_speed_rad_s",
            "max_trap_speed_um_s",
        ):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and np.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive number, got {value!r}")
        for name in ("noise_speed_um_s", "noise_lateral_um", "noise_rotation_rad", "room_margin_um", "far_gap_um"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and np.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be a non-negative number, got {value!r}")
        if not self.min_speed_um_s <= 0 < self.cruise_speed_um_s <= self.max_speed_um_s:
            raise ValueError(
                f"need min_speed_um_s <= 0 < cruise_speed_um_s <= max_speed_um_s, got "
                f"{self.min_speed_um_s}, {self.cruise_speed_um_s}, {self.max_speed_um_s}"
            )
        if self.model_dt_s > self.step_s:
            raise ValueError(f"model_dt_s={self.model_dt_s} must not exceed step_s={self.step_s}")

    @property
    def horizon_s(self) -> float:
        return (1 + self.plan_steps) * self.step_s

    @property
    def model_substeps(self) -> int:
        return max(1, int(round(self.step_s / self.model_dt_s)))

    @property
    def substeps_per_replan(self) -> int:
        """Physics steps one environment's replan simulates: rollouts x horizon."""
        return self.n_rollouts * (1 + self.plan_steps) * self.model_substeps

    @property
    def model_trap_law(self) -> ph.TrapLaw:
        return ph.TrapLaw(
            "gaussian", stiffness_pn_per_um=self.model_trap_stiffness_pn_per_um, waist_um=self.model_trap_waist_um
        )


@struct.dataclass
class MPCCosts:
    """Weights of the cost terms (array leaves: changing them does not recompile)."""

    progress_per_um: float = 1.0
    obstacle_margin_um: float = 0.75
    """Clearance below which an obstacle costs, for one at rest after moving (parked),
    passed slowly..."""
    obstacle_pass_margin_s: float = 0.15
    """... plus the assembly's commanded speed along the route times this (the model errs
    more at speed) ..."""
    obstacle_idle_margin_um: float = 2.5
    """... plus this for one never seen moving (it may start towards the assembly) ..."""
    obstacle_speed_margin_s: float = 1.5
    """... plus its predicted speed times this (a moving obstacle's prediction errs more) ..."""
    obstacle_uncertainty_um_s: float = 0.5
    """... plus this per second into the horizon for one that is idle or moving (a
    prediction's error grows; a parked one stays put)."""
    obstacle_per_um2: float = 20.0
    obstacle_contact: float = 500.0
    lookahead_s: float = 8.0
    """Terminal cost: each obstacle's closest approach to the assembly, standing where
    the rollout ends, over this long beyond the horizon at its predicted velocity."""
    lookahead_margin_um: float = 3.0
    lookahead_per_um2: float = 5.0
    wall_margin_um: float = 0.5
    wall_per_um2: float = 5.0
    wall_contact: float = 5.0
    trap_margin: float = 0.6
    """Fraction of the distance to the model law's bend above which the handle costs."""
    trap_per_unit2: float = 50.0
    trap_lost: float = 500.0
    contact_force_limit_pn: float = 4.0
    contact_force_per_pn2: float = 5.0
    detached: float = 500.0
    lateral_per_um2: float = 0.002
    rotation_per_rad2: float = 5.0
    smooth_speed_per_um2_s2: float = 0.01
    smooth_lateral_per_um2: float = 0.05
    smooth_rotation_per_rad2: float = 2.0


COST_TERMS = ("progress", "obstacle", "lookahead", "wall", "trap", "contact_force", "detached", "offset", "smoothness")


def model_scene_config(scene_config: sc.SceneConfig, config: MPCConfig) -> sc.SceneConfig:
    """The task's scene as the planner's model: deterministic, ``model_dt_s`` steps,
    softer traps, one control step per replan period."""
    return dataclasses.replace(
        scene_config,
        dt_s=config.model_dt_s,
        control_period_s=config.step_s,
        temperature_k=0.0,
        trap_law=config.model_trap_law,
    )


def cap_rigid(vectors, limit):
    """Scale all of a formation's vectors (..., T, 2) by one factor so that the longest
    is at most ``limit``: capping each trap alone would shear the formation and pinch the cell."""
    longest = jnp.max(jnp.sqrt(jnp.sum(vectors**2, axis=-1)), axis=-1)[..., None, None]
    return vectors * jnp.minimum(1.0, limit / jnp.maximum(longest, 1e-12))


def rate_limited(plans, previous, config: MPCConfig):
    """Plans (..., L, 3) whose lateral offset and rotation change by at most
    ``max_lateral_speed_um_s`` and ``max_rotation_speed_rad_s`` per step, starting from
    ``previous`` (..., 3)."""
    step = jnp.asarray(
        [jnp.inf, config.max_lateral_speed_um_s * config.step_s, config.max_rotation_speed_rad_s * config.step_s],
        plans.dtype,
    )

    def limit(last, target):
        value = jnp.clip(target, last - step, last + step)
        return value, value

    first = jnp.broadcast_to(previous, plans.shape[:-2] + plans.shape[-1:])
    _, limited = jax.lax.scan(limit, first, jnp.moveaxis(plans, -2, 0))
    return jnp.moveaxis(limited, 0, -2)


def _scene_indices(scene: sc.Scene):
    bodies = np.asarray(scene.model.sphere_body)
    payload = np.flatnonzero(bodies <= scene.payload)
    obstacle_spheres = np.asarray([np.flatnonzero(bodies == o)[0] for o in scene.obstacles], int)
    return payload, obstacle_spheres


def obstacle_margin_um(costs: MPCCosts, tracks: dict, ahead_s, speed_um_s):
    """Clearance (N, K) below which each obstacle costs, ``ahead_s`` into the horizon
    with the assembly commanded at ``speed_um_s`` (N,) along the route."""
    mobile = jnp.clip(tracks["idle"] + tracks["speed_um_s"] / MOBILE_SPEED_UM_S, 0.0, 1.0)
    return (
        costs.obstacle_margin_um
        + costs.obstacle_pass_margin_s * jnp.abs(speed_um_s)[:, None]
        + costs.obstacle_idle_margin_um * tracks["idle"]
        + costs.obstacle_speed_margin_s * tracks["speed_um_s"]
        + costs.obstacle_uncertainty_um_s * ahead_s * mobile
    )


def step_cost_terms(scene: sc.Scene, costs: MPCCosts, state: sc.SceneState, events: sc.SceneEvents, margin_um):
    """Per-rollout cost terms (N,) of one model step's outcome that depend on the state
    alone (clearances, with the obstacles' margins (N, K); handle margin, contact force,
    detachment)."""
    model = scene.model
    payload, obstacle_spheres = _scene_indices(scene)
    xy = ph.sphere_positions_um(model, state.physics.pose)  # (N, S, 2)
    radius = model.sphere_radius_um
    between = jnp.sqrt(jnp.sum((xy[:, payload, None] - xy[:, None, obstacle_spheres]) ** 2, axis=-1))
    gap = jnp.min(between - radius[payload][:, None] - radius[obstacle_spheres][None], axis=1)  # (N, K)
    obstacle = costs.obstacle_per_um2 * jnp.sum(
        jnp.maximum(margin_um - gap, 0.0) ** 2, axis=-1
    ) + costs.obstacle_contact * jnp.sum(events.obstacle_touched | (gap <= 0.0), axis=-1)
    wall_gap = model.walls.distance_and_normal(xy[:, payload])[0] - radius[payload]
    wall = (
        costs.wall_per_um2 * jnp.sum(jnp.maximum(costs.wall_margin_um - wall_gap, 0.0) ** 2, axis=-1)
        + costs.wall_contact * events.wall_collision
    )
    bend_um = 0.5 * model.trap_law.waist_um
    trap = costs.trap_per_unit2 * jnp.sum(
        jnp.maximum(events.trap_distance_um / bend_um - costs.trap_margin, 0.0) ** 2, axis=-1
    ) + costs.trap_lost * jnp.any(events.trap_lost, axis=-1)
    contact = costs.contact_force_per_pn2 * jnp.sum(
        jnp.maximum(events.contact_force_pn - costs.contact_force_limit_pn, 0.0) ** 2, axis=-1
    )
    detached = costs.detached * events.cell_detached
    return {"obstacle": obstacle, "wall": wall, "trap": trap, "contact_force": contact, "detached": detached}


def lookahead_cost(scene: sc.Scene, costs: MPCCosts, state: sc.SceneState, tracks: dict):
    """Terminal cost (N,): for each obstacle, the closest approach of its predicted
    straight path over ``lookahead_s`` to the payload's spheres where they stand at the
    end of the rollout, penalised quadratically below ``lookahead_margin_um`` (a cost to
    go: an end state in an obstacle's way is worth less than one beside it)."""
    model = scene.model
    payload, obstacle_spheres = _scene_indices(scene)
    xy = ph.sphere_positions_um(model, state.physics.pose)
    spheres, obstacles = xy[:, payload], xy[:, obstacle_spheres]  # (N, P, 2), (N, K, 2)
    velocity = tracks["direction"] * tracks["speed_um_s"][..., None]  # (N, K, 2)
    relative = spheres[:, :, None] - obstacles[:, None]  # (N, P, K, 2)
    speed2 = jnp.sum(velocity**2, axis=-1)[:, None]  # (N, 1, K)
    when = jnp.clip(jnp.sum(relative * velocity[:, None], axis=-1) / jnp.maximum(speed2, 1e-9), 0.0, costs.lookahead_s)
    closest = jnp.sqrt(jnp.sum((relative - velocity[:, None] * when[..., None]) ** 2, axis=-1))
    radius = model.sphere_radius_um
    gap = jnp.min(closest - radius[payload][None, :, None] - radius[obstacle_spheres][None, None], axis=1)
    return costs.lookahead_per_um2 * jnp.sum(jnp.maximum(costs.lookahead_margin_um - gap, 0.0) ** 2, axis=-1)


def rollout(
    scene: sc.Scene,
    route: RouteData,
    offsets_um,
    costs: MPCCosts,
    state: sc.SceneState,
    tracks: dict,
    start,
    actions,
    *,
    config: MPCConfig,
    obstacle_config: ScenarioConfig,
):
    """Roll out N action sequences (N, H, 3) from N scene states with the model's
    ``step_batch``; ``start`` (N, 3): the formation's arc, lateral offset and rotation
    now; ``tracks``: predicted obstacle tracks (N, K, ...). Returns the final state and
    the cost terms (dict of (N,), ``COST_TERMS``) summed over the horizon."""
    step_s = config.step_s
    obstacles = np.asarray(scene.obstacles, int)
    cell_index = scene.payload
    arc0 = cell_arc_um(route, state.physics.pose[:, cell_index, :2], start[:, 0])
    key = jax.random.PRNGKey(0)  # the model is deterministic (temperature 0): the key draws zero noise

    def one_step(carry, inputs):
        action, ahead_s = inputs
        scene_state, arc, previous = carry
        speed, lateral, rotation = action[:, 0], action[:, 1], action[:, 2]
        arc_next = jnp.clip(arc + speed * step_s, 0.0, route.path.length_um)
        places = formation_places(route, offsets_um, arc_next, clip_lateral(route, arc_next, lateral), rotation)
        velocity = cap_rigid((places - scene_state.physics.trap_xy_um) / step_s, config.max_trap_speed_um_s)
        obstacle_xy = scene_state.physics.pose[:, obstacles, :2]
        flow = jax.vmap(scene.model.flow.velocity_um_s)(obstacle_xy)
        propulsion = propulsion_um_s(tracks, scene_state.time_s, obstacle_xy, flow, obstacle_config)
        new_state, events = sc.step_batch(scene, scene_state, velocity, key, propulsion)
        terms = step_cost_terms(scene, costs, new_state, events, obstacle_margin_um(costs, tracks, ahead_s, speed))
        change = action - previous
        terms["smoothness"] = (
            costs.smooth_speed_per_um2_s2 * change[:, 0] ** 2
            + costs.smooth_lateral_per_um2 * change[:, 1] ** 2
            + costs.smooth_rotation_per_rad2 * change[:, 2] ** 2
        )
        terms["offset"] = costs.lateral_per_um2 * lateral**2 + costs.rotation_per_rad2 * rotation**2
        progress = cell_arc_um(route, new_state.physics.pose[:, cell_index, :2], arc_next) - arc0
        return (new_state, arc_next, action), (terms, progress)

    first = jnp.stack([jnp.zeros_like(start[:, 0]), start[:, 1], start[:, 2]], axis=-1)
    ahead_s = step_s * jnp.arange(1, actions.shape[1] + 1, dtype=actions.dtype)
    (final, _, _), (terms, progress) = jax.lax.scan(
        one_step, (state, start[:, 0], first), (jnp.swapaxes(actions, 0, 1), ahead_s)
    )
    summed = {name: jnp.sum(value, axis=0) for name, value in terms.items()}
    summed["lookahead"] = lookahead_cost(scene, costs, final, tracks)
    summed["progress"] = -costs.progress_per_um * jnp.mean(progress, axis=0)
    return final, {name: summed[name] for name in COST_TERMS}


def interpolation_matrix(plan_steps: int, knot_steps: int) -> np.ndarray:
    """(plan_steps, n_knots) weights of linear interpolation from knots every ``knot_steps``."""
    n_knots = -(-plan_steps // knot_steps) + 1
    position = np.arange(plan_steps) / knot_steps
    low = np.floor(position).astype(int)
    frac = position - low
    weights = np.zeros((plan_steps, n_knots))
    weights[np.arange(plan_steps), low] = 1.0 - frac
    weights[np.arange(plan_steps), np.minimum(low + 1, n_knots - 1)] += frac
    return weights


def candidates(key, nominal, config: MPCConfig):
    """(B, R, L, 3) candidate plans: the nominal, hold, back off (the whole horizon),
    cruise and dash on the route, side-steps of ``SIDE_STEP_UM`` either way while
    holding, cruise at each of ``PASS_OFFSETS_UM`` beside the route (the rate limit
    makes the offsets gradual), then the nominal plus knot noise (half of them at a
    quarter of the scale), clipped to the limits."""
    n_env, plan_steps, _ = nominal.shape
    n_noisy = config.n_rollouts - N_FIXED_MANOEUVRES
    weights = jnp.asarray(interpolation_matrix(plan_steps, config.knot_steps), nominal.dtype)
    scale = jnp.asarray([config.noise_speed_um_s, config.noise_lateral_um, config.noise_rotation_rad], nominal.dtype)
    shrink = jnp.where(jnp.arange(n_noisy) % 2 == 0, 1.0, 0.25).astype(nominal.dtype)
    knots = jax.random.normal(key, (n_env, n_noisy, weights.shape[1], 3), nominal.dtype) * scale
    noise = jnp.einsum("lk,bnkd->bnld", weights, knots) * shrink[None, :, None, None]
    noisy = nominal[:, None] + noise
    hold = nominal.at[..., 0].set(0.0)
    back = nominal.at[..., 0].set(config.min_speed_um_s)
    cruise = jnp.zeros_like(nominal).at[..., 0].set(config.cruise_speed_um_s)
    dash = cruise.at[..., 0].set(config.max_speed_um_s)
    left, right = (hold.at[..., 1].add(side * SIDE_STEP_UM) for side in (1.0, -1.0))
    passing = [cruise.at[..., 1].set(offset) for offset in PASS_OFFSETS_UM]
    fixed = jnp.stack([nominal, hold, back, cruise, dash, left, right, *passing], axis=1)
    plans = jnp.concatenate([fixed, noisy], axis=1)
    low = jnp.asarray([config.min_speed_um_s, -config.max_lateral_um, -config.max_rotation_rad], nominal.dtype)
    high = jnp.asarray([config.max_speed_um_s, config.max_lateral_um, config.max_rotation_rad], nominal.dtype)
    return jnp.clip(plans, low, high)


def replan(
    scene: sc.Scene,
    route: RouteData,
    offsets_um,
    costs: MPCCosts,
    state: sc.SceneState,
    tracks: dict,
    start,
    committed,
    nominal,
    key,
    *,
    config: MPCConfig,
    obstacle_config: ScenarioConfig,
):
    """One replan of B environments: ``state`` (B) and ``tracks`` (B, K, ...) as the
    model's start, ``start`` (B, 3) the formation now, ``committed`` (B, 3) the action
    executed until the next replan, ``nominal`` (B, L, 3) the warm start. Returns the
    best plan (B, L, 3), its cost terms (dict of (B,)), every candidate's total cost
    (B, R) and the model's state (B) at the end of the best plan's rollout (the
    committed step, then the plan). Ties go to the first candidate: with every weight
    zero the plan is the nominal one (as rate-limited and clipped), rolled out."""
    n_env = nominal.shape[0]
    plans = rate_limited(candidates(key, nominal, config), committed[:, None], config)
    n_rollouts = plans.shape[1]
    repeat = lambda a: jnp.repeat(a, n_rollouts, axis=0)  # noqa: E731
    actions = jnp.concatenate([jnp.broadcast_to(committed[:, None, None], (n_env, n_rollouts, 1, 3)), plans], axis=2)
    final, terms = rollout(
        scene,
        route,
        offsets_um,
        costs,
        jax.tree.map(repeat, state),
        jax.tree.map(repeat, tracks),
        repeat(start),
        actions.reshape(n_env * n_rollouts, -1, 3),
        config=config,
        obstacle_config=obstacle_config,
    )
    terms = {name: value.reshape(n_env, n_rollouts) for name, value in terms.items()}
    total = sum(terms.values())
    best = jnp.argmin(total, axis=1)
    pick = lambda a: jnp.take_along_axis(a, best[:, None], axis=1)[:, 0]  # noqa: E731
    best_plan = jnp.take_along_axis(plans, best[:, None, None, None], axis=1)[:, 0]
    rows = jnp.arange(n_env) * n_rollouts + best
    predicted = jax.tree.map(lambda a: a[rows], final)
    return best_plan, {name: pick(value) for name, value in terms.items()}, total, predicted


@functools.cache
def make_replan(config: MPCConfig, obstacle_config: ScenarioConfig):
    """``replan`` jitted for one configuration; call it as ``replan`` without the keywords.
    One jitted function per configuration, so navigators built alike share its compilations."""
    return jax.jit(functools.partial(replan, config=config, obstacle_config=obstacle_config))
