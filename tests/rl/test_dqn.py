"""Pure-JAX DQN: the whole loop jits and vmaps over seeds (the corridor MDP's training of
``test_dqn_known_mdp``, five seeds in one program, shared with that test through
``conftest.py``'s ``corridor_training``; the real task's training chunk is compiled
once for the suite by ``tests.rl.canonical``'s users); the epsilon schedule; policy
files round-trip and reject wrong or missing files."""

import dataclasses

import jax
import numpy as np
import pytest

from otgym.rl.dqn import DQNConfig, epsilon
from otgym.rl.network import QNetwork
from otgym.rl.policy import load_policy, save_policy
from otgym.tasks.transport import core as tr
from tests.rl.conftest import CORRIDOR_GROUP
from tests.rl.test_dqn_known_mdp import CONFIG, SEEDS

TINY = DQNConfig(
    n_envs=8, total_env_steps=160, chunk_iters=10, buffer_size=64, batch_size=16, learning_starts=32, target_every=5
)
"""The epsilon schedule's configuration: 20 iterations."""


@pytest.mark.slow
@pytest.mark.xdist_group(CORRIDOR_GROUP)  # one worker trains (conftest.py's corridor_training)
def test_training_runs_in_jit_over_the_seeds(corridor_training):
    """The corridor training of five seeds in one jitted, vmapped program: a loss per
    iteration, zero until the replay buffer holds ``learning_starts`` = 512 transitions
    (16 iterations of 32 environments), positive after; the buffer full at its 4096
    (38,400 transitions were offered); 1200 iterations run; the seeds' networks differ."""
    runner, metrics, _ = corridor_training
    iterations = CONFIG.n_chunks * CONFIG.chunk_iters
    starts = CONFIG.learning_starts // CONFIG.n_envs
    loss = np.asarray(metrics["loss"])
    assert iterations == 1200 and starts == 16 and loss.shape == (SEEDS, iterations)
    assert np.all(np.isfinite(loss))
    assert np.all(loss[:, : starts - 1] == 0) and np.all(loss[:, starts + 1 :] > 0)
    assert np.all(np.asarray(runner.buffer.size) == CONFIG.buffer_size)
    assert np.all(np.asarray(runner.iteration) == iterations)
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
