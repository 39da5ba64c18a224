"""The DQN finds the optimal policy of a small MDP whose optimal Q-values are known
from value iteration (issue 10, item 5): a test that fails for a learner that does not
learn (an untrained network, a wrong target, a sign flipped in the update).

The MDP is a miniature of the speed-control task: a corridor of 8 cells, the last the
goal (+10); each step costs 1; action 0 advances one cell, action 1 two cells for an
extra 0.5 (the faster speed), action 2 stays (never optimal). In the two hazard cells
3 and 4 (the narrow passage of the real task) the fast action fails with probability
1/2 (-10, episode over). Optimal: fast where it is safe, slow in the hazard, and the
margin is real (Q gaps 0.5-1.1) everywhere but cell 1, where the two are within 0.005
(excluded, as no finite sample could resolve it)."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from otgym.rl.dqn import DQNConfig, Env
from otgym.rl.network import QNetwork
from tests.rl.conftest import CORRIDOR_GROUP

CELLS, GOAL, HAZARD = 8, 7, (3, 4)
ADVANCE = (1, 2, 0)  # cells advanced by action 0 (slow), 1 (fast), 2 (stay)
FAST_COST, FAIL_PROBABILITY, GOAL_REWARD, FAIL_REWARD, TIME_LIMIT = 0.5, 0.5, 10.0, -10.0, 30
GAMMA = 0.99
CLEAR_GAP = 0.1
"""States whose best and second-best optimal Q differ by less than this are excluded."""

CONFIG = DQNConfig(
    n_envs=32,
    total_env_steps=38_400,
    chunk_iters=100,
    buffer_size=4096,
    batch_size=64,
    learning_rate=1e-3,
    gamma=GAMMA,
    eps_fraction=0.5,
    target_every=25,
    learning_starts=512,
    updates_per_iter=1,
    hidden=(32, 32),
)
SEEDS = 5


def _outcomes(cell: int, action: int):
    """(probability, reward, next cell, terminated) of one step."""
    reached = min(cell + ADVANCE[action], GOAL)
    reward = -1.0 - (FAST_COST if action == 1 else 0.0) + (GOAL_REWARD if reached == GOAL else 0.0)
    if action == 1 and cell in HAZARD:
        return [
            (FAIL_PROBABILITY, -1.0 - FAST_COST + FAIL_REWARD, cell, True),
            (1 - FAIL_PROBABILITY, reward, reached, reached == GOAL),
        ]
    return [(1.0, reward, reached, reached == GOAL)]


def optimal_q() -> np.ndarray:
    """Q* (cells 0..6, 3 actions) by value iteration (Bellman 1957), discounted as the DQN."""
    value = np.zeros(CELLS)
    for _ in range(3000):
        q = np.array(
            [
                [
                    sum(p * (r + (0.0 if done else GAMMA * value[n])) for p, r, n, done in _outcomes(s, a))
                    for a in range(3)
                ]
                for s in range(GOAL)
            ]
        )
        value[:GOAL] = q.max(axis=1)
    return q


def corridor_env() -> Env:
    """The MDP as a batched functional environment (one-hot cell observation), starting
    in a uniformly random non-goal cell so that every cell is visited."""
    advance, hazard = jnp.asarray(ADVANCE), jnp.isin(jnp.arange(CELLS), jnp.asarray(HAZARD))

    def observe(cell):
        return jax.nn.one_hot(cell, CELLS)

    def reset(key, n):
        cell = jax.random.randint(key, (n,), 0, GOAL)
        return observe(cell), (cell, jnp.zeros(n, jnp.int32))

    def step(key, state, action):
        cell, t = state
        failed = (action == 1) & hazard[cell] & (jax.random.uniform(key, cell.shape) < FAIL_PROBABILITY)
        reached = jnp.minimum(cell + advance[action], GOAL)
        at_goal = (reached == GOAL) & ~failed
        reward = -1.0 - FAST_COST * (action == 1) + GOAL_REWARD * at_goal + FAIL_REWARD * failed
        cell = jnp.where(failed, cell, reached)
        terminated = failed | at_goal
        truncated = (t + 1 >= TIME_LIMIT) & ~terminated
        return observe(cell), (cell, t + 1), reward, terminated, truncated, {"success": at_goal}

    def auto_reset(key, obs, state, done):
        fresh_obs, fresh = reset(key, obs.shape[0])
        keep = lambda new, old: jnp.where(done.reshape(done.shape + (1,) * (old.ndim - 1)), new, old)  # noqa: E731
        return keep(fresh_obs, obs), jax.tree.map(keep, fresh, state)

    return Env(reset, step, auto_reset, CELLS, 3)


def test_value_iteration_gives_a_mixed_optimal_policy():
    """The reference itself: fast where safe, slow in (and just before entering) the hazard."""
    q = optimal_q()
    ordered = np.sort(q, axis=1)
    clear = ordered[:, -1] - ordered[:, -2] >= CLEAR_GAP
    assert list(np.flatnonzero(~clear)) == [1]
    assert list(q.argmax(axis=1)[clear]) == [1, 1, 0, 0, 1, 0]  # cells 0, 2, 3, 4, 5, 6


@pytest.mark.slow
@pytest.mark.xdist_group(CORRIDOR_GROUP)  # one worker trains (conftest.py's corridor_training)
def test_dqn_finds_the_optimal_policy_and_values(corridor_training):
    """Five training seeds (vmapped, one compile). The issue's bar for training
    reliability is 4 of 5 seeds; each passing seed must choose the optimal action in
    every clearly decided cell, and its greedy value at each cell must lie within 0.25 of
    V* (half the smallest clear Q-gap, 0.5; measured errors of these seeds: <= 0.05,
    while half the budget left cell 0, the farthest from the goal, wrong in 3 of 5). The same
    checks on the untrained networks must fail: they choose like chance, (1/3)^6 for
    all six cells."""
    q_star = optimal_q()
    ordered = np.sort(q_star, axis=1)
    clear = ordered[:, -1] - ordered[:, -2] >= CLEAR_GAP
    runner, _, untrained = corridor_training
    cells = jax.nn.one_hot(jnp.arange(GOAL), CELLS)

    network = QNetwork(3, CONFIG.hidden)

    def passes(q_params) -> list[bool]:
        q = np.asarray(jax.vmap(lambda p: network.apply(p, cells))(q_params))
        actions, values = q.argmax(axis=-1), q.max(axis=-1)
        return [
            bool(
                np.array_equal(a[clear], q_star.argmax(axis=1)[clear]) and np.all(np.abs(v - q_star.max(axis=1)) < 0.25)
            )
            for a, v in zip(actions, values)
        ]

    trained = passes(runner.q_params)
    assert sum(trained) >= 4, f"seeds finding the optimum: {trained}"
    assert not any(passes(untrained.q_params))
