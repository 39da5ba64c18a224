"""Physics throughput: environment-substeps per second of the standard scene.

Standard scene (issue 2): two two-handle robots (4 traps), one cell, four obstacles
(dynamic, as in the transport scene), in free fluid. A second table times the full
transport scene of ``otgym.sim.scene`` on the default chip (walls and flow sampled from
grids, obstacle propulsion and events), which is what environments step.
Reference, measured in the same run: the same dynamics written as a plain NumPy loop
(``numpy_substep`` below: Euler-Maruyama over the same model arrays, vectorised over
spheres and environments). Before timing, both run 50 steps from the same state at
T = 0 and must agree to float32 precision, so the reference is the same physics.

XLA's own count of the compiled work (flops, transcendentals, bytes per environment of
a one-substep control step of the standard scene at 64 environments) is printed too:
unlike a timing it does not depend on what else the machine runs, so two commits can be
compared on a busy machine (run the script at each). (XLA counts a loop's body once,
so the count of a many-substep step says little; figures printed before 2026-11-26 as
"per env-substep" were mostly the up-front noise draw.)

The transport scene's scratch memory per environment (XLA's memory analysis of the
compiled batched step, ``--memory-sizes``) is printed last: it sets how many
environments fit on one GPU.

Run: python benchmarks/physics_throughput.py [--quick]
Targets: >= 1e5 substeps/s for one environment, >= 1e6 env-substeps/s batched (CPU),
>= 1e8 on one H100.
"""

from __future__ import annotations

import argparse
import time

import jax
import jax.numpy as jnp
import numpy as np

from otgym import physics as ph

SUBSTEPS = 100


def standard_model(temperature_k=298.15):
    bodies = [ph.two_handle_robot("robot_a"), ph.two_handle_robot("robot_b"), ph.cell("cell")]
    bodies += [ph.obstacle(f"obstacle_{i}", kinematic=False) for i in range(4)]
    config = ph.PhysicsConfig(dt_s=1e-4, substeps=SUBSTEPS, temperature_k=temperature_k)
    pose = np.array([[0, -6.0, 0], [0, 6.0, np.pi], [0, 0, 0], [25, 0, 0], [-25, 0, 0], [0, 25, 0], [0, -25, 0]], float)
    return ph.build_model(bodies, config), pose


def numpy_substep(m, pose, trap_xy, noise):
    """One Euler-Maruyama step of E environments in NumPy. pose (E, B, 3), trap_xy (E, T, 2)."""
    body = np.asarray(m.sphere_body)
    offset, radius = m["offset"], m["radius"]
    cos, sin = np.cos(pose[:, body, 2]), np.sin(pose[:, body, 2])
    lever = np.stack([cos * offset[:, 0] - sin * offset[:, 1], sin * offset[:, 0] + cos * offset[:, 1]], -1)
    xy = pose[:, body, :2] + lever
    force = np.zeros_like(xy)
    traps = np.asarray(m.trap_sphere)
    to_trap = trap_xy - xy[:, traps]
    distance = np.linalg.norm(to_trap, axis=-1, keepdims=True)
    law = m.trap_law
    force[:, traps] += law.stiffness_pn_per_um * to_trap * np.exp(-2 * distance**2 / law.waist_um**2)
    a, b = np.asarray(m.pair_a), np.asarray(m.pair_b)
    delta = xy[:, b] - xy[:, a]
    dist = np.linalg.norm(delta, axis=-1)
    normal = delta / np.maximum(dist, 1e-9)[..., None]
    gap = dist - radius[a] - radius[b]
    contact = m["stiffness"] * np.maximum(-gap, 0)
    reduced = radius[a] * radius[b] / (radius[a] + radius[b])
    ratio = np.maximum(gap, m["min_gap"]) / m["wavelength"]  # Gregory's retarded van der Waals
    vdw = m["hamaker"] * reduced * (1 + 28 * ratio) / (6 * np.maximum(gap, m["min_gap"]) ** 2 * (1 + 14 * ratio) ** 2)
    on_a = (vdw - contact)[..., None] * normal
    np.add.at(force, (slice(None), a), on_a)
    np.add.at(force, (slice(None), b), -on_a)
    torque = lever[..., 0] * force[..., 1] - lever[..., 1] * force[..., 0]
    generalised = np.zeros_like(pose)
    for index in range(pose.shape[1]):
        mask = body == index
        generalised[:, index, :2] = force[:, mask].sum(axis=1)
        generalised[:, index, 2] = torque[:, mask].sum(axis=1)
    noise = np.broadcast_to(noise, pose.shape)
    cos, sin = np.cos(pose[..., 2]), np.sin(pose[..., 2])  # body frame: anisotropic mobility, Cholesky noise
    body_x = cos * generalised[..., 0] + sin * generalised[..., 1]
    body_y = -sin * generalised[..., 0] + cos * generalised[..., 1]
    mob, chol = m["mobility"], m["noise"]
    step_x = (mob[:, 0, 0] * body_x + mob[:, 0, 1] * body_y) * m["dt"] + chol[:, 0, 0] * noise[..., 0]
    step_y = (
        (mob[:, 1, 0] * body_x + mob[:, 1, 1] * body_y) * m["dt"]
        + chol[:, 1, 0] * noise[..., 0]
        + chol[:, 1, 1] * noise[..., 1]
    )
    new = pose.copy()
    new[..., 0] += cos * step_x - sin * step_y
    new[..., 1] += sin * step_x + cos * step_y
    new[..., 2] += m["rotational_mobility"] * generalised[..., 2] * m["dt"] + m["rotational_noise"] * noise[..., 2]
    return new


