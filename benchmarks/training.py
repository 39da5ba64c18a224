"""Training benchmark (issues 5 and 10): how reliably and how fast the pure-JAX DQN
reaches the acceptance on the ``paper`` SpeedControl preset.

Each training seed is trained (wall time from start, compile included) and tested on
fresh episodes (seeds ``--eval-seed`` onwards, used neither in training nor in the
shipped policy's selection) against the constant speeds with
``speed_control_eval.acceptance``: it must finish significantly faster (sign test)
than the fastest constant speed at least as safe as it, and keep its steps safe. The
benchmark prints the fraction of training seeds that pass (goal: at least 4 of 5).
Also the functional env's batched steps/s, and the reference, same run:
stable-baselines3 DQN on the Gymnasium adapter for the same number of steps as one
of our seeds, timed over a sample and extrapolated (labelled so; it steps one env at
a time). Without SB3 the adapter alone is timed (one env, random actions, no
learning): a floor under any SB3 run, so the ratio printed is a lower bound.

    python benchmarks/training.py [--seeds 0 1 2 3 4] [--steps 204800] [--episodes 256] [--repeats 2]
"""

from __future__ import annotations

import argparse
import time

import jax
import jax.numpy as jnp
import numpy as np

from otgym.rl.dqn import DQNConfig


def env_steps_per_s(params, n_envs: int = 256, n_steps: int = 20) -> float:
    from otgym.tasks.transport import speed_control as spc

    reset, step = jax.jit(spc.reset_batch, static_argnums=2), jax.jit(spc.step_batch)
    _, state = reset(jax.random.PRNGKey(0), params, n_envs)
    action = jnp.full(n_envs, 2)
    state = jax.block_until_ready(step(jax.random.PRNGKey(1), state, action, params)[1])
    start = time.perf_counter()
    for index in range(n_steps):
        state = step(jax.random.PRNGKey(index), state, action, params)[1]
    jax.block_until_ready(state)
    return n_envs * n_steps / (time.perf_counter() - start)


def sb3_seconds(total_steps: int, sample_steps: int, learning_starts: int = 500) -> float | None:
    """Seconds SB3 DQN needs for ``total_steps`` on the Gymnasium adapter, extrapolated
    from ``sample_steps`` timed after its ``learning_starts`` (before them it does no
    gradient steps) and after the adapter's JAX compile; torch on one thread (its
    intra-op threads only slow these tiny MLPs on 2 cores). None without SB3."""
    try:
        import gymnasium as gym
        import torch
        from stable_baselines3 import DQN
    except ImportError:
        return None
    import otgym.envs  # noqa: F401

    torch.set_num_threads(1)
    env = gym.make("otgym/SpeedControl-v0")
    env.reset(seed=0)
    env.step(0)  # compile the adapter's jitted step outside the timing
    model = DQN("MlpPolicy", env, learning_starts=learning_starts, verbose=0, seed=0)
    model.learn(learning_starts)
    start = time.perf_counter()
    model.learn(sample_steps, reset_num_timesteps=False)
    return (time.perf_counter() - start) * total_steps / sample_steps


def adapter_seconds(total_steps: int, sample_steps: int = 1000) -> float:
    """Seconds the Gymnasium adapter alone needs for ``total_steps`` (extrapolated)."""
    import gymnasium as gym

    import otgym.envs  # noqa: F401

    env = gym.make("otgym/SpeedControl-v0")
    env.reset(seed=0)
    env.step(0)  # compile
    start = time.perf_counter()
    for _ in range(sample_steps):
        _, _, terminated, truncated, _ = env.step(env.action_space.sample())
        if terminated or truncated:
            env.reset()
    return (time.perf_counter() - start) * total_steps / sample_steps


def constant_speed_evaluation(params, hidden, episodes: int, seed: int, repeats: int):
    """The constant speeds alone on the test episodes (the same for every training seed);
    the rollout's network is evaluated but not used by them."""
    from otgym.experiments.speed_control.evaluate import evaluate
    from otgym.rl.network import QNetwork
    from otgym.tasks.transport import core as tr

    levels = tuple(range(1, params.config.n_actions + 1))
    unused = QNetwork(params.config.n_actions, tuple(hidden)).init(jax.random.PRNGKey(0), jnp.zeros((1, tr.OBS_SIZE)))
    return evaluate(params, unused, hidden, episodes, seed, policies=levels, repeats=repeats)


