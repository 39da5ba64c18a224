"""Paired A/B throughput of two checkouts on one CPU core: a timing that survives a
busy machine.

Two worker processes, one per checkout (this one and ``--baseline``, e.g. a
``git worktree add ../otgym-old <commit>``), are pinned to the same core with XLA on
one thread and step the same scene over the same wall-clock window, started together.
The core's time is shared between them, so whatever else the machine runs slows both
alike, and the ratio of their control steps counts what differs: the code. (Timed one
after the other on this shared 2-core machine, two runs of one commit differed by up
to 1.75x; paired, repeated pairs of the same two commits agree to within a step or
two.)

Run: python benchmarks/paired_ab.py --baseline ../otgym-old [--scene transport|standard]
     [--envs 128] [--seconds 60] [--repeats 2] [--core 1]
Prints env-substeps/s of each and the ratio this / baseline per repeat.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path

WORKER = """
import sys, time
repo, scene_kind, n_env, start_at, window_s = sys.argv[1], sys.argv[2], int(sys.argv[3]), float(sys.argv[4]), float(sys.argv[5])
sys.path[:0] = [repo, repo + "/benchmarks"]
import jax, jax.numpy as jnp
from otgym import physics as ph
import physics_throughput as pt
if scene_kind == "standard":
    model, pose = pt.standard_model()
    state = jax.tree.map(lambda a: jnp.broadcast_to(a, (n_env,) + a.shape), ph.initial_state(model, pose))
    step, first, second, substeps = jax.jit(ph.control_step_batch), model, ph.Controls.zeros(model, n_env), pt.SUBSTEPS
else:
    from otgym.sim import scene as sc
    scene = sc.build_scene(sc.SceneConfig(kind="transport"))
    state = jax.vmap(sc.reset, in_axes=(None, 0))(scene, jax.random.split(jax.random.PRNGKey(0), n_env))
    step, first, second = jax.jit(sc.step_batch), scene, jnp.zeros((n_env, scene.n_traps, 2))
    substeps = scene.model.substeps
jax.block_until_ready(step(first, state, second, jax.random.PRNGKey(0)))  # compile before the window
while time.time() < start_at:
    time.sleep(0.01)
rate = pt.control_steps_per_second(step, first, state, second, window_s)
print(rate * window_s, window_s, rate * n_env * substeps, flush=True)
"""


def run_pair(this: Path, baseline: Path, scene: str, n_env: int, seconds: float, core: int, start_in_s: float):
    """Both workers' (calls, seconds, env-substeps/s), started at the same moment."""
    environment = dict(
        os.environ, XLA_FLAGS="--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1", JAX_PLATFORMS="cpu"
    )
    start_at = time.time() + start_in_s
    workers = [
        subprocess.Popen(
            [
                "taskset",
                "-c",
                str(core),
                sys.executable,
                "-c",
                WORKER,
                str(repo),
                scene,
                str(n_env),
                str(start_at),
                str(seconds),
            ],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env=environment,
        )
        for repo in (this, baseline)
    ]
    results = []
    for worker in workers:
        out, err = worker.communicate()
        if worker.returncode != 0:
            raise SystemExit(f"error: a worker failed:\n{err.strip().splitlines()[-1] if err.strip() else out}")
        calls, elapsed, rate = out.split()
        results.append((round(float(calls)), float(elapsed), float(rate)))
    return results


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", type=Path, required=True, help="another checkout of otgym (the reference)")
    parser.add_argument("--scene", choices=("transport", "standard"), default="transport")
    parser.add_argument("--envs", type=int, default=128)
    parser.add_argument("--seconds", type=float, default=60.0, help="timed window of each pair")
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--core", type=int, default=1, help="the CPU core both workers share")
    parser.add_argument(
        "--start-in-s",
        type=float,
        default=40.0,
        help="time given to both workers to import and compile before the window opens",
    )
    args = parser.parse_args()
    this = Path(__file__).resolve().parent.parent
    if not (args.baseline / "otgym" / "physics").is_dir():
        raise SystemExit(f"error: {args.baseline} is not an otgym checkout")
    print(
        f"{args.scene} scene, {args.envs} environments, one core ({args.core}) shared by both, XLA on one "
        f"thread, {args.seconds:g} s windows; load average {os.getloadavg()[0]:.2f} at start"
    )
    print(f"this: {this}\nbaseline: {args.baseline.resolve()}")
    for repeat in range(args.repeats):
        (calls_a, _, rate_a), (calls_b, _, rate_b) = run_pair(
            this, args.baseline, args.scene, args.envs, args.seconds, args.core, args.start_in_s
        )
        print(
            f"  pair {repeat + 1}: this {rate_a:.3g} env-substeps/s ({calls_a} calls), baseline {rate_b:.3g} "
            f"({calls_b} calls): ratio {rate_a / rate_b:.3f}"
        )
    print(f"load average {os.getloadavg()[0]:.2f} at the end")


if __name__ == "__main__":
    main()
