"""The ``sort-cells`` core: cells of two kinds (two radii) arrive with the chip's flow at
its inlet, and a manipulator (robots gripping a cell, or a trap holding it: ``config``)
moves each across the flow so that it leaves by its kind's outlet.

The cells. Up to ``max_cells`` spheres, each carried by the chip's focal-plane flow
(``otgym.sim.fields``, sampled at its centre) with Brownian motion of its Stokes-Einstein
coefficient, integrated with ``substeps`` explicit Euler steps per control step; a cell
closer to a wall than its radius is put back at its radius along the wall normal. A cell
within ``exit_distance_um`` of an outlet port leaves by it; one in the chip longer than
``max_residence_s`` is lost (stalled), as is an arrival that finds ``max_cells`` cells in
the chip. Arrivals: one at reset, then one every ``arrival_interval_s``, its kind drawn
with probability one half, at a random place across the inlet channel (where the larger
kind fits), 1.5 larger radii in from the inlet.

The manipulator acts on the target: the cell farthest downstream of those still upstream
of the junction (x below the junction's). Each step the action is 0 (let go), 1 (move the
target toward the side of kind 0's outlet) or 2 (toward kind 1's). Holding a cell starts
with ``grip_time_s`` of taking hold (reset when the action lets go or the target
changes); from then on the held cell moves across the flow, along y, at the kind's
manipulation speed on top of the flow, and receives the kind's held-cell intensity
(``config.manipulation``): its dose grows by intensity x the time held. No other cell
receives light (cells near the manipulator but not held are left out).

Observation (11 values): the target's presence, kind (+1 kind 0, -1 kind 1), distance
upstream of the junction over the inlet's length, offset across from the junction over
the inlet's half width, and the fraction of the grip done; the same four for the next
cell upstream; the elapsed fraction of the episode and the cells in the chip over
``max_cells``.

Pure and jittable, batched over a leading environment axis.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from otgym.sim.chip import load_chip
from otgym.sim.fields import GridFlow, GridWalls, chip_fields
from otgym.tasks.sort_cells.config import SortConfig, manipulation

OBS_SIZE = 11
N_ACTIONS = 3


@struct.dataclass
class SortParams:
    flow: GridFlow
    walls: GridWalls
    spawn_um: jnp.ndarray  # (M, 2) arrival places across the inlet channel
    junction_um: jnp.ndarray  # (2,)
    outlets_um: jnp.ndarray  # (2, 2) the outlet of kind 0, of kind 1
    side_sign: jnp.ndarray  # (2,) the y direction toward each kind's outlet side
    speed_um_s: jnp.ndarray  # (2,) manipulation speed per kind
    intensity_mw_per_um2: jnp.ndarray  # (2,) light on a held cell, per kind
    radius_um: jnp.ndarray  # (2,)
    diffusion_um2_s: jnp.ndarray  # (2,)
    inlet_length_um: float = struct.field(pytree_node=False)
    half_width_um: float = struct.field(pytree_node=False)
    config: SortConfig = struct.field(pytree_node=False)


@struct.dataclass
class SortState:
    xy_um: jnp.ndarray  # (K, 2)
    kind: jnp.ndarray  # (K,) int32
    active: jnp.ndarray  # (K,) bool
    age_s: jnp.ndarray  # (K,)
    dose_mj_per_um2: jnp.ndarray  # (K,) each cell's light dose so far
    held: jnp.ndarray  # int32 the held (or being taken) cell, -1 none
    grip_s: jnp.ndarray  # time spent taking hold of / holding it
    next_arrival_s: jnp.ndarray
    time_s: jnp.ndarray
    steps: jnp.ndarray  # int32
    arrived: jnp.ndarray  # int32 cells that arrived (lost ones included)
    correct: jnp.ndarray  # int32 cells that left by their kind's outlet
    wrong: jnp.ndarray  # int32 cells that left by the other outlet
    lost: jnp.ndarray  # int32
    finished_dose_mj_per_um2: jnp.ndarray  # summed dose of the cells that left or were lost in the chip
    finished: jnp.ndarray  # int32 cells whose dose is in that sum


def make_params(config: SortConfig) -> SortParams:
    """Load the chip and its fields, read the ports and the junction from its sidecar,
    and derive the manipulation (host work, once)."""
    chip = load_chip(config.chip)
    ports = {port.name: port for port in chip.ports}
    for name, kind in [(config.inlet, "inlet"), *((outlet, "outlet") for outlet in config.outlets)]:
        if name not in ports or ports[name].kind != kind:
            raise ValueError(f"chip {chip.name!r} has no {kind} port {name!r}; its ports: {sorted(ports)}")
    junction = np.asarray(chip.site_um(config.junction_site))
    inlet = np.asarray(ports[config.inlet].xy_um)
    flow, walls = chip_fields(chip)
    flow = flow.scaled(config.flow_scale)
    largest = max(config.cell_radii_um)
    direction = (junction - inlet) / np.linalg.norm(junction - inlet)
    across = np.array([-direction[1], direction[0]])
    entry = inlet + 1.5 * largest * direction
    offsets = np.arange(-60.0, 60.25, 0.25)
    candidates = (entry + offsets[:, None] * across).astype(np.float32)
    grid = np.asarray(walls.distance)  # on the pixel centres
    cells = np.clip(np.floor(candidates / chip.pixel_size_um).astype(int), 0, np.array(grid.shape[::-1]) - 1)
    distance = grid[cells[:, 1], cells[:, 0]]
    spawn = candidates[distance > largest + 0.5]
    if len(spawn) == 0:
        raise ValueError(f"chip {chip.name!r}: the inlet channel has no room for a cell of radius {largest} um")
    outlets = np.asarray([ports[name].xy_um for name in config.outlets])
    side = np.sign(outlets[:, 1] - junction[1])
    if side[0] == side[1] or 0 in side:
        raise ValueError(f"the outlets {config.outlets} must lie on either side of the junction")
    derived = manipulation(config)
    half_width = float(np.max(np.abs((spawn - junction) @ across))) + largest
    as32 = lambda a: jnp.asarray(a, jnp.float32)  # noqa: E731
    return SortParams(
        flow=flow,
        walls=walls,
        spawn_um=as32(spawn),
        junction_um=as32(junction),
        outlets_um=as32(outlets),
        side_sign=as32(side),
        speed_um_s=as32(derived["speed_um_s"]),
        intensity_mw_per_um2=as32(derived["intensity_mw_per_um2"]),
        radius_um=as32(config.cell_radii_um),
        diffusion_um2_s=as32(config.diffusion_um2_s()),
        inlet_length_um=float(np.linalg.norm(junction - inlet)),
        half_width_um=half_width,
        config=config,
    )


def _arrive(key, params: SortParams, state: SortState):
    """A new cell at the inlet, in the first free slot; lost if there is none."""
    kind_key, place_key = jax.random.split(key)
    kind = jax.random.bernoulli(kind_key).astype(jnp.int32)
    xy = params.spawn_um[jax.random.randint(place_key, (), 0, params.spawn_um.shape[0])]
    free = ~state.active
    slot = jnp.argmax(free)
    room = jnp.any(free)
    put = (jnp.arange(free.shape[0]) == slot) & room
    return state.replace(
        xy_um=jnp.where(put[:, None], xy, state.xy_um),
        kind=jnp.where(put, kind, state.kind),
        active=state.active | put,
        age_s=jnp.where(put, 0.0, state.age_s),
        dose_mj_per_um2=jnp.where(put, 0.0, state.dose_mj_per_um2),
        arrived=state.arrived + 1,
        lost=state.lost + (~room).astype(jnp.int32),
    )


def reset_one(key, params: SortParams):
    config = params.config
    k = config.max_cells
    zero, izero = jnp.zeros((), jnp.float32), jnp.zeros((), jnp.int32)
    state = SortState(
        xy_um=jnp.zeros((k, 2), jnp.float32),
        kind=jnp.zeros(k, jnp.int32),
        active=jnp.zeros(k, bool),
        age_s=jnp.zeros(k, jnp.float32),
        dose_mj_per_um2=jnp.zeros(k, jnp.float32),
        held=jnp.full((), -1, jnp.int32),
        grip_s=zero,
        next_arrival_s=jnp.asarray(config.arrival_interval_s, jnp.float32),
        time_s=zero,
        steps=izero,
        arrived=izero,
        correct=izero,
        wrong=izero,
        lost=izero,
        finished_dose_mj_per_um2=zero,
        finished=izero,
    )
    state = _arrive(key, params, state)
    return observe(params, state), state


def _upstream_order(params: SortParams, state: SortState):
    """The target (the most downstream cell upstream of the junction) and the next one:
    indices and presence."""
    upstream = state.active & (state.xy_um[:, 0] < params.junction_um[0])
    score = jnp.where(upstream, state.xy_um[:, 0], -jnp.inf)
    first = jnp.argmax(score)
    second_score = score.at[first].set(-jnp.inf)
    second = jnp.argmax(second_score)
    return first, jnp.any(upstream), second, jnp.isfinite(second_score[second])


def _describe(params: SortParams, state: SortState, index, present):
    xy = state.xy_um[index]
    return jnp.where(
        present,
        jnp.stack(
            [
                1.0,
                1.0 - 2.0 * state.kind[index],
                (params.junction_um[0] - xy[0]) / params.inlet_length_um,
                (xy[1] - params.junction_um[1]) / params.half_width_um,
            ]
        ),
        0.0,
    )


def observe(params: SortParams, state: SortState):
    config = params.config
    first, has_first, second, has_second = _upstream_order(params, state)
    grip = jnp.where(
        has_first & (state.held == first), jnp.minimum(state.grip_s / max(config.grip_time, 1e-6), 1.0), 0.0
    )
    return jnp.concatenate(
        [
            _describe(params, state, first, has_first),
            grip[None],
            _describe(params, state, second, has_second),
            jnp.stack([state.steps / config.max_steps, jnp.sum(state.active) / config.max_cells]),
        ]
    ).astype(jnp.float32)


def _move(key, params: SortParams, state: SortState, push_um):
    """Advect, diffuse and push (``push_um`` (E, K, 2) over the step) the cells of E
    environments at once, keeping them off the walls. Batched as it is (the field
    samplers take any leading axes): under ``vmap`` its gathers compiled three times
    slower."""
    config = params.config
    dt = config.control_period_s / config.substeps
    radius = params.radius_um[state.kind]
    sigma = jnp.sqrt(2 * params.diffusion_um2_s[state.kind] * dt)[..., None]
    noise = jax.random.normal(key, (config.substeps, *state.xy_um.shape), state.xy_um.dtype)

    def substep(xy, kick):
        xy = xy + params.flow.velocity_um_s(xy) * dt + push_um / config.substeps + sigma * kick
        distance, normal = params.walls.distance_and_normal(xy)
        xy = xy + jnp.maximum(radius - distance, 0.0)[..., None] * normal
        return xy, None

    xy, _ = jax.lax.scan(substep, state.xy_um, noise)
    return jnp.where(state.active[..., None], xy, state.xy_um)


def _take_hold(state: SortState, action, params: SortParams):
    """One environment's manipulation this step: the target, whether it is acted on, the
    grip time, the push (K, 2) over the step and the cells' doses after it."""
    config = params.config
    period = config.control_period_s
    action = jnp.clip(jnp.asarray(action, jnp.int32), 0, N_ACTIONS - 1)
    first, present, _, _ = _upstream_order(params, state)
    acting = (action > 0) & present
    same = state.held == first
    grip_s = jnp.where(acting, jnp.where(same, state.grip_s, 0.0) + period, 0.0)
    held_time = jnp.clip(grip_s - config.grip_time, 0.0, period)  # this step's time holding the cell
    kind = state.kind[first]
    toward = jnp.where(action == 1, params.side_sign[0], params.side_sign[1])
    is_held = (jnp.arange(config.max_cells) == first) & acting
    push = jnp.where(is_held[:, None], jnp.stack([0.0, toward * params.speed_um_s[kind] * held_time]), 0.0)
    dose = state.dose_mj_per_um2 + jnp.where(is_held, params.intensity_mw_per_um2[kind] * held_time, 0.0)
    return first, acting, grip_s, push, dose