def numpy_arrays(model):
    get = lambda a: np.asarray(a, np.float64)  # noqa: E731
    return {
        "offset": get(model.sphere_offset_um),
        "radius": get(model.sphere_radius_um),
        "stiffness": get(model.pair_stiffness_pn_per_um),
        "hamaker": get(model.pair_hamaker_pn_um),
        "min_gap": float(model.min_gap_um),
        "wavelength": float(model.retardation_wavelength_um),
        "mobility": get(model.body_translational_mobility),
        "noise": get(model.body_translational_noise_um),
        "rotational_mobility": get(model.body_rotational_mobility),
        "rotational_noise": get(model.body_rotational_noise_rad),
        "dt": float(model.dt_s),
    }


class NumpyModel(dict):
    def __init__(self, model):
        super().__init__(numpy_arrays(model))
        self.sphere_body, self.trap_sphere = model.sphere_body, model.trap_sphere
        self.pair_a, self.pair_b, self.trap_law = model.pair_a, model.pair_b, model.trap_law


def check_same_dynamics():
    model, pose = standard_model(temperature_k=0.0)
    state = ph.initial_state(model, pose)
    reference = NumpyModel(model)
    numpy_pose = np.asarray(state.pose, np.float64)[None]
    numpy_traps = np.asarray(state.trap_xy_um, np.float64)[None]
    for _ in range(SUBSTEPS // 2):
        numpy_pose = numpy_substep(reference, numpy_pose, numpy_traps, 0.0)
    half = model.replace(substeps=SUBSTEPS // 2)
    jax_state, _ = jax.jit(ph.control_step)(half, state, ph.Controls.zeros(half), jax.random.PRNGKey(0))
    difference = np.abs(np.asarray(jax_state.pose) - numpy_pose[0]).max()
    moved = np.abs(numpy_pose[0] - np.asarray(state.pose)).max()
    print(
        f"same dynamics check: JAX vs NumPy after {SUBSTEPS // 2} steps at T=0: "
        f"max |difference| {difference:.2e} (bodies moved up to {moved:.2e})"
    )
    assert difference < 1e-4, "the NumPy reference and the JAX core disagree"


def control_steps_per_second(step, first, state, second, min_seconds):
    """Calls per second of ``step(first, state, second, key) -> (state, _)`` after one
    compiling call, each call waited for. The key's split runs once before the window
    too: its first call compiles it, which would count in the window (a large part of a
    one-second window at one environment on a loaded machine)."""
    key = jax.random.PRNGKey(1)
    key, step_key = jax.random.split(key)
    jax.block_until_ready(step(first, state, second, step_key))
    calls, start = 0, time.perf_counter()
    while time.perf_counter() - start < min_seconds:
        key, step_key = jax.random.split(key)
        state, _ = step(first, state, second, step_key)
        jax.block_until_ready(state)
        calls += 1
    return calls / (time.perf_counter() - start)


def time_jax(model, pose, n_env, min_seconds):
    state = jax.tree.map(lambda a: jnp.broadcast_to(a, (n_env,) + a.shape), ph.initial_state(model, pose))
    rate = control_steps_per_second(
        jax.jit(ph.control_step_batch), model, state, ph.Controls.zeros(model, n_env), min_seconds
    )
    return rate * SUBSTEPS * n_env


def time_numpy(model, pose, n_env, min_seconds):
    reference = NumpyModel(model)
    state = ph.initial_state(model, pose)
    numpy_pose = np.repeat(np.asarray(state.pose, np.float64)[None], n_env, 0)
    numpy_traps = np.repeat(np.asarray(state.trap_xy_um, np.float64)[None], n_env, 0)
    rng = np.random.default_rng(0)
    steps, start = 0, time.perf_counter()
    while time.perf_counter() - start < min_seconds:
        numpy_pose = numpy_substep(reference, numpy_pose, numpy_traps, rng.standard_normal(numpy_pose.shape))
        steps += 1
    return steps * n_env / (time.perf_counter() - start)


def compiled_cost_per_env_substep(model, pose, n_env=64):
    """XLA's cost analysis of a batched control step of ONE substep, divided by
    environments: the work of a substep plus a step's setup. XLA counts a loop's body
    once, whatever its trip count, so a many-substep step's count is not its work (with
    the noise drawn up front the count grew with the substeps only through the draw)."""
    state = jax.tree.map(lambda a: jnp.broadcast_to(a, (n_env,) + a.shape), ph.initial_state(model, pose))
    one = model.replace(substeps=1)
    compiled = (
        jax.jit(ph.control_step_batch).lower(one, state, ph.Controls.zeros(one, n_env), jax.random.PRNGKey(0)).compile()
    )
    cost = compiled.cost_analysis()
    cost = cost[0] if isinstance(cost, (list, tuple)) else cost
    return {name: cost.get(name, float("nan")) / n_env for name in ("flops", "transcendentals", "bytes accessed")}


def time_scene(n_env, min_seconds):
    from otgym.sim import scene as sc

    scene = sc.build_scene(sc.SceneConfig(kind="transport"))
    states = jax.vmap(sc.reset, in_axes=(None, 0))(scene, jax.random.split(jax.random.PRNGKey(0), n_env))
    velocity = jnp.zeros((n_env, scene.n_traps, 2))
    rate = control_steps_per_second(jax.jit(sc.step_batch), scene, states, velocity, min_seconds)
    return rate * scene.model.substeps * n_env


def scene_scratch_per_env_bytes(n_env):
    """XLA's memory analysis of one compiled batched transport-scene step: scratch
    (temporary) bytes divided by environments (the issue's limit: 0.25 MB)."""
    from otgym.sim import scene as sc

    scene = sc.build_scene(sc.SceneConfig(kind="transport"))
    states = jax.vmap(sc.reset, in_axes=(None, 0))(scene, jax.random.split(jax.random.PRNGKey(0), n_env))
    velocity = jnp.zeros((n_env, scene.n_traps, 2))
    compiled = jax.jit(sc.step_batch).lower(scene, states, velocity, jax.random.PRNGKey(1)).compile()
    return compiled.memory_analysis().temp_size_in_bytes / n_env


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="shorter timings")
    parser.add_argument("--sizes", default="1,64,1024,4096")
    parser.add_argument("--scene-sizes", default="1,64,1024")
    parser.add_argument("--memory-sizes", default="1024", help="batch sizes of the scratch-per-environment figure")
    args = parser.parse_args()
    seconds = 1.0 if args.quick else 3.0
    print(f"device: {jax.devices()[0].device_kind} ({jax.default_backend()}), {jax.device_count()} device(s)")
    check_same_dynamics()
    model, pose = standard_model()
    print(
        f"standard scene: {model.n_bodies} bodies, {len(model.sphere_body)} spheres, "
        f"{len(model.pair_a)} sphere pairs, {model.n_traps} traps, dt = {float(model.dt_s):g} s"
    )
    cost = compiled_cost_per_env_substep(model, pose)
    print(
        "compiled work of a one-substep control step per env (XLA cost analysis, 64 envs): "
        + ", ".join(f"{value:,.0f} {name}" for name, value in cost.items())
    )
    print(f"{'envs':>6} {'otgym JAX env-substeps/s':>26} {'NumPy loop env-substeps/s':>27} {'ratio':>8}")
    for n_env in [int(s) for s in args.sizes.split(",")]:
        jax_rate = time_jax(model, pose, n_env, seconds)
        numpy_rate = time_numpy(model, pose, n_env, seconds)
        print(f"{n_env:>6} {jax_rate:>26.3e} {numpy_rate:>27.3e} {jax_rate / numpy_rate:>7.1f}x")
    print("transport scene on the default chip (walls + grid flow + obstacles), 2000 substeps per control step")
    print(f"{'envs':>6} {'env-substeps/s':>16} {'control steps/s (5 Hz, 0.2 s each)':>36}")
    for n_env in [int(s) for s in args.scene_sizes.split(",")]:
        rate = time_scene(n_env, seconds)
        print(f"{n_env:>6} {rate:>16.3e} {rate / 2000:>36.1f}")
    for n_env in [int(s) for s in args.memory_sizes.split(",") if s]:
        scratch = scene_scratch_per_env_bytes(n_env)
        print(
            f"transport scene scratch per environment at {n_env} envs (XLA memory analysis of the compiled step): "
            f"{scratch / 1e6:.3f} MB (limit 0.25 MB)"
        )


if __name__ == "__main__":
    main()
