"""Scripted baseline of the ``assemble`` task, and the episode metrics of any policy.

Baseline: the task's plan (beads assigned to targets, synchronised straight moves; the
plan's assignment is checked against the Hungarian method, ``scipy.optimize.
linear_sum_assignment``) run at one constant pace: the largest level not above half the
trap's waist. Half the waist is where the Gaussian trap's force peaks, so over the
whole of such a jump the pull on the bead grows as it lags (a rule of thumb, ours).

``episode_metrics`` runs episodes of a batch with any policy (obs -> actions) and
records each episode's end: success, RMS placement error (um), time (s), beads lost,
collisions.

``baseline_table`` is ``otgym experiment assemble-baseline`` (presets, paces and a
learned policy side by side on the same episodes).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator

import jax
import jax.numpy as jnp
import numpy as np
from scipy.optimize import linear_sum_assignment

from otgym import tasks
from otgym.tasks.assemble import core
from otgym.tasks.assemble.config import PRESETS, AssembleConfig

METRICS = ("success", "rms_error_um", "time_s", "beads_lost", "collisions")


def baseline_action(config: AssembleConfig) -> int:
    """The largest pace level not above half the waist (the smallest level if none is)."""
    levels = np.asarray(config.pace_levels_um)
    fitting = np.flatnonzero(levels <= config.waist_um / 2 + 1e-9)
    return int(fitting[-1]) if fitting.size else int(np.argmin(levels))


def assignment_gap(params: core.AssembleParams, n: int, seed: int) -> tuple[float, float]:
    """Over ``n`` resets: the fraction whose assignment cost equals the Hungarian
    optimum (to 1e-4 relative), and the largest relative excess over it."""
    _, state = jax.jit(core.reset_batch, static_argnums=2)(jax.random.PRNGKey(seed), params, n)
    start, goal = np.asarray(state.start_um, float), np.asarray(state.goal_um, float)
    equal, worst = 0, 0.0
    for s, g in zip(start, goal, strict=True):
        cost = np.sum((s[:, None] - g[None]) ** 2, axis=-1)
        rows, cols = linear_sum_assignment(cost)
        optimum = cost[rows, cols].sum()
        mine = np.trace(cost)
        excess = (mine - optimum) / optimum
        equal += excess <= 1e-4
        worst = max(worst, excess)
    return equal / n, worst


def episode_metrics(params: core.AssembleParams, policy: Callable, n_episodes: int, seed: int) -> dict:
    """Run ``n_episodes`` episodes at once with ``policy(obs (E, 9)) -> actions (E,)``
    (jittable) and return each episode's final metrics (arrays of ``n_episodes``)."""
    task = tasks.load("assemble")
    key = jax.random.PRNGKey(seed)
    key, reset_key = jax.random.split(key)
    obs, state = jax.jit(task.reset_batch, static_argnums=2)(reset_key, params, n_episodes)

    @jax.jit
    def step(key, obs, state):
        return task.step_batch(key, state, policy(obs), params)

    done = np.zeros(n_episodes, bool)
    final = {name: np.zeros(n_episodes) for name in METRICS}
    for _ in range(params.config.max_steps):
        key, step_key = jax.random.split(key)
        obs, state, _, terminated, truncated, info = step(step_key, obs, state)
        ended = np.asarray(terminated | truncated) & ~done
        for name in METRICS:
            final[name][ended] = np.asarray(info[name])[ended]
        done |= ended
        if done.all():
            break
    return final


def summary(final: dict) -> dict:
    success = final["success"].astype(bool)
    n = len(success)
    return {
        "episodes": n,
        "success": float(success.mean()),
        "success_ci95": 1.96 * float(np.sqrt(success.mean() * (1 - success.mean()) / n)),
        "rms_error_um": float(np.mean(final["rms_error_um"][success])) if success.any() else float("nan"),
        "time_s": float(np.mean(final["time_s"][success])) if success.any() else float("nan"),
        "beads_lost": int(final["beads_lost"].sum()),
        "collisions": int(final["collisions"].sum()),
    }


def constant(action: int):
    return lambda obs: jnp.full(obs.shape[0], action, jnp.int32)


def greedy(policy_path: str, params: core.AssembleParams):
    from otgym.rl.network import QNetwork
    from otgym.rl.policy import load_policy

    q_params, meta = load_policy(policy_path, core.OBS_SIZE, params.config.n_actions)
    network = QNetwork(params.config.n_actions, tuple(meta.get("hidden", ())))
    return lambda obs: jnp.argmax(network.apply(q_params, obs), axis=-1).astype(jnp.int32)


def report_outcomes(policy_path, preset: str, episodes: int, seed: int) -> dict:
    """The report comparison's paired outcomes (``otgym.experiments.task_report.run``): the
    plan at the baseline's constant pace and the greedy Q-network of ``policy_path`` on
    the same ``episodes`` from ``seed``."""
    task = tasks.load("assemble")
    params = task.make_params(task.config(preset))
    runs = {"baseline": constant(baseline_action(params.config)), "learned": greedy(str(policy_path), params)}
    return {name: episode_metrics(params, policy, episodes, seed) for name, policy in runs.items()}


def paces(choice: str, config: AssembleConfig) -> list[int]:
    """The pace levels ``choice`` names on ``config``: ``baseline`` (``baseline_action``),
    ``all``, or one level's index; ValueError otherwise."""
    if choice == "baseline":
        return [baseline_action(config)]
    if choice == "all":
        return list(range(config.n_actions))
    if not choice.isdigit() or int(choice) >= config.n_actions:
        raise ValueError(f"--pace must be 'baseline', 'all' or a level index in 0..{config.n_actions - 1}")
    return [int(choice)]


def check_policy(policy_path: str, presets: list[str]) -> None:
    """ValueError (or OSError) unless ``policy_path`` is a policy file whose network fits
    every preset of ``presets`` (its shapes traced, nothing compiled)."""
    from otgym.rl.policy import load_policy

    for name in presets:
        load_policy(policy_path, core.OBS_SIZE, PRESETS[name].n_actions)


def baseline_table(presets: list[str], episodes: int, seed: int, pace: str, policy: str | None) -> Iterator[str]:
    """The markdown table of ``otgym experiment assemble-baseline``, a line at a time
    (each row once its episodes ran): per preset, each pace of ``pace`` (and the greedy
    Q-network of ``policy``, if given) on the same ``episodes`` from ``seed``: success
    with its 95 % normal interval, RMS error and time of the successes, beads lost,
    collisions; then, per preset, how often the plan's assignment is the Hungarian one."""
    task = tasks.load("assemble")
    yield "| preset | traps | stiffness pN/um | policy | success | RMS error um | time s | beads lost | collisions |"
    yield "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"
    for name in presets:
        params = task.make_params(task.config(name))
        config = params.config
        runs = [(f"pace {config.pace_levels_um[a]} um/frame", constant(a)) for a in paces(pace, config)]
        if policy:
            runs.append((f"greedy {policy}", greedy(policy, params)))
        for label, run in runs:
            s = summary(episode_metrics(params, run, episodes, seed))
            yield (
                f"| {name} | {config.n_traps} | {config.trap_stiffness_pn_per_um:g} | {label} | "
                f"{s['success']:.3f} +- {s['success_ci95']:.3f} | {s['rms_error_um']:.3f} | {s['time_s']:.2f} | "
                f"{s['beads_lost']} | {s['collisions']} |"
            )
        equal, worst = assignment_gap(params, episodes, seed)
        yield f"<!-- {name}: plan's assignment = Hungarian optimum in {equal:.3f} of resets, worst excess {worst:.2e} -->"
