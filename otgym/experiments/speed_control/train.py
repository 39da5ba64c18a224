"""DQN training of any task with a discrete action space (``otgym.rl.dqn`` on the
task's batched ``reset_batch`` / ``step_batch`` / ``auto_reset``, the whole loop in
``jit``): ``train_task`` for a registered task (``otgym train --task``), ``train`` for
the learned speed controller of a ``SpeedControl`` preset (paper section II-C, III-B).
Writes the policy file and the learning curve (cumulative reward per episode, the
paper's Fig. 6c)."""

from __future__ import annotations

import dataclasses
import json
import time
from pathlib import Path

import gymnasium as gym
import jax
import numpy as np

from otgym import tasks
from otgym.rl.dqn import DQNConfig, Env, make_train
from otgym.rl.policy import save_policy
from otgym.tasks.base import Task
from otgym.tasks.transport import core as tr
from otgym.tasks.transport.presets import TaskConfig

CURVE_WINDOW = 50


def make_env(params: tr.TransportParams, task: Task | None = None) -> Env:
    """The DQN's batched environment of ``task`` (default: speed control) with ``params``;
    ValueError if the task's actions are not discrete."""
    task = task if task is not None else tasks.load("speed-control")
    space = task.action_space(params)
    if not isinstance(space, gym.spaces.Discrete):
        raise ValueError(f"task {task.name!r} has {type(space).__name__} actions; DQN needs a discrete action space")
    return Env(
        reset=lambda key, n: task.reset_batch(key, params, n),
        step=lambda key, state, action: task.step_batch(key, state, action, params),
        auto_reset=lambda key, obs, state, done: task.auto_reset(key, params, obs, state, done),
        obs_size=task.observation_size(params),
        n_actions=int(space.n),
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
    """Train the speed controller of preset ``task`` for one seed (``train_task``)."""
    speed = tasks.load("speed-control")
    params = speed.make_params(task) if params is None else params
    return train_task(speed, params, config, seed, progress, {"preset": task.name})


def train_task(
    task: Task | str,
    params=None,
    config: DQNConfig = DQNConfig(),
    seed: int = 0,
    progress=None,
    extra_meta: dict | None = None,
    preset: str | None = None,
) -> TrainResult:
    """Train ``task`` (a Task or a registered name; ``params`` default: its ``preset``'s)
    for one seed, chunk by chunk (each chunk one jitted call, the runner staying on the
    device); ``progress(done_chunks, n_chunks)`` after each. The policy's meta holds the
    task's own ``policy_meta``."""
    start = time.perf_counter()
    task = tasks.load(task) if isinstance(task, str) else task
    params = task.make_params(task.config(preset)) if params is None else params
    env = make_env(params, task)
    init, run_chunk, _ = make_train(config, env)
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
        "task": task.name,
        "preset": preset or task.presets()[0],
        "obs_size": env.obs_size,
        "n_actions": env.n_actions,
        **task.policy_meta(params),
        **(extra_meta or {}),
        "hidden": list(config.hidden),
        "env_steps": config.n_chunks * config.chunk_iters * config.n_envs,
        "seed": seed,
        "dqn": {
            name: list(value) if isinstance(value, tuple) else value
            for name, value in dataclasses.asdict(config).items()
        },
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
    _curve(result.episode_returns, out_dir / "learning_curve.png", result.meta)
    summary = {
        "episodes": result.episodes,
        "env_steps": result.env_steps,
        "wall_s": round(result.wall_s, 1),
        "final_mean_return": round(float(np.mean(result.episode_returns[-CURVE_WINDOW:])), 3),
    }
    (out_dir / "training.json").write_text(json.dumps({**summary, **result.meta}, indent=2))
    return summary


def _curve(returns: np.ndarray, path: Path, meta: dict) -> None:
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
    ax.set_title(f"DQN, task {meta.get('task', 'speed-control')}, preset {meta['preset']}")
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
