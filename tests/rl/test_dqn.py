"""Pure-JAX DQN: the whole loop jits and vmaps over seeds (on the corridor MDP of
``test_dqn_known_mdp``, a program that compiles in seconds; the real task's training
chunk is compiled once for the suite by ``tests.rl.canonical``'s users); the epsilon
schedule; policy files round-trip and reject wrong or missing files."""

import dataclasses

import jax
import numpy as np
import pytest

from otgym.rl.dqn import DQNConfig, epsilon, make_train
from otgym.rl.network import QNetwork
from otgym.rl.policy import load_policy, save_policy
from otgym.tasks.transport import core as tr
from tests.rl.test_dqn_known_mdp import corridor_env

TINY = DQNConfig(
    n_envs=8, total_env_steps=160, chunk_iters=10, buffer_size=64, batch_size=16, learning_starts=32, target_every=5
)


@pytest.fixture(scope="module")
def trained():
    _, _, train = make_train(TINY, corridor_env())
    runner, metrics = jax.jit(jax.vmap(train))(jax.random.split(jax.random.PRNGKey(0), 2))
    return runner, metrics


@pytest.mark.slow
def test_training_runs_in_jit_over_two_seeds(trained):
    runner, metrics = trained
    assert metrics["loss"].shape == (2, TINY.n_chunks * TINY.chunk_iters)
    assert np.all(np.isfinite(np.asarray(metrics["loss"])))
    # learning starts once the buffer holds 32 transitions (4 iterations of 8 envs)
    assert np.all(np.asarray(metrics["loss"])[:, :3] == 0) and np.all(np.asarray(metrics["loss"])[:, 5:] > 0)
    assert int(runner.buffer.size[0]) == 64 and int(runner.iteration[0]) == 20
    kernel = runner.q_params["params"]["Dense_0"]["kernel"]
    assert not np.allclose(np.asarray(kernel[0]), np.asarray(kernel[1])), "seeds differ"


def test_epsilon_decays_linearly_to_its_end():
    config = dataclasses.replace(TINY, eps_fraction=0.5)
    assert float(epsilon(config, 0)) == pytest.approx(1.0)
    assert float(epsilon(config, 5)) == pytest.approx(0.505)
    assert float(epsilon(config, 19)) == pytest.approx(0.01)


def test_policy_file_round_trip_and_errors(tmp_path):
    q_params = QNetwork(6, (128, 128)).init(jax.random.PRNGKey(3), np.zeros((1, tr.OBS_SIZE), np.float32))
    path = save_policy(tmp_path / "policy.npz", q_params, {"preset": "paper", "hidden": [128, 128]})
    loaded, meta = load_policy(path, tr.OBS_SIZE, 6)
    assert meta["preset"] == "paper"
    np.testing.assert_array_equal(
        np.asarray(loaded["params"]["Dense_2"]["bias"]), np.asarray(q_params["params"]["Dense_2"]["bias"])
    )
    with pytest.raises(ValueError, match="does not fit"):
        load_policy(path, tr.OBS_SIZE, 10)
    with pytest.raises(FileNotFoundError, match="does not exist"):
        load_policy(tmp_path / "missing.npz", tr.OBS_SIZE, 6)
    (tmp_path / "junk.npz").write_bytes(b"not a policy")
    with pytest.raises(ValueError, match="not an otgym policy"):
        load_policy(tmp_path / "junk.npz", tr.OBS_SIZE, 6)
