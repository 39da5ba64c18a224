"""Model-predictive navigation: does one decision fit the control period on this CPU?

* Decision time: one replan of one environment (``MPCNavigator``'s jitted replan:
  candidates, rollouts of the scene's batched step, costs, the choice), timed back to
  back after a warm-up, for rollouts x plan steps around the default (32 x 25 steps of
  0.1 s, 50 physics steps of 2 ms each). The ratio is the decision time over the
  replan period (0.1 s: a replan runs while the previous plan's step is executed, so
  it must finish within it; the task's control period is 20 ms, 5 ticks a replan).
  Per 20 ms control period the controller then computes (decision time) / 5 on
  average. The implied throughput is physics steps per replan over its time.
* Reference in the same run: the scene's ``step_batch`` alone on the model scene at the
  same batch (rollouts environments, 50 steps of 2 ms a call): the physics the
  replan cannot avoid; the rest is the replan's own work (costs, candidates).
* The full-fidelity alternative, measured: the task's own scene (0.25 ms steps, 80 a
  tick, Brownian noise) at the same batch, and the decision time it would give.
* Model fidelity: from a gripped state in the chip's first channel, four manoeuvres
  held for the default horizon (2.5 s): the model's cell against the task's real cell
  (full physics, 20 ms ticks executing the same segments).

    python benchmarks/mpc.py [--repeats 20] [--quick]
"""

from __future__ import annotations

import argparse
import copy
import dataclasses
import functools
import os
import time

import jax
import jax.numpy as jnp
import numpy as np

from otgym.autonomy import mpc
from otgym.autonomy.mpc import MPCConfig, MPCCosts
from otgym.autonomy.mpc_navigator import MPCNavigator
from otgym.autonomy.navigator import RouteNavigator, route_point
from otgym.sim import scene as sc
from otgym.task.task import CARRY, InteractiveTask
from otgym.tasks.transport.scenario import Scenario

SIZES = ((16, 24), (24, 24), (32, 12), (32, 24), (64, 24))
"""(rollouts, plan steps) timed; the default is (32, 24)."""
MANOEUVRES = {
    "cruise 6 um/s": (6.0, 0.0, 0.0),
    "side-step 2 um": (0.0, 2.0, 0.0),
    "dash 8 um/s, -1 um, 0.2 rad": (8.0, -1.0, 0.2),
    "back off 4 um/s": (-4.0, 0.0, 0.0),
}


def parked_far(task) -> Scenario:
    points = route_point(task.route_um, task.route_arc_um, np.array([240.0, 255.0, 270.0, 285.0]))
    return Scenario(
        0,
        np.zeros(4),
        np.zeros(4),
        points,
        np.tile([1.0, 0.0], (4, 1)),
        np.full(4, 2.0),
        np.full(4, 1e6),
        np.full(4, 1e6 + 1.0),
    )


def gripped(task):
    state = task.reset([parked_far(task)], jax.random.PRNGKey(0))
    route = RouteNavigator(task.route_um, task.route_arc_um, task.offsets_um, task.config.tick_s)
    route.reset(1)
    obs, key = state.observation, jax.random.PRNGKey(1)
    for _ in range(150):  # 3 s: gripped and carried about 14 um into the channel
        key, step_key = jax.random.split(key)
        obs = task.step(state, route.increments(obs), step_key)
    assert obs.phase[0] == CARRY
    return state, obs


def replan_inputs(navigator: MPCNavigator, obs):
    navigator.tracker.reset(1, obs.obstacle_xy_um.shape[1])
    navigator.tracker.observe(obs.time_s - 0.02, obs.obstacle_xy_um)
    navigator.tracker.observe(obs.time_s, obs.obstacle_xy_um)
    pose = navigator._pose(
        navigator.route,
        navigator.offsets_um,
        jnp.asarray(obs.trap_xy_um, jnp.float32),
        jnp.asarray(obs.cell_arc_um, jnp.float32),
    )
    start = jnp.asarray(np.stack([np.asarray(a) for a in pose], axis=-1), jnp.float32)
    tracks = {k: jnp.asarray(v, jnp.float32) for k, v in navigator.tracker.predicted_tracks(obs.time_s).items()}
    return navigator.model_state(obs), tracks, start


