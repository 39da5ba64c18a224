"""Run by ``test_sharding.py`` in a fresh process started with two host devices (the
device count is fixed when JAX starts): ``python -m tests.experiments.sharded_rollouts
OUT_DIR PART...`` with parts ``physics`` (a batched physics rollout of four
environments), ``training`` (the first chunk of the canonical test training of
``tests.rl.canonical``: 100 iterations of 64 environments, the Q-network updated from
the 79th on) and ``evaluation`` (an evaluation rollout of four episodes; the training's
chunk holds its parts, the Q-network's forward pass over split environments and their
episode ends, so ``test_sharding`` runs physics and training only).

That process runs each part split over both devices and saves ``devices2.npz`` in
OUT_DIR, with ``devices_<part>``, the number of devices each result is split over. The
one-device results it is compared with come from ``run_parts`` in the test's own
process, a one-device process (``otgym.physics.sharding.environment_mesh`` answers None
there, so no array is constrained): its programs are those every other one-device
process runs, the canonical training chunk included, so JAX's persistent cache serves
them to and from the rest of the suite. (A process started with two host devices keys
its compiled programs apart from a one-device process's, so it could not share them.)"""

import sys
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np


def devices_of(array) -> int:
    return len(array.sharding.device_set)


def physics_rollout():
    from otgym import physics as ph
    from tests.physics.helpers import batch_state, run_batch

    config = ph.PhysicsConfig(dt_s=1e-4, substeps=20, field_refresh_substeps=5)
    model = ph.build_model([ph.two_handle_robot("a"), ph.two_handle_robot("b"), ph.cell("c")], config)
    state = batch_state(model, np.array([[0.0, -6.0, 0.0], [0.0, 6.0, 3.0], [0.0, 0.0, 0.0]]), 4)
    controls = ph.Controls.zeros(model, 4).replace(trap_velocity_um_s=jnp.full((4, model.n_traps, 2), 3.0))
    final, (states, reports) = run_batch(model, state, controls, jax.random.PRNGKey(5), 4)
    return {"physics_pose": final.pose, "physics_trap_distance": reports.trap_distance_max_um}, devices_of(final.pose)


def training():
    from otgym.experiments.speed_control.train import make_env
    from otgym.rl.dqn import make_train
    from otgym.tasks.transport import speed_control as spc
    from otgym.tasks.transport.presets import preset
    from tests.rl.canonical import TRAIN_CONFIG as config

    init, run_chunk, _ = make_train(config, make_env(spc.make_params(preset("paper"))))
    runner = jax.jit(init)(jax.random.PRNGKey(0))
    run_chunk = jax.jit(run_chunk)
    runner, chunk = run_chunk(runner)  # the first chunk: the updates from iteration 79 on are compared
    metrics = [chunk]
    leaves = jax.tree_util.tree_leaves_with_path(runner.q_params)
    out = {f"train_q{jax.tree_util.keystr(path)}": leaf for path, leaf in leaves}
    out["train_obs"] = runner.obs
    out["train_return_sum"] = jnp.concatenate([m["return_sum"] for m in metrics])
    out["train_loss"] = jnp.concatenate([m["loss"] for m in metrics])
    return out, devices_of(runner.obs)


def evaluation():
    from otgym.experiments.speed_control.evaluate import make_rollout
    from otgym.rl.network import QNetwork
    from otgym.tasks.transport import speed_control as spc
    from otgym.tasks.transport.core import OBS_SIZE

    params = spc.make_params("paper")
    hidden = (16,)
    q_params = QNetwork(params.config.n_actions, hidden).init(jax.random.PRNGKey(1), jnp.zeros((1, OBS_SIZE)))
    rollout = make_rollout(params, hidden, 2, policies=(0, 3))
    (progress, success, time_s), (active, force, distance) = rollout(q_params, jax.random.PRNGKey(2))
    out = {"eval_progress": progress, "eval_time_s": time_s, "eval_force": force, "eval_distance": distance}
    return out, devices_of(force)


PARTS = {"physics": physics_rollout, "training": training, "evaluation": evaluation}


def run_parts(names: list[str]) -> dict:
    results, split = {}, {}
    for name in names:
        arrays, split[name] = PARTS[name]()
        results.update({key: np.asarray(value) for key, value in arrays.items()})
    return results | {f"devices_{name}": split[name] for name in names}


if __name__ == "__main__":
    out, parts = Path(sys.argv[1]), sys.argv[2:]
    assert len(jax.local_devices()) == 2, "start with XLA_FLAGS=--xla_force_host_platform_device_count=2"
    np.savez(out / "devices2.npz", **run_parts(parts))
