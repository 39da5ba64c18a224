"""The corridor MDP's DQN training, shared by the modules that check it."""

import jax
import pytest

CORRIDOR_GROUP = "corridor_dqn"
"""The xdist group of every test that uses ``corridor_training``: one worker trains."""


@pytest.fixture(scope="session")
def corridor_training():
    """``test_dqn_known_mdp``'s training (its ``CONFIG``: 32 environments, 38,400 steps)
    of its ``SEEDS`` seeds from ``PRNGKey(0)``, the whole loop jitted and vmapped over
    the seeds in one program: (trained runner, metrics, untrained runner), each with the
    seed axis first. Built once for the tests that check it, which share an xdist group
    (``CORRIDOR_GROUP``)."""
    from otgym.rl.dqn import make_train
    from tests.rl.test_dqn_known_mdp import CONFIG, SEEDS, corridor_env

    init, _, train = make_train(CONFIG, corridor_env())
    keys = jax.random.split(jax.random.PRNGKey(0), SEEDS)
    runner, metrics = jax.jit(jax.vmap(train))(keys)
    return runner, metrics, jax.vmap(init)(keys)
