"""Throughput of the ``assemble`` task: environment steps (SLM frames of 50 ms, 500
physics substeps each) per second at 1 and 1024 environments, and the compile time of
the batched reset and step.

References, measured in the same run:
* the bare physics (``otgym.physics.control_step_batch`` of the task's model, traps
  held): the task's own work (plan, events, observation) is the difference;
* a NumPy loop of the same physics (``numpy_substep`` of benchmarks/physics_throughput.py:
  Euler-Maruyama over the same model arrays, vectorised over beads and environments),
  timed over a few substeps and scaled to a frame's 500.

Run: python benchmarks/assemble_throughput.py [--preset ring] [--quick] [--envs 1,1024]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

from otgym import physics as ph
from otgym import tasks

sys.path.insert(0, str(Path(__file__).resolve().parent))
from task_throughput import _rate, numpy_rate  # noqa: E402  (the timing loop and the NumPy reference, shared)


def time_task(task, params, n_env: int, min_seconds: float) -> tuple[float, float]:
    """(compile seconds of reset + step, environment steps per second)."""
    reset = jax.jit(task.reset_batch, static_argnums=2)
    step = jax.jit(task.step_batch)
    key = jax.random.PRNGKey(0)
    actions = jnp.full(n_env, 1, jnp.int32)
    start = time.perf_counter()
    _, state = reset(key, params, n_env)
    jax.block_until_ready(step(key, state, actions, params))
    compile_s = time.perf_counter() - start
    keys = iter(np.asarray(jax.random.split(jax.random.PRNGKey(1), 100_000)))  # host rows: no slicing op

    def one():
        jax.block_until_ready(step(next(keys), state, actions, params)[1])

    return compile_s, _rate(one, min_seconds) * n_env


def time_physics(params, n_env: int, min_seconds: float) -> float:
    model = params.model
    task = tasks.load("assemble")
    _, state = jax.jit(task.reset_batch, static_argnums=2)(jax.random.PRNGKey(0), params, n_env)
    step = jax.jit(ph.control_step_batch)
    controls = ph.Controls.zeros(model, n_env)
    physics = state.physics
    jax.block_until_ready(step(model, physics, controls, jax.random.PRNGKey(0)))
    keys = iter(np.asarray(jax.random.split(jax.random.PRNGKey(1), 100_000)))  # host rows: no slicing op

    def one():
        jax.block_until_ready(step(model, physics, controls, next(keys))[0])

    return _rate(one, min_seconds) * n_env


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--preset", default="ring")
    parser.add_argument("--quick", action="store_true", help="shorter timing windows")
    parser.add_argument("--envs", default="1,1024", help="comma-separated environment counts")
    args = parser.parse_args()
    window = 1.0 if args.quick else 3.0
    task = tasks.load("assemble")
    params = task.make_params(task.config(args.preset))
    config = params.config
    print(
        f"assemble ({args.preset}: {config.n_beads} beads, {config.substeps} substeps per "
        f"{config.frame_period_s * 1e3:g} ms frame), {jax.devices()[0].device_kind}"
    )
    print("| envs | compile s | task steps/s | bare physics steps/s | NumPy loop steps/s | task / NumPy |")
    print("| --- | --- | --- | --- | --- | --- |")
    for n_env in [int(n) for n in args.envs.split(",")]:
        compile_s, task_rate = time_task(task, params, n_env, window)
        physics_rate = time_physics(params, n_env, window)
        numpy_steps = numpy_rate(task, params, n_env, window)
        print(
            f"| {n_env} | {compile_s:.1f} | {task_rate:.3g} | {physics_rate:.3g} | {numpy_steps:.3g} | "
            f"{task_rate / numpy_steps:.1f} |",
            flush=True,
        )


if __name__ == "__main__":
    main()