def time_replan(task, navigator: MPCNavigator, obs, config: MPCConfig, repeats: int) -> float:
    """Median wall seconds of one environment's replan (compiled beforehand)."""
    replan = mpc.make_replan(config, task.config.scenario)
    state, tracks, start = replan_inputs(navigator, obs)
    committed = jnp.asarray([[0.0, float(start[0, 1]), float(start[0, 2])]], jnp.float32)
    nominal = jnp.zeros((1, config.plan_steps, 3), jnp.float32).at[..., 0].set(config.cruise_speed_um_s)
    call = functools.partial(
        replan,
        navigator.model,
        navigator.route,
        navigator.model_offsets_um,
        MPCCosts(),
        state,
        tracks,
        start,
        committed,
        nominal,
    )
    jax.block_until_ready(call(jax.random.PRNGKey(0)))
    times = []
    for i in range(repeats):
        begin = time.perf_counter()
        jax.block_until_ready(call(jax.random.PRNGKey(i + 1)))
        times.append(time.perf_counter() - begin)
    return float(np.median(times))


def time_physics(scene: sc.Scene, batch: int, calls: int) -> float:
    """Median wall seconds of one ``step_batch`` call of ``batch`` environments."""
    state = jax.vmap(lambda k: sc.reset(scene, k))(jax.random.split(jax.random.PRNGKey(0), batch))
    zeros = jnp.zeros((batch, scene.n_traps, 2))
    propulsion = jnp.zeros((batch, len(scene.obstacles), 2))
    step = jax.jit(functools.partial(sc.step_batch, scene))
    state, _ = step(state, zeros, jax.random.PRNGKey(1), propulsion)
    jax.block_until_ready(state)
    times = []
    for i in range(calls):
        begin = time.perf_counter()
        state, _ = step(state, zeros, jax.random.PRNGKey(i), propulsion)
        jax.block_until_ready(state)
        times.append(time.perf_counter() - begin)
    return float(np.median(times))