def _account(key, state: SortState, hold, xy, params: SortParams):
    """One environment after the move: exits, stalls, arrivals, reward and info."""
    config = params.config
    period = config.control_period_s
    first, acting, grip_s, _, dose = hold
    to_outlet = jnp.linalg.norm(xy[:, None] - params.outlets_um[None], axis=-1)  # (K, 2)
    exits = state.active & (jnp.min(to_outlet, axis=1) < config.exit_distance_um)
    right = exits & (jnp.argmin(to_outlet, axis=1) == state.kind)
    wrong = exits & ~right
    age = state.age_s + period
    stalled = state.active & ~exits & (age > config.max_residence_s)
    finished = exits | stalled
    n_right, n_wrong, n_stalled = (jnp.sum(m).astype(jnp.int32) for m in (right, wrong, stalled))
    new = state.replace(
        xy_um=xy,
        active=state.active & ~finished,
        age_s=age,
        dose_mj_per_um2=dose,
        held=jnp.where(acting, first, -1).astype(jnp.int32),
        grip_s=grip_s,
        time_s=state.time_s + period,
        steps=state.steps + 1,
        correct=state.correct + n_right,
        wrong=state.wrong + n_wrong,
        lost=state.lost + n_stalled,
        finished_dose_mj_per_um2=state.finished_dose_mj_per_um2 + jnp.sum(jnp.where(finished, dose, 0.0)),
        finished=state.finished + jnp.sum(finished).astype(jnp.int32),
    )
    due = new.time_s >= state.next_arrival_s - 1e-4
    arrived = _arrive(key, params, new)
    new = jax.tree.map(lambda x, y: jnp.where(due, x, y), arrived, new)
    refused = new.lost - (state.lost + n_stalled)
    new = new.replace(
        next_arrival_s=jnp.where(due, state.next_arrival_s + config.arrival_interval_s, state.next_arrival_s)
    )
    weights = config.reward
    reward = weights.correct * n_right + weights.wrong * n_wrong + weights.lost * (n_stalled + refused)
    truncated = new.steps >= config.max_steps
    info = metrics(new, config)
    info["success"] = truncated & (info["purity"] >= config.min_purity) & (new.correct > 0)
    return observe(params, new), new, reward.astype(jnp.float32), jnp.zeros((), bool), truncated, info


