"""Cost of the opt-in overlap projection (``PhysicsConfig(contact_overlap_cap=...)``).

Env-substeps per second of the transport scene on the default chip (walls and flow,
obstacles) with the penalty contact alone (the reference, the default) and with the
projection on (cap 2 % of a radius, at most its default 64 iterations), measured alternately
in the same run, each figure the best of ``--repeats`` timings, and their ratio.
Then what each buys: the gripper-cell overlap at the end of each control step (the
negative of ``SceneEvents.cell_gap_um``) over 10 control steps of 16 environments, with
every trap still and with every trap moving at 12 um/s along +x (the assembly carried).

Run: python benchmarks/contact_projection.py [--envs 1,64] [--seconds 3] [--repeats 2]
"""

from __future__ import annotations

import argparse

import jax
import jax.numpy as jnp
import numpy as np
from physics_throughput import control_steps_per_second  # benchmarks/ is on the path when run as a script

from otgym.sim import scene as sc

CAP = 0.02


def rate(scene, n_env: int, seconds: float) -> float:
    states = jax.vmap(sc.reset, in_axes=(None, 0))(scene, jax.random.split(jax.random.PRNGKey(0), n_env))
    velocity = jnp.zeros((n_env, scene.n_traps, 2))
    return (
        control_steps_per_second(jax.jit(sc.step_batch), scene, states, velocity, seconds)
        * scene.model.substeps
        * n_env
    )


def grip_overlaps_um(scene, speed_um_s: float, n_env: int = 16, n_steps: int = 10) -> np.ndarray:
    """Gripper-cell overlap (um, (n_steps, n_env, robots)) at the end of each control step."""
    states = jax.vmap(sc.reset, in_axes=(None, 0))(scene, jax.random.split(jax.random.PRNGKey(0), n_env))
    velocity = jnp.zeros((n_env, scene.n_traps, 2)).at[..., 0].set(speed_um_s)
    step, overlaps = jax.jit(sc.step_batch), []
    for index in range(n_steps):
        states, events = step(scene, states, velocity, jax.random.PRNGKey(index))
        overlaps.append(-np.asarray(events.cell_gap_um))
    return np.array(overlaps)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--envs", default="1,64", help="environment counts, comma-separated")
    parser.add_argument("--seconds", type=float, default=3.0, help="seconds per timing")
    parser.add_argument("--repeats", type=int, default=2, help="alternating timings per variant")
    args = parser.parse_args()
    try:
        env_counts = [int(n) for n in args.envs.split(",")]
    except ValueError:
        parser.error(f"--envs must be positive integers separated by commas, got {args.envs!r}")
    if min(env_counts) < 1 or args.seconds <= 0 or args.repeats < 1:
        parser.error("--envs counts and --repeats must be at least 1 and --seconds positive")
    scenes = {
        "penalty (reference)": sc.build_scene(sc.SceneConfig()),
        f"projection, cap {CAP:g}": sc.build_scene(sc.SceneConfig(contact_overlap_cap=CAP)),
    }
    print("transport scene, default chip: env-substeps/s, best of", args.repeats)
    for n_env in env_counts:
        best = {name: 0.0 for name in scenes}
        for _ in range(args.repeats):
            for name, scene in scenes.items():
                best[name] = max(best[name], rate(scene, n_env, args.seconds))
        reference, projected = best.values()
        print(
            f"  {n_env:5d} envs: "
            + ", ".join(f"{name} {value:.3g}" for name, value in best.items())
            + f"; projection / penalty = {projected / reference:.2f}"
        )
    smallest_radius = float(np.min(np.asarray(next(iter(scenes.values())).model.sphere_radius_um)))
    print(
        f"gripper-cell overlap at the control steps' ends (10 steps x 16 envs x 2 robots; smallest radius "
        f"{smallest_radius:g} um): median / max, as a fraction of that radius"
    )
    for speed in (0.0, 12.0):
        print(
            f"  traps at {speed:g} um/s: "
            + ", ".join(
                f"{name} {np.median(o) / smallest_radius:.1%} / {o.max() / smallest_radius:.1%}"
                for name, o in ((name, grip_overlaps_um(scene, speed)) for name, scene in scenes.items())
            )
        )


if __name__ == "__main__":
    main()
