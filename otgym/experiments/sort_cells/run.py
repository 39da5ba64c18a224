"""The ``sort-cells`` scripted baseline against random and idle policies, and the
trade-off between robots and direct trapping in one table.

``otgym experiment sort-cells-baselines --episodes 64 --seed 0`` (``table``, ``markdown``) prints, for each
preset (``robots``, ``direct``, and each manipulator at the other's flow and arrivals:
``robots-fast``, ``direct-slow``) and policy, the means over episodes (120 s each) of
purity, yield, throughput, cells lost and the light dose per cell, with the purity's 95 %
normal interval.

A learned policy (the greedy action of a Q-network from ``otgym train --task
sort-cells``) runs the same episodes (``learned_rollout``); ``report_outcomes`` pairs it
with the baseline for ``otgym experiment sort-cells`` (``otgym.experiments.task_report.run``).
Policies compared are run one per call on the same ``PRNGKey(seed)`` and batch size, so
each episode sees the same arrivals (times, kinds, places) and the same Brownian kicks
under every policy."""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np

from otgym import tasks
from otgym.tasks.sort_cells import PRESETS, baseline, core

POLICIES = ("baseline", "random", "idle")
METRICS = (
    "purity",
    "yield",
    "throughput_cells_per_min",
    "cells_arrived",
    "cells_sorted",
    "cells_missorted",
    "cells_lost",
    "light_dose_per_cell_mj_per_um2",
)


@functools.lru_cache(maxsize=8)
def _params(preset: str):
    task = tasks.load("sort-cells")
    return task.make_params(task.config(preset))


@functools.partial(jax.jit, static_argnums=(2, 4))
def _rollout(key, params: core.SortParams, n_episodes: int, policy, greedy=None):
    """``n_episodes`` episodes from ``key`` under one policy: ``policy`` (an int32 index
    into ``POLICIES``, traced, so every scripted policy shares one program) or, when
    ``greedy`` is given, ``greedy(obs)``. The metrics at the episode's end."""
    task = tasks.load("sort-cells")
    reset_key, run_key = jax.random.split(key)
    obs, state = task.reset_batch(reset_key, params, n_episodes)

    def body(carry, step_key):
        obs, state = carry
        act_key, step_key = jax.random.split(step_key)
        if greedy is None:
            scripted = baseline.actions(obs, params)
            random = jax.random.randint(act_key, (n_episodes,), 0, core.N_ACTIONS)
            action = jnp.where(policy == 0, scripted, jnp.where(policy == 1, random, 0)).astype(jnp.int32)
        else:
            action = greedy(obs)
        obs, state, *_ = task.step_batch(step_key, state, action, params)
        return (obs, state), None

    (obs, state), _ = jax.lax.scan(body, (obs, state), jax.random.split(run_key, params.config.max_steps))
    return core.metrics(state, params.config)


def _finish(out, config) -> dict:
    found = {name: np.asarray(value) for name, value in jax.device_get(out).items()}
    found["success"] = (found["purity"] >= config.min_purity) & (found["cells_sorted"] > 0)  # as the step's info
    return found


def rollouts(preset: str, policies, n_episodes: int, seed: int) -> dict:
    """``{policy: per-episode metrics (numpy (n,))}`` at the end of the same
    ``n_episodes`` episodes of ``preset`` (the same ``PRNGKey(seed)`` resets and step
    keys, so the same arrivals) under each of ``policies`` (names of ``POLICIES``), with
    ``success`` (purity at least ``min_purity``, as the task's ``info``)."""
    if preset not in PRESETS:
        raise ValueError(f"unknown preset {preset!r}; choose one of {list(PRESETS)}")
    for policy in policies:
        if policy not in POLICIES:
            raise ValueError(f"unknown policy {policy!r}; choose one of {list(POLICIES)}")
    params, key = _params(preset), jax.random.PRNGKey(seed)
    return {
        policy: _finish(_rollout(key, params, n_episodes, jnp.int32(POLICIES.index(policy))), params.config)
        for policy in policies
    }