def metrics(state: SortState, config: SortConfig) -> dict:
    """The episode's metrics so far: purity (the fraction of the sorted cells that left
    by their kind's outlet), yield (cells in their outlet over the cells whose fate is
    decided: sorted, missorted or lost; the cells still in the chip are not counted),
    throughput (cells in their outlet per minute), counts, and the mean light dose of
    the cells that left the chip or stalled in it (the held-cell intensity times the
    time held)."""
    sorted_cells = state.correct + state.wrong
    decided = sorted_cells + state.lost
    minutes = jnp.maximum(state.time_s, 1e-6) / 60.0
    return {
        "purity": jnp.where(sorted_cells > 0, state.correct / jnp.maximum(sorted_cells, 1), 0.0),
        "yield": jnp.where(decided > 0, state.correct / jnp.maximum(decided, 1), 0.0),
        "throughput_cells_per_min": state.correct / minutes,
        "cells_arrived": state.arrived,
        "cells_sorted": state.correct,
        "cells_missorted": state.wrong,
        "cells_lost": state.lost,
        "light_dose_per_cell_mj_per_um2": jnp.where(
            state.finished > 0, state.finished_dose_mj_per_um2 / jnp.maximum(state.finished, 1), 0.0
        ),
        "time_s": state.time_s,
    }


