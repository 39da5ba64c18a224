"""Throughput of every registered task (``otgym list tasks``): environment steps per
second at 1 and 1024 environments, and the compile time of the batched reset and step,
each task on its default preset.

A step is timed as ``step_batch`` of a fixed batch state with a fixed action (the
action space's first sample under seed 0, the same in every environment), a fresh key
each call, so each call does the same work; one call's wall time over the environments
is the rate. Compile time is the first reset plus the first step (tracing, XLA's
compile, one run), per environment count.

Reference, where one exists: a NumPy loop of the same step. The ``assemble`` task's
physics has one (``numpy_substep`` of physics_throughput.py over the task's own model
arrays: Euler-Maruyama, traps held, timed over substeps and scaled to a frame's
substeps, as benchmarks/assemble_throughput.py does); the transport scene's step
(walls, flow, obstacle propulsion, the events the transport and orient tasks read) has
none, and its row says so.

Run from the checkout to time (the script's folder comes first on ``sys.path``, so name
the checkout): PYTHONPATH=. python benchmarks/task_throughput.py [--envs 1,1024]
[--quick] [--tasks a,b]
"""

from __future__ import annotations

import argparse
import platform
import sys
import time
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

from otgym import registry, tasks

sys.path.insert(0, str(Path(__file__).resolve().parent))
from physics_throughput import NumpyModel, numpy_substep  # noqa: E402


def _rate(call, min_seconds: float) -> float:
    calls, start = 0, time.perf_counter()
    while time.perf_counter() - start < min_seconds:
        call()
        calls += 1
    return calls / (time.perf_counter() - start)


def fixed_actions(task, params, n_env: int):
    space = task.action_space(params)
    space.seed(0)
    one = np.asarray(task.check_action(space.sample(), params))
    return jnp.asarray(np.broadcast_to(one, (n_env, *one.shape)).copy())


def time_task(task, params, n_env: int, min_seconds: float) -> tuple[float, float]:
    """(compile seconds of reset + step, environment steps per second)."""
    reset = jax.jit(task.reset_batch, static_argnums=2)
    step = jax.jit(task.step_batch)
    key = jax.random.PRNGKey(0)
    actions = fixed_actions(task, params, n_env)
    start = time.perf_counter()
    _, state = reset(key, params, n_env)
    jax.block_until_ready(step(key, state, actions, params))
    compile_s = time.perf_counter() - start
    keys = iter(np.asarray(jax.random.split(jax.random.PRNGKey(1), 100_000)))  # host rows: no slicing op

    def one():
        jax.block_until_ready(step(next(keys), state, actions, params)[1])

    return compile_s, _rate(one, min_seconds) * n_env


def numpy_rate(task, params, n_env: int, min_seconds: float) -> float | None:
    """Environment steps per second of a NumPy loop of the same step, or None if none exists."""
    if task.name != "assemble":
        return None
    model = params.model
    _, state = jax.jit(task.reset_batch, static_argnums=2)(jax.random.PRNGKey(0), params, n_env)
    reference = NumpyModel(model)
    pose = np.asarray(state.physics.pose, np.float64)
    traps = np.asarray(state.physics.trap_xy_um, np.float64)
    rng = np.random.default_rng(0)
    substeps, start = 0, time.perf_counter()
    while time.perf_counter() - start < min_seconds:
        pose = numpy_substep(reference, pose, traps, rng.standard_normal(pose.shape))
        substeps += 1
    return substeps * n_env / (time.perf_counter() - start) / model.substeps


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--envs", default="1,1024", help="comma-separated environment counts")
    parser.add_argument("--quick", action="store_true", help="1 s timing windows instead of 3 s")
    parser.add_argument("--tasks", default=None, help="comma-separated task names (default: every registered task)")
    args = parser.parse_args()
    window = 1.0 if args.quick else 3.0
    names = args.tasks.split(",") if args.tasks else list(registry.names("tasks"))
    counts = [int(n) for n in args.envs.split(",")]
    import otgym

    print(f"{platform.processor() or platform.machine()}, JAX {jax.__version__} on {jax.devices()[0].device_kind}")
    print(f"otgym from {Path(otgym.__file__).parent}")
    print("| task | preset | envs | compile s (reset + step) | env steps/s | NumPy loop env steps/s | task / NumPy |")
    print("| --- | --- | ---: | ---: | ---: | ---: | ---: |")
    for name in names:
        task = tasks.load(name)
        preset = task.presets()[0]
        params = task.make_params(task.config(preset))
        for n_env in counts:
            compile_s, rate = time_task(task, params, n_env, window)
            reference = numpy_rate(task, params, n_env, window)
            versus = (
                ("-", "none of the same step")
                if reference is None
                else (f"{reference:.3g}", f"{rate / reference:.0f}x")
            )
            print(
                f"| {name} | {preset} | {n_env} | {compile_s:.1f} | {rate:.3g} | {versus[0]} | {versus[1]} |",
                flush=True,
            )


if __name__ == "__main__":
    main()
