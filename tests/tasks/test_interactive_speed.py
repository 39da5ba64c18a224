"""Task ``interactive-speed`` (``otgym.tasks.transport.interactive_speed``): its
features and route follower are the real-time navigator's own arithmetic under
``jax.numpy``; a constant speed carries the cell as the real-time task with the
navigator ``rl`` does; the reward counts progress and time; an episode terminates past
the finish and is truncated at the time limit."""

import dataclasses

import gymnasium as gym
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from otgym.autonomy.rl_navigator import RLNavigator
from otgym.task.task import InteractiveTask
from otgym.tasks.transport import interactive_speed as its
from otgym.tasks.transport import speed_features as sf
from otgym.tasks.transport.route_follow import APPROACH, CARRY, RouteFollow
from tests.autonomy.test_rl_navigator import Fixed

ROUTE = np.stack([np.linspace(0.0, 300.0, 2401), 0.002 * np.linspace(0.0, 300.0, 2401) ** 2], axis=1)
ARC = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(ROUTE, axis=0), axis=1))])


def test_the_features_and_the_tracker_under_jax_are_numpys():
    """Fails if the jitted task saw other features than the navigator on the same input
    (float32 against float64, to the float32 resolution of the route)."""
    rng = np.random.default_rng(0)
    n_env, window, k = 5, 51, 4
    times = np.sort(rng.uniform(0, 1, (n_env, window)), axis=1)
    xy = rng.uniform(0, 200, (n_env, 1, k, 2)) + 2.0 * times[:, :, None, None] * rng.normal(size=(n_env, 1, k, 2))
    count = np.array([0, 1, 2, 30, 80])
    velocity = sf.tracked_velocity_um_s(times, xy, count)
    got = np.asarray(sf.tracked_velocity_um_s(*map(jnp.asarray, (times, xy, count)), jnp))
    # float32 resolves 200 um to 1.5e-5 um: over the closest two times (0.014 s) 2e-3 um/s
    assert np.allclose(got, velocity, atol=5e-3) and np.abs(velocity).max() > 1.0
    inputs = (
        ARC[rng.integers(0, 2400, n_env)],
        rng.uniform(0, 200, (n_env, k, 2)),
        velocity,
        rng.uniform(-5, 60, (n_env, k)),
        rng.random((n_env, k)) < 0.5,
        rng.uniform(0, 8, n_env),
        rng.uniform(0, 1, n_env),
        rng.random(n_env) < 0.5,
    )
    expected = sf.speed_features(ROUTE, ARC, sf.route_tangents(ROUTE), *inputs)
    route, arc = jnp.asarray(ROUTE, jnp.float32), jnp.asarray(ARC, jnp.float32)
    got = jax.jit(lambda *a: sf.speed_features(route, arc, sf.route_tangents(route, jnp), *a, xp=jnp))(*inputs)
    # float32 tangents of 0.125 um steps of a 300 um route: 3e-5 um over 0.125 um, 2.4e-4 of a unit
    assert got.shape == (n_env, sf.N_FEATURES) and np.allclose(got, expected, atol=1e-3)


@pytest.mark.parametrize("phase", [APPROACH, CARRY])
def test_the_route_follower_under_jax_is_numpys(phase):
    rng = np.random.default_rng(1)
    offsets = np.array([[-3.0, 4.0], [3.0, 4.0], [-3.0, -4.0], [3.0, -4.0]])
    cell_arc = np.array([10.0, 120.0, 250.0])
    cell = np.stack([np.interp(cell_arc, ARC, ROUTE[:, i]) for i in (0, 1)], axis=1) + rng.normal(0, 0.3, (3, 2))
    traps = cell[:, None] + offsets[None] + rng.normal(0, 0.5, (3, 4, 2))
    args = (cell_arc - 0.5, np.array([0.0, 5.0, 8.0]), np.full(3, phase), cell_arc, cell, traps)
    expected = RouteFollow(ROUTE, ARC, offsets, 0.02).increments(*args)
    follow = RouteFollow(*(jnp.asarray(a, jnp.float32) for a in (ROUTE, ARC, offsets)), 0.02)
    got = follow.increments(*(jnp.asarray(a) for a in args), xp=jnp)
    for mine, theirs in zip(got, expected):
        assert np.allclose(mine, theirs, atol=1e-4)


@pytest.fixture(scope="module")
def one_scenario():
    """The task on the first scenario of its pool, and the real-time task beside it."""
    config = dataclasses.replace(its.PRESETS["default"], n_scenarios=1)
    return config, its.make_params(config), InteractiveTask(config.interactive)


DECISIONS = 12


