"""Training job of the learned speed controller (paper section II-C, III-B): DQN
(``otgym.rl.dqn``) on the ``SpeedControl`` task of a preset, the whole loop in
``jit``; writes the policy file and the learning curve (cumulative reward per
episode, the paper's Fig. 6c)."""

from __future__ import annotations

import dataclasses
import json
import time
from pathlib import Path

import jax
import numpy as np

from otgym.envs import speed_control as spc
from otgym.envs import transport as tr
from otgym.envs.presets import TaskConfig
from otgym.rl.dqn import DQNConfig, Env, make_train
from otgym.rl.policy import save_policy

CURVE_WINDOW = 50


def make_env(params: tr.TransportParams) -> Env:
    return Env(
        reset=lambda key, n: spc.reset_batch(key, params, n),
        step=lambda key, state, action: spc.step_batch(key, state, action, params),
        auto_reset=lambda key, obs, state, done: tr.auto_reset(key, params, obs, state, done),
        obs_size=tr.OBS_SIZE,
        n_actions=params.config.n_actions,
    )


@dataclasses.dataclass
class TrainResult:
    q_params: dict
    episode_returns: np.ndarray  # mean return of the episodes that ended in each iteration, repeated per episode
    episodes: int
    env_steps: int
    wall_s: float
    meta: dict


def train(
    task: TaskConfig,
    config: DQNConfig = DQNConfig(),
    seed: int = 0,
    progress=None,
    params: tr.TransportParams | None = None,
) -> TrainResult:
    """Train one seed chunk by chunk (each chunk one jitted call, the runner staying
    on the device); ``progress(done_chunks, n_chunks)`` after each."""
    start = time.perf_counter()
    params = spc.make_params(task) if params is None else params
    init, run_chunk, _ = make_train(config, make_env(params))
    runner = jax.jit(init)(jax.random.PRNGKey(seed))
    run_chunk = jax.jit(run_chunk)
    chunks = []
    for index in range(config.n_chunks):
        runner, metrics = run_chunk(runner)
        chunks.append(jax.device_get(metrics))
        if progress is not None:
            progress(index + 1, config.n_chunks)
    jax.block_until_ready(runner.q_params)
    metrics = {name: np.concatenate([c[name] for c in chunks]) for name in chunks[0]}
    ended = metrics["episodes"] > 0
    returns = np.repeat(
        metrics["return_sum"][ended] / metrics["episodes"][ended], metrics["episodes"][ended].astype(int)
    )
    meta = {
        "preset": task.name,
        "obs_size": tr.OBS_SIZE,
        "n_actions": task.n_actions,
        "speed_levels_um_s": list(task.speed_levels_um_s),
        "hidden": list(config.hidden),
        "env_steps": config.n_chunks * config.chunk_iters * config.n_envs,
        "seed": seed,
    }
    return TrainResult(
        jax.device_get(runner.q_params),
        returns,
        int(metrics["episodes"].sum()),
        meta["env_steps"],
        time.perf_counter() - start,
        meta,
    )


def write_training(result: TrainResult, out_dir: Path) -> dict:
    """Write ``policy.npz``, ``learning_curve.png`` and ``training.json``."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    save_policy(out_dir / "policy.npz", result.q_params, result.meta)
    _curve(result.episode_returns, out_dir / "learning_curve.png", result.meta["preset"])
    summary = {
        "episodes": result.episodes,
        "env_steps": result.env_steps,
        "wall_s": round(result.wall_s, 1),
        "final_mean_return": round(float(np.mean(result.episode_returns[-CURVE_WINDOW:])), 3),
    }
    (out_dir / "training.json").write_text(json.dumps({**summary, **result.meta}, indent=2))
    return summary


def _curve(returns: np.ndarray, path: Path, preset: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4))
    episodes = np.arange(1, len(returns) + 1)
    ax.plot(episodes, returns, lw=0.3, color="tab:blue", alpha=0.4, label="episode")
    if len(returns) >= CURVE_WINDOW:
        smooth = np.convolve(returns, np.ones(CURVE_WINDOW) / CURVE_WINDOW, mode="valid")
        ax.plot(episodes[CURVE_WINDOW - 1 :], smooth, color="tab:blue", label=f"mean of {CURVE_WINDOW}")
    ax.set_xlabel("episode")
    ax.set_ylabel("cumulative reward per episode")
    ax.set_title(f"DQN speed control, preset {preset}")
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
