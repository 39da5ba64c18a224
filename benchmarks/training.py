"""Training benchmark (issue 5): wall time from start (compile included) of the
pure-JAX DQN on the ``paper`` SpeedControl preset to the acceptance: the shipped
policy's protocol (``otgym.experiments.pretrain``: train the seeds, keep the best on
validation episodes), then the test on fresh episodes against the constant speeds;
and the functional env's batched steps/s. Reference, same run: stable-baselines3 DQN
on the Gymnasium adapter for the same number of steps as one of our seeds, timed over
a sample and extrapolated (it steps one env at a time; the whole run would take about
seven minutes). Without SB3 the adapter alone is timed (one env, random actions, no
learning): a floor under any SB3 run, so the ratio printed is a lower bound.

    python benchmarks/training.py [--steps 204800] [--seeds 0] [--episodes 256]
"""

from __future__ import annotations

import argparse
import time

import jax
import jax.numpy as jnp

from otgym.rl.dqn import DQNConfig


def env_steps_per_s(params, n_envs: int = 256, n_steps: int = 20) -> float:
    from otgym.envs import speed_control as spc

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


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--steps", type=int, default=DQNConfig().total_env_steps, help="env steps per seed")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0], help="training seeds, the best on validation kept")
    parser.add_argument("--episodes", type=int, default=256, help="test episodes per policy")
    parser.add_argument("--sb3-sample", type=int, default=10_000, help="SB3 steps timed (then extrapolated)")
    args = parser.parse_args()
    from otgym.envs import speed_control as spc
    from otgym.envs.presets import paper
    from otgym.experiments.pretrain import train_and_select
    from otgym.experiments.speed_control_eval import acceptance, evaluate

    start = time.perf_counter()
    task = paper()
    params = spc.make_params(task)
    config = DQNConfig(total_env_steps=args.steps)
    best, candidates = train_and_select(task, config, args.seeds, params=params)
    selected_s = time.perf_counter() - start
    evaluation = evaluate(params, best.result.q_params, config.hidden, args.episodes, seed=1)
    total_s = time.perf_counter() - start
    rows = [row for row in evaluation.rows() if row["policy"] != "untrained"]
    safety = evaluation.safety("RL", task.force_band_pn[1], task.deviation_limit_um)
    checks = acceptance(rows, safety)
    print(f"training {len(args.seeds)} seeds x {best.result.env_steps} env steps and validation: {selected_s:.1f} s "
          f"(compile included); kept seed {best.seed}; with the {args.episodes}-episode test: {total_s:.1f} s")
    for row in rows:
        atct = "/" if row["ATCT_s"] is None else f"{row['ATCT_s']:.2f}"
        print(f"  {row['policy']:3s} ASR {row['ASR']:.3f}  ATCT {atct:>6s} s  success {row['success_rate']:.3f}")
    print(f"acceptance: RL completes all {args.episodes} episodes: {checks['asr_one']}; ATCT below every constant "
          f"speed that also does ({', '.join(checks['faster_than'])}): {checks['faster']}; force < "
          f"{task.force_band_pn[1]:g} pN in {safety['force_below_limit']:.2%} of steps; handle within "
          f"{task.deviation_limit_um} um in {safety['distance_within_limit']:.2%} (median {safety['distance_median_um']:.3f} um)")
    print(f"functional env, 256 envs batched: {env_steps_per_s(params):.0f} env steps/s")
    ours_s = best.result.wall_s
    sb3 = sb3_seconds(best.result.env_steps, args.sb3_sample)
    if sb3 is None:
        floor = adapter_seconds(best.result.env_steps)
        print(f"stable-baselines3 is not installed (pip install '.[sb3]'); the Gymnasium adapter alone (one env, no "
              f"learning) needs {floor:.0f} s for {best.result.env_steps} steps: SB3 would be at least "
              f"{floor / ours_s:.1f}x slower than our {ours_s:.1f} s")
    else:
        print(f"SB3 DQN, {best.result.env_steps} steps on the Gymnasium adapter (extrapolated from {args.sb3_sample}): "
              f"{sb3:.0f} s; ours (one seed, compile included) {ours_s:.1f} s; ratio {sb3 / ours_s:.1f}x")


if __name__ == "__main__":
    main()