def rollout(preset: str, policy: str, n_episodes: int, seed: int) -> dict:
    """Per-episode metrics (numpy (n,)) of ``n_episodes`` episodes of ``preset`` from
    ``PRNGKey(seed)`` under ``policy`` (one of ``POLICIES``)."""
    return rollouts(preset, (policy,), n_episodes, seed)[policy]


class _Greedy:
    """Greedy actions of a Q-network (hashable by identity, so a static jit argument)."""

    def __init__(self, q_params, n_actions: int):
        from otgym.rl.network import QNetwork

        layers = q_params["params"]
        hidden = tuple(int(layers[f"Dense_{i}"]["kernel"].shape[1]) for i in range(len(layers) - 1))
        self.network, self.q_params = QNetwork(n_actions, hidden), jax.tree.map(jnp.asarray, q_params)

    def __call__(self, obs):
        return jnp.argmax(self.network.apply(self.q_params, obs), axis=-1).astype(jnp.int32)


def learned_rollout(q_params, preset: str, n_episodes: int, seed: int) -> dict:
    """Per-episode metrics, as ``rollouts``, of the greedy Q-network ``q_params`` on the
    same episodes as the scripted policies' for this ``preset``, ``n_episodes`` and ``seed``."""
    if preset not in PRESETS:
        raise ValueError(f"unknown preset {preset!r}; choose one of {list(PRESETS)}")
    params = _params(preset)
    greedy = _Greedy(q_params, core.N_ACTIONS)
    out = _rollout(jax.random.PRNGKey(seed), params, n_episodes, jnp.int32(0), greedy)
    return _finish(out, params.config)


def report_outcomes(policy_path, preset: str, episodes: int, seed: int) -> dict:
    """The report comparison's paired outcomes (``otgym.experiments.task_report.run``): the
    scripted baseline and the greedy Q-network of ``policy_path`` on the same
    ``episodes`` from ``seed`` (per episode: ``success``, the throughput and the task's
    other metrics at the episode's end)."""
    from otgym.rl.policy import load_policy

    q_params, _ = load_policy(policy_path, core.OBS_SIZE, core.N_ACTIONS)
    return {
        "baseline": rollout(preset, "baseline", episodes, seed),
        "learned": learned_rollout(q_params, preset, episodes, seed),
    }


def summarise(outcome: dict) -> dict:
    """Means over the episodes, and the purity's 95 % normal interval (1.96 standard errors)."""
    n = len(outcome["purity"])
    summary = {name: float(np.mean(outcome[name])) for name in METRICS}
    summary["purity_ci95"] = 1.96 * float(np.std(outcome["purity"], ddof=1)) / np.sqrt(n) if n > 1 else float("nan")
    summary["episodes"] = n
    return summary


def table(n_episodes: int, seed: int, presets=tuple(PRESETS), policies=POLICIES) -> list[dict]:
    rows = []
    for preset in presets:
        for policy, outcome in rollouts(preset, tuple(policies), n_episodes, seed).items():
            rows.append({"preset": preset, "policy": policy, **summarise(outcome)})
    return rows


def markdown(rows: list[dict]) -> str:
    lines = [
        "| preset | policy | purity [95 %] | yield | throughput (cells/min) | lost | dose per cell (mJ/um^2) |",
        "|---|---|---|---:|---:|---:|---:|",
    ]
    for r in rows:
        lines.append(
            f"| {r['preset']} | {r['policy']} | {r['purity']:.3f} +- {r['purity_ci95']:.3f} | {r['yield']:.3f} | "
            f"{r['throughput_cells_per_min']:.2f} | {r['cells_lost']:.2f} | {r['light_dose_per_cell_mj_per_um2']:.3g} |"
        )
    return "\n".join(lines)
