"""Training benchmark (issue 5): wall time from start (compile included) of the
pure-JAX DQN on the ``paper`` SpeedControl preset, the acceptance checks on 64
evaluation episodes per policy, and the functional env's batched steps/s. If
stable-baselines3 is installed, its DQN on the Gymnasium adapter is timed over a
sample of steps and extrapolated to the same number of steps (it steps one env
at a time, about 100x slower per step, so the full run is not waited for). Without
it, the adapter alone is timed (one env, random actions, no learning): a floor under
any SB3 run's time, so the ratio printed is a lower bound.

    python benchmarks/training.py [--steps 200000] [--episodes 64]
"""

from __future__ import annotations

import argparse
import time

import jax
import jax.numpy as jnp


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


def sb3_seconds(total_steps: int, sample_steps: int = 2000) -> float | None:
    try:
        import gymnasium as gym
        from stable_baselines3 import DQN
    except ImportError:
        return None
    import otgym.envs  # noqa: F401

    model = DQN("MlpPolicy", gym.make("otgym/SpeedControl-v0"), learning_starts=500, verbose=0)
    start = time.perf_counter()
    model.learn(sample_steps)
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
    parser.add_argument("--steps", type=int, default=200_000)
    parser.add_argument("--episodes", type=int, default=64)
    args = parser.parse_args()
    from otgym.envs.presets import paper
    from otgym.envs import speed_control as spc
    from otgym.experiments.speed_control import train
    from otgym.experiments.speed_control_eval import evaluate
    from otgym.rl.dqn import DQNConfig

    start = time.perf_counter()
    task = paper()
    params = spc.make_params(task)
    config = DQNConfig(total_env_steps=args.steps)
    result = train(task, config, seed=0, params=params)
    trained_s = time.perf_counter() - start
    evaluation = evaluate(params, result.q_params, config.hidden, args.episodes, seed=1)
    total_s = time.perf_counter() - start
    rows = {row["policy"]: row for row in evaluation.rows()}
    rl = rows["RL"]
    safe_constants = [r for name, r in rows.items() if name.startswith("G") and r["success_rate"] == 1.0]
    faster = all(rl["ATCT_s"] is not None and rl["ATCT_s"] < r["ATCT_s"] for r in safe_constants)
    safety = evaluation.safety("RL", task.force_band_pn[1], task.deviation_limit_um)
    print(f"training: {result.env_steps} env steps, {result.episodes} episodes, {trained_s:.1f} s "
          f"(compile included); with evaluation {total_s:.1f} s")
    for name, row in rows.items():
        atct = "/" if row["ATCT_s"] is None else f"{row['ATCT_s']:.2f}"
        print(f"  {name:9s} ASR {row['ASR']:.3f}  ATCT {atct:>6s} s  success {row['success_rate']:.3f}")
    print(f"acceptance: RL ASR 1.00: {rl['ASR'] == 1.0}; ATCT below every constant speed with success 1.00: "
          f"{faster}; force < 10 pN in {safety['force_below_limit']:.2%}, handle within "
          f"{task.deviation_limit_um} um in {safety['distance_within_limit']:.2%} of samples")
    print(f"functional env, 256 envs batched: {env_steps_per_s(params):.0f} env steps/s")
    sb3 = sb3_seconds(result.env_steps)
    if sb3 is None:
        floor = adapter_seconds(result.env_steps)
        print(f"stable-baselines3 is not installed; the Gymnasium adapter alone (one env, no learning) needs "
              f"{floor:.0f} s for the same steps (extrapolated): SB3 would be at least {floor / trained_s:.1f}x slower")
    else:
        print(f"SB3 DQN, same steps (extrapolated): {sb3:.0f} s; ratio {sb3 / trained_s:.1f}x")


if __name__ == "__main__":
    main()