def fidelity(task, navigator: MPCNavigator, state, obs, config: MPCConfig):
    """Per manoeuvre: the model's and the real cell's distance after the horizon (um), the real travel."""
    steps = 1 + config.plan_steps
    model_state, _, start = replan_inputs(navigator, obs)
    k = obs.obstacle_xy_um.shape[1]
    tracks = {
        "start_um": jnp.asarray(obs.obstacle_xy_um, jnp.float32),
        "direction": jnp.zeros((1, k, 2)),
        "speed_um_s": jnp.zeros((1, k)),
        "depart_s": jnp.zeros((1, k)),
        "end_s": jnp.full((1, k), 1e6),
        "idle": jnp.zeros((1, k)),
    }
    rollout = jax.jit(functools.partial(mpc.rollout, config=config, obstacle_config=task.config.scenario))
    rows = []
    for name, action in MANOEUVRES.items():
        action = np.array([action], np.float32)
        actions = mpc.rate_limited(jnp.asarray(np.repeat(action[:, None], steps, axis=1)), start, config)
        final, _ = rollout(
            navigator.model,
            navigator.route,
            navigator.model_offsets_um,
            MPCCosts(),
            model_state,
            tracks,
            start,
            actions,
        )
        model_cell = np.asarray(final.physics.pose)[0, navigator.model.payload, :2]
        real_state, real_obs, key = copy.copy(state), obs, jax.random.PRNGKey(7)
        ticks = navigator.ticks_per_step
        for step in range(steps):
            pose = navigator._pose(
                navigator.route,
                navigator.offsets_um,
                jnp.asarray(real_obs.trap_xy_um, jnp.float32),
                jnp.asarray(real_obs.cell_arc_um, jnp.float32),
            )
            segment = jnp.asarray(np.stack([np.asarray(a) for a in pose], axis=-1), jnp.float32)
            for tick in range(ticks):
                now, later = (
                    np.asarray(a)
                    for a in navigator._places(
                        navigator.route,
                        navigator.offsets_um,
                        segment,
                        actions[:, step],
                        tick / ticks,
                        (tick + 1) / ticks,
                        step_s=config.step_s,
                    )
                )
                key, step_key = jax.random.split(key)
                real_obs = task.step(real_state, np.asarray(mpc.cap_rigid(later - now, 0.4)), step_key)
        error = float(np.linalg.norm(model_cell - real_obs.cell_xy_um[0]))
        travel = float(np.linalg.norm(real_obs.cell_xy_um[0] - obs.cell_xy_um[0]))
        rows.append((name, error, travel, bool(real_state.metrics.trap_losses[0]), real_obs.contact_force_pn.max()))
    return rows


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=20, help="replans timed per size")
    parser.add_argument("--quick", action="store_true", help="5 repeats, default size and one smaller only")
    args = parser.parse_args()
    sizes = ((16, 24), (32, 24)) if args.quick else SIZES
    repeats = 5 if args.quick else args.repeats
    print(
        f"device: {jax.devices()[0].device_kind} ({jax.default_backend()}); {os.cpu_count()} CPU cores, "
        f"load average {os.getloadavg()[0]:.2f} at start (other jobs included)"
    )
    task = InteractiveTask()
    default = MPCConfig()
    navigator = MPCNavigator(task, default, chunk_envs=1)
    state, obs = gripped(task)
    tick_s = task.config.tick_s
    print(
        f"model: the task's scene at {default.model_dt_s * 1e3:g} ms steps ({default.model_substeps} a "
        f"{default.step_s:g} s model step), temperature 0, traps {default.model_trap_stiffness_pn_per_um:g} pN/um "
        f"x {default.model_trap_waist_um:g} um waist, extra grip squeeze {navigator.extra_squeeze_um:.3f} um; "
        f"task: {task.config.scene.dt_s * 1e3:g} ms steps, {task.config.scene.substeps} a {tick_s * 1e3:g} ms tick"
    )
    print(
        "decision time of one environment's replan (median of "
        f"{repeats}); replan period {default.step_s:g} s = {navigator.ticks_per_step} control periods of "
        f"{tick_s * 1e3:g} ms"
    )
    print(
        f"  {'rollouts':>8} {'horizon':>8} {'physics steps':>13} {'replan (ms)':>11} {'/ period':>9} "
        f"{'per 20 ms tick (ms)':>19} {'steps/s':>9} {'physics alone (ms)':>18} {'replan / physics':>16}"
    )
    for rollouts, plan_steps in sizes:
        config = dataclasses.replace(default, n_rollouts=rollouts, plan_steps=plan_steps)
        seconds = time_replan(task, navigator, obs, config, repeats)
        physics = time_physics(navigator.model, rollouts, 3 * repeats) * (1 + plan_steps)
        steps = config.substeps_per_replan
        mark = "  (default)" if (rollouts, plan_steps) == (default.n_rollouts, default.plan_steps) else ""
        print(
            f"  {rollouts:>8} {config.horizon_s:>7.1f}s {steps:>13,} {seconds * 1e3:>11.1f} "
            f"{seconds / default.step_s:>8.2f}x {seconds * 1e3 / navigator.ticks_per_step:>19.1f} "
            f"{steps / seconds:>9.2e} {physics * 1e3:>18.1f} {seconds / physics:>15.2f}x{mark}"
        )
    full = time_physics(task.scene, default.n_rollouts, 3 * repeats)
    full_replan = full * default.horizon_s / tick_s
    print(
        f"full fidelity instead (the task's scene, {task.config.scene.substeps} steps of "
        f"{task.config.scene.dt_s * 1e3:g} ms a tick, {default.n_rollouts} rollouts x {default.horizon_s:g} s): "
        f"{full * 1e3:.1f} ms a tick of the batch, {full_replan:.2f} s of physics a replan = "
        f"{full_replan / default.step_s:.1f}x the replan period "
        f"({default.n_rollouts * default.horizon_s / tick_s * task.config.scene.substeps / full_replan:.2e} steps/s)"
    )
    print(
        f"model fidelity from a gripped state (cell at arc {obs.cell_arc_um[0]:.1f} um), each manoeuvre held for "
        f"{default.horizon_s:g} s (rate-limited as planned): model cell vs the task's real cell"
    )
    print(f"  {'manoeuvre':<30} {'error (um)':>10} {'real travel (um)':>16} {'trap lost':>9} {'peak contact (pN)':>17}")
    for name, error, travel, lost, contact in fidelity(task, navigator, state, obs, default):
        print(f"  {name:<30} {error:>10.2f} {travel:>16.1f} {str(lost):>9} {contact:>17.2f}")
    print(f"load average {os.getloadavg()[0]:.2f} at the end")


if __name__ == "__main__":
    main()
