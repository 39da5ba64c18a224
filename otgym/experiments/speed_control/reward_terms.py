"""Does every term of the speed-control reward matter?

Runs the shipped policy (greedy) and uniformly random speeds on the same seeded
episodes of the ``paper`` preset and records every term of every step's reward
(``otgym.tasks.transport.core.reward_terms``, weighted as trained). Per policy and term:
the fraction of steps where it is not zero (where it binds), its mean and range, and
its share of the summed absolute reward. A term that is zero, or the same, in every
step teaches nothing but the episode's length; the table says which.

    otgym experiment reward-terms [--policy pretrained] [--episodes 256] [--seed 401] --out DIR

writes DIR/reward_terms.csv, reward_terms.md and reward_terms.png (one histogram per term).
"""

from __future__ import annotations

import csv
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

from otgym.rl.network import QNetwork
from otgym.tasks.transport import core as tr
from otgym.tasks.transport import speed_control as spc

POLICIES = ("RL", "random")


def collect(params: tr.TransportParams, q_params, hidden, n_episodes: int, seed: int) -> dict:
    """{policy: {term: values (steps,)}} over the steps each episode ran, for the greedy
    policy and for uniformly random speeds on the same seeded episodes."""
    config = params.config
    network = QNetwork(config.n_actions, tuple(hidden))
    levels = jnp.asarray(config.speed_levels_um_s)

    @jax.jit
    def run(key):
        reset_key, key = jax.random.split(key)
        obs, state = spc.reset_batch(reset_key, params, n_episodes)
        tile = lambda a: jnp.concatenate([a, a])  # noqa: E731  RL first, random second
        obs, state = tile(obs), jax.tree.map(tile, state)
        random_policy = jnp.arange(2 * n_episodes) >= n_episodes

        def body(carry, step_key):
            obs, state, active = carry
            random_key, step_key = jax.random.split(step_key)
            greedy = jnp.argmax(network.apply(q_params, obs), axis=-1)
            action = jnp.where(random_policy, jax.random.randint(random_key, greedy.shape, 0, config.n_actions), greedy)
            obs, state, _, terminated, truncated, info = spc.step_batch(step_key, state, action, params)
            terms = tr.reward_terms(
                config, info["events"], levels[action], info["failed"], info["success"], cell_behind_um=-obs[:, 2]
            )
            return (obs, state, active & ~(terminated | truncated)), (active, terms)

        carry = (obs, state, jnp.ones(2 * n_episodes, bool))
        _, records = jax.lax.scan(body, carry, jax.random.split(key, config.max_steps))
        return records

    active, terms = jax.device_get(run(jax.random.PRNGKey(seed)))
    halves = {"RL": slice(0, n_episodes), "random": slice(n_episodes, 2 * n_episodes)}
    return {
        policy: {name: np.asarray(values)[:, half][active[:, half]] for name, values in terms.items()}
        for policy, half in halves.items()
    }


def summarize(samples: dict) -> list[dict]:
    """One row per policy and term: steps, fraction of steps where it binds (is not
    zero), mean, min, max, and its share of the summed absolute reward."""
    rows = []
    for policy, terms in samples.items():
        total = sum(np.abs(values).sum() for values in terms.values())
        for name, values in terms.items():
            rows.append(
                {
                    "policy": policy,
                    "term": name,
                    "steps": int(values.size),
                    "binds": float(np.mean(values != 0)),
                    "mean": float(values.mean()),
                    "min": float(values.min()),
                    "max": float(values.max()),
                    "share_of_abs_reward": float(np.abs(values).sum() / total),
                }
            )
    return rows


def markdown(rows: list[dict]) -> list[str]:
    lines = [
        "| policy | term | steps | binds (fraction of steps) | mean | min | max | share of abs. reward |",
        "|---|---|---:|---:|---:|---:|---:|---:|",
    ]
    for row in rows:
        lines.append(
            f"| {row['policy']} | {row['term']} | {row['steps']} | {row['binds']:.4f} | {row['mean']:.4g} | "
            f"{row['min']:.4g} | {row['max']:.4g} | {row['share_of_abs_reward']:.3f} |"
        )
    return lines


def write_figure(samples: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(samples["RL"])
    fig, axes = plt.subplots(2, (len(names) + 1) // 2, figsize=(3.2 * ((len(names) + 1) // 2), 6))
    for axis, name in zip(axes.ravel(), names):
        values = [samples[policy][name] for policy in POLICIES]
        low, high = min(v.min() for v in values), max(v.max() for v in values)
        axis.set_title(name)
        if low == high:
            axis.text(0.5, 0.5, f"{low:g} in every step", ha="center", va="center", transform=axis.transAxes)
            axis.set_xticks([])
            axis.set_yticks([])
            continue
        bins = np.linspace(low - 1e-9, high + 1e-9, 30)
        for policy, data in zip(POLICIES, values):
            axis.hist(data, bins=bins, alpha=0.6, label=policy, weights=np.full(data.size, 1 / data.size))
        axis.set_yscale("log")
        axis.locator_params(axis="x", nbins=4)
        axis.set_xlabel("weighted reward per step")
    axes.ravel()[0].set_ylabel("fraction of steps")
    axes.ravel()[0].legend()
    for axis in axes.ravel()[len(names) :]:
        axis.axis("off")
    fig.suptitle("Speed-control reward terms per step: trained policy and random speeds, same episodes")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def run(policy: str, episodes: int, seed: int, out: Path, log=print) -> None:
    """Measure the reward terms of ``policy`` and of random speeds on ``episodes`` episodes;
    write reward_terms.csv, .md and .png into ``out`` (ValueError or OSError for a bad
    policy or folder, before any work)."""
    from otgym.experiments.common.output_folder import check_out_dir
    from otgym.rl.policy import load_policy, policy_meta, resolve_policy
    from otgym.tasks.transport.presets import preset

    check_out_dir(out)
    path = resolve_policy(policy)
    task = preset(policy_meta(path).get("preset", "paper"))
    q_params, meta = load_policy(path, tr.OBS_SIZE, task.n_actions)
    log(
        f"running {episodes} episodes for the policy and for random speeds (compile included, about a "
        "minute for 256 on 2 cores)"
    )
    samples = collect(spc.make_params(task), q_params, meta["hidden"], episodes, seed)
    rows = summarize(samples)
    with open(out / "reward_terms.csv", "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    text = "\n".join(markdown(rows)) + "\n"
    (out / "reward_terms.md").write_text(text)
    write_figure(samples, out / "reward_terms.png")
    log(text)
    log(f"wrote {out}/reward_terms.csv, reward_terms.md, reward_terms.png")
