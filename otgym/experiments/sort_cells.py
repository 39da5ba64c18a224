"""The ``sort-cells`` scripted baseline against random and idle policies, and the
trade-off between robots and direct trapping in one table.

``python -m otgym.experiments.sort_cells --episodes 64 --seed 0`` prints, for each
preset (``robots``, ``direct``, and each manipulator at the other's flow and arrivals:
``robots-fast``, ``direct-slow``) and policy, the means over episodes (120 s each) of
purity, yield, throughput, cells lost and the light dose per cell, with the purity's 95 %
normal interval."""

from __future__ import annotations

import argparse
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


@functools.partial(jax.jit, static_argnums=(2,))
def _rollout(key, params: core.SortParams, n_episodes: int, policies):
    """``n_episodes`` episodes from ``key``, each run once under every policy of
    ``policies`` (P,) (indices into ``POLICIES``): one program for all of them."""
    task = tasks.load("sort-cells")
    reset_key, run_key = jax.random.split(key)
    obs, state = task.reset_batch(reset_key, params, n_episodes)
    copies = policies.shape[0]
    obs, state = jax.tree.map(lambda a: jnp.concatenate([a] * copies), (obs, state))
    which = jnp.repeat(policies, n_episodes)
    n = which.shape[0]

    def body(carry, step_key):
        obs, state = carry
        act_key, step_key = jax.random.split(step_key)
        scripted = baseline.actions(obs, params)
        random = jax.random.randint(act_key, (n,), 0, core.N_ACTIONS)
        action = jnp.where(which == 0, scripted, jnp.where(which == 1, random, 0)).astype(jnp.int32)
        obs, state, *_ = task.step_batch(step_key, state, action, params)
        return (obs, state), None

    (obs, state), _ = jax.lax.scan(body, (obs, state), jax.random.split(run_key, params.config.max_steps))
    return jax.tree.map(lambda a: a.reshape(copies, n_episodes), core.metrics(state, params.config))


def rollouts(preset: str, policies, n_episodes: int, seed: int) -> dict:
    """``{policy: per-episode metrics (numpy (n,))}`` at the end of the same
    ``n_episodes`` episodes of ``preset`` (the same arrivals: same ``PRNGKey(seed)``
    resets and step keys) under each of ``policies`` (names of ``POLICIES``)."""
    if preset not in PRESETS:
        raise ValueError(f"unknown preset {preset!r}; choose one of {list(PRESETS)}")
    for policy in policies:
        if policy not in POLICIES:
            raise ValueError(f"unknown policy {policy!r}; choose one of {list(POLICIES)}")
    indices = jnp.asarray([POLICIES.index(p) for p in policies], jnp.int32)
    out = jax.device_get(_rollout(jax.random.PRNGKey(seed), _params(preset), n_episodes, indices))
    return {policy: {name: np.asarray(value[i]) for name, value in out.items()} for i, policy in enumerate(policies)}


def rollout(preset: str, policy: str, n_episodes: int, seed: int) -> dict:
    """Per-episode metrics (numpy (n,)) of ``n_episodes`` episodes of ``preset`` from
    ``PRNGKey(seed)`` under ``policy`` (one of ``POLICIES``)."""
    return rollouts(preset, (policy,), n_episodes, seed)[policy]


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


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=64)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--preset", action="append", choices=list(PRESETS))
    parser.add_argument("--policy", action="append", choices=list(POLICIES))
    args = parser.parse_args(argv)
    if args.episodes < 2:
        parser.error(f"--episodes must be at least 2, got {args.episodes}")
    rows = table(args.episodes, args.seed, tuple(args.preset or PRESETS), tuple(args.policy or POLICIES))
    print(markdown(rows))


if __name__ == "__main__":
    main()