@pytest.mark.slow
def test_a_constant_speed_carries_the_cell_as_the_real_time_task_does(one_scenario):
    """The cell's arc after each of 12 decisions at 5 um/s and at 0 um/s, against the
    real-time task driven by navigator rl with the same fixed choice on the same
    scenario: agreement within 1 um (four times the spread between environments
    measured here, 0.25 um: the route's 0.125 um points and the Brownian noise).
    Rewards: 0.1 per um of progress minus 0.1 per decision, no collision this early."""
    config, params, task = one_scenario
    n_env, actions = 2, np.array([3, 0])  # 5 um/s, 0 um/s
    obs, state = its.reset_batch(jax.random.PRNGKey(0), params, n_env)
    assert obs.shape == (n_env, sf.N_FEATURES) and np.all(np.asarray(state.phase) == APPROACH)
    step = jax.jit(lambda key, state: its.step_batch(key, state, jnp.asarray(actions), params))
    arcs, rewards = [], []
    previous = np.asarray(params.route_arc_um[state.route_index])
    for i in range(DECISIONS):
        obs, state, reward, terminated, truncated, info = step(jax.random.PRNGKey(i), state)
        arcs.append(np.asarray(info["cell_arc_um"]))
        rewards.append(np.asarray(reward))
        assert not np.any(terminated) and not np.any(truncated)
        assert np.allclose(reward, 0.1 * (arcs[-1] - previous) - 0.1, atol=1e-4)
        previous = arcs[-1]
    assert np.all(np.asarray(state.phase) == CARRY)
    assert np.allclose(obs[:, 20], np.asarray(its.sf.SPEEDS_UM_S)[actions] / sf.SPEED_SCALE_UM_S)

    host = []
    for action in actions:
        navigator = RLNavigator.for_task(task, Fixed(int(action)))
        navigator.reset(1)
        task_state = task.reset([task.scenario(config.scenario_base)], jax.random.PRNGKey(5))
        observation, row, key = task_state.observation, [], jax.random.PRNGKey(7)
        for tick in range(DECISIONS * config.decision_ticks):
            key, tick_key = jax.random.split(key)
            observation = task.step(task_state, navigator.increments(observation), tick_key)
            if tick % config.decision_ticks == config.decision_ticks - 1:
                row.append(observation.cell_arc_um[0])
        host.append(row)
    assert np.allclose(np.array(arcs), np.array(host).T, atol=1.0), (np.array(arcs), np.array(host).T)
    assert arcs[-1][0] > 20.0 and arcs[-1][1] < 5.0  # 5 um/s over ~5.5 s of carrying; standing still


@pytest.mark.slow
def test_the_episode_ends_past_the_finish_and_a_batch_restarts_it(one_scenario):
    """With the finish at 3 % of the route, 8 um/s passes it within a few decisions:
    terminated there, success, and ``auto_reset`` brings that environment back to the
    route's start while the other keeps its state."""
    config, params, _ = one_scenario
    params = params.replace(config=dataclasses.replace(config, finish_fraction=0.03))
    task = its.InteractiveSpeed()
    obs, state = task.reset_batch(jax.random.PRNGKey(1), params, 2)
    step = jax.jit(lambda key, state: task.step_batch(key, state, jnp.array([5, 0]), params))
    for i in range(12):
        obs, state, reward, terminated, truncated, info = step(jax.random.PRNGKey(i), state)
        if terminated[0]:
            break
    assert bool(terminated[0]) and bool(info["success"][0]) and not bool(terminated[1])
    assert float(info["cell_arc_um"][0]) >= 0.03 * float(params.route_arc_um[-1])
    obs, state = task.auto_reset(jax.random.PRNGKey(9), params, obs, state, terminated | truncated)
    assert int(state.steps[0]) == 0 and int(state.steps[1]) == i + 1


@pytest.mark.slow
def test_the_time_limit_truncates_and_does_not_terminate(one_scenario):
    """At 0 um/s with a 2 s limit: four decisions, the fourth truncated, none terminated
    (the time limit is no failure and no success: DQN bootstraps through it)."""
    config, params, _ = one_scenario
    short = dataclasses.replace(config.interactive, time_limit_s=2.0)
    params = params.replace(config=dataclasses.replace(config, interactive=short))
    obs, state = its.reset_batch(jax.random.PRNGKey(2), params, 1)
    step = jax.jit(lambda key, state: its.step_batch(key, state, jnp.array([0]), params))
    ends = []
    for i in range(4):
        obs, state, reward, terminated, truncated, info = step(jax.random.PRNGKey(i), state)
        ends.append((bool(terminated[0]), bool(truncated[0]), bool(info["success"][0])))
    assert ends == [(False, False, False)] * 3 + [(False, True, False)]


def test_the_task_is_registered_with_its_spaces_and_its_dqn_settings():
    from otgym import tasks
    from otgym.rl.dqn import DQNConfig

    task = tasks.load("interactive-speed")
    assert task.policy_shape(task.config()) == (sf.N_FEATURES, len(sf.SPEEDS_UM_S))
    assert task.action_space(None) == gym.spaces.Discrete(len(sf.SPEEDS_UM_S))
    config = DQNConfig(**task.dqn_config(task.config("train")))
    assert config.explore_hold_max > 1 and config.hidden == (64, 64)
    assert task.device_action(np.array([3.0, 4.0]), None) == 3  # 5 um/s
    with pytest.raises(ValueError, match="no preset"):
        task.config("fast")