def reset_batch(key, params: SortParams, n_envs: int):
    return jax.vmap(lambda k: reset_one(k, params))(jax.random.split(key, n_envs))


def step_batch(key, state: SortState, action, params: SortParams):
    """Step E environments with integer actions (E,) (clipped to 0..2). Returns obs,
    state, reward, terminated (never: episodes run their time), truncated, info."""
    move_key, arrive_key = jax.random.split(key)
    action = jnp.asarray(action)
    hold = jax.vmap(lambda s, a: _take_hold(s, a, params))(state, action)
    xy = _move(move_key, params, state, hold[3])
    keys = jax.random.split(arrive_key, action.shape[0])
    return jax.vmap(lambda k, s, h, x: _account(k, s, h, x, params))(keys, state, hold, xy)


def auto_reset(key, params: SortParams, obs, state: SortState, done):
    """Replace finished environments by fresh episodes (computed only when any is done)."""

    def fresh(_):
        new_obs, new_state = reset_batch(key, params, done.shape[0])
        pick = lambda a, b: jnp.where(done.reshape(done.shape + (1,) * (a.ndim - 1)), a, b)  # noqa: E731
        return pick(new_obs, obs), jax.tree.map(pick, new_state, state)

    return jax.lax.cond(jnp.any(done), fresh, lambda _: (obs, state), None)