def with_rl(constant, rl):
    """One Evaluation holding RL's rows then the constant speeds' (same episodes)."""
    from otgym.experiments.speed_control.evaluate import Evaluation

    return Evaluation(
        rl.names + constant.names,
        rl.speeds_um_s + constant.speeds_um_s,
        np.concatenate([rl.progress, constant.progress]),
        np.concatenate([rl.success, constant.success]),
        np.concatenate([rl.time_s, constant.time_s]),
        rl.force_pn + constant.force_pn,
        rl.distance_um + constant.distance_um,
    )


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--steps", type=int, default=DQNConfig().total_env_steps, help="env steps per seed")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4], help="training seeds")
    parser.add_argument("--episodes", type=int, default=256, help="test episodes per batch")
    parser.add_argument("--repeats", type=int, default=2, help="test batches (seeds --eval-seed onwards)")
    parser.add_argument(
        "--eval-seed",
        type=int,
        default=301,
        help="first test seed (fresh: not 1000, the selection's, nor 201-204, the README's Table II)",
    )
    parser.add_argument("--sb3-sample", type=int, default=10_000, help="SB3 steps timed (then extrapolated)")
    args = parser.parse_args()
    from otgym.experiments.speed_control.evaluate import acceptance, evaluate, passes
    from otgym.experiments.speed_control.train import train
    from otgym.tasks.transport import speed_control as spc
    from otgym.tasks.transport.presets import paper

    task = paper()
    params = spc.make_params(task)
    config = DQNConfig(total_env_steps=args.steps)
    limits = task.force_band_pn[1], task.deviation_limit_um
    constant = constant_speed_evaluation(params, config.hidden, args.episodes, args.eval_seed, args.repeats)
    episodes = constant.success.shape[1]
    print(
        f"test: {episodes} episodes (seeds {args.eval_seed}..{args.eval_seed + args.repeats - 1}); constant "
        "speeds: "
        + ", ".join(
            f"{row['policy']} {row['success_rate']:.3f} / {row['ATCT_s']:.1f} s"
            for row in constant.rows()
            if row["ATCT_s"] is not None
        )
    )
    passed, train_s = [], []
    for seed in args.seeds:
        result = train(task, config, seed, params=params)
        train_s.append(result.wall_s)
        rl = evaluate(
            params, result.q_params, config.hidden, args.episodes, args.eval_seed, policies=(0,), repeats=args.repeats
        )
        evaluation = with_rl(constant, rl)
        checks = acceptance(evaluation, evaluation.safety("RL", *limits))
        row = next(evaluation.rows())
        passed.append(passes(checks))
        print(
            f"seed {seed}: trained {result.env_steps} steps in {result.wall_s:.0f} s; success {row['success_rate']:.3f} "
            f"[{row['success_ci95_low']:.3f}, {row['success_ci95_high']:.3f}], ATCT {row['ATCT_s']:.2f} s; reference "
            f"{checks['reference']}: first in {checks['faster_episodes']}, later in {checks['slower_episodes']} "
            f"(p = {checks['speed_p']:.2g}); force safe {checks['force_safe']}; handles within "
            f"{limits[1]} um in {evaluation.safety('RL', *limits)['distance_within_limit']:.1%} of the steps "
            f"(G1: {evaluation.safety('G1', *limits)['distance_within_limit']:.1%}, reported, not required); "
            f"{'PASS' if passed[-1] else 'fail'}",
            flush=True,
        )
    print(
        f"training seeds passing the acceptance: {sum(passed)} of {len(passed)} (goal: at least 4 of 5); "
        f"training {np.mean(train_s):.0f} s per seed (compile included)"
    )
    print(f"functional env, 256 envs batched: {env_steps_per_s(params):.0f} env steps/s")
    ours_s = float(np.mean(train_s))
    sb3 = sb3_seconds(result.env_steps, args.sb3_sample)
    if sb3 is None:
        floor = adapter_seconds(result.env_steps)
        print(
            f"stable-baselines3 is not installed (pip install '.[sb3]'); the Gymnasium adapter alone (one env, no "
            f"learning) needs {floor:.0f} s for {result.env_steps} steps (extrapolated from 1000): SB3 would be at "
            f"least {floor / ours_s:.1f}x slower than our {ours_s:.1f} s per seed"
        )
    else:
        print(
            f"SB3 DQN, {result.env_steps} steps on the Gymnasium adapter, extrapolated from {args.sb3_sample}: "
            f"{sb3:.0f} s; ours (one seed, whole run, compile included) {ours_s:.1f} s; ratio {sb3 / ours_s:.1f}x"
        )


if __name__ == "__main__":
    main()
