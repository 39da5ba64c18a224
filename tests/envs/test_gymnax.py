"""otgym's tasks as gymnax environments (``otgym.envs.gymnax_env``): the same
transitions as the functional task, gymnax's reset of a finished episode, its spaces,
clear errors; and an existing JAX RL library (rejax's DQN) training on one."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from otgym.tasks.transport import core as tr
from otgym.tasks.transport import speed_control as spc

gymnax_env = pytest.importorskip("otgym.envs.gymnax_env", reason="needs the [jax-rl] extra (gymnax<1, rejax)")

TRAIN_STEPS = 2048
TRAIN_ENVS = 8


@pytest.fixture(scope="module")
def env(paper_params):
    return gymnax_env.TaskEnvironment("speed-control", "paper", task_params=paper_params)


@pytest.mark.slow
def test_a_step_is_the_functional_tasks_step_and_a_finished_episode_starts_again(env, paper_params):
    params = env.default_params
    assert params.task is paper_params and params.max_steps_in_episode == paper_params.config.max_steps
    key = jax.random.PRNGKey(3)
    obs, state = env.reset(key, params)
    reset = jax.jit(spc.reset)
    own_obs, own_state = reset(key, paper_params)
    np.testing.assert_allclose(np.asarray(obs), np.asarray(own_obs), rtol=1e-5, atol=1e-6)
    step_key = jax.random.PRNGKey(4)
    obs1, state1, reward, done, info = env.step(step_key, state, 2, params)
    inner_key, reset_key = jax.random.split(step_key)
    own = jax.jit(spc.step)(inner_key, own_state, 2, paper_params)
    assert not bool(done) and not bool(info["terminated"]) and not bool(info["truncated"])
    # one program (step, reset and gymnax's select) against the step alone: XLA fuses
    # them differently, so float32 round-off (about 1e-7 of values of order 1) may differ
    np.testing.assert_allclose(np.asarray(obs1), np.asarray(own[0]), rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(float(reward), float(own[2]), rtol=1e-5, atol=1e-6)
    # the episode's last step: the state comes back as a fresh reset with gymnax's reset key
    last = state1.replace(steps=jnp.asarray(paper_params.config.max_steps - 1, state1.steps.dtype))
    obs2, state2, _, done2, info2 = env.step(step_key, last, 0, params)
    fresh_obs, fresh_state = reset(reset_key, paper_params)
    assert bool(done2) and bool(info2["truncated"])
    np.testing.assert_allclose(np.asarray(obs2), np.asarray(fresh_obs), rtol=1e-5, atol=1e-6)
    assert int(state2.steps) == int(fresh_state.steps) == 0


def test_spaces_and_errors(env):
    assert env.action_space(env.default_params).n == env.num_actions == 6
    assert env.observation_space(env.default_params).shape == (tr.OBS_SIZE,)
    assert env.name == "otgym/speed-control/paper"
    with pytest.raises(ValueError, match="unknown task 'juggle'"):
        gymnax_env.TaskEnvironment("juggle")


@pytest.mark.slow
def test_rejax_dqn_trains_on_a_task(tmp_path, monkeypatch):
    """The rejax example of docs/speed-control.md, run as it stands: rejax's DQN,
    unchanged, trains on the paper's task for 2048 steps in 8 environments: every step
    taken, the Q-network updated from its initial weights, no value or weight not
    finite."""
    pytest.importorskip("rejax")
    from tests.docs.test_examples import example_code

    monkeypatch.chdir(tmp_path)
    namespace = {"__name__": "__docs_example__"}
    exec(compile(example_code("docs/speed-control.md", "rejax.DQN.create"), "speed-control.md", "exec"), namespace)
    algo, trained = namespace["algo"], namespace["trained"]
    assert (algo.total_timesteps, algo.num_envs) == (TRAIN_STEPS, TRAIN_ENVS)
    key = jax.random.PRNGKey(0)
    initial = algo.init_state(key).q_ts.params
    assert int(trained.global_step) == TRAIN_STEPS
    before, after = jax.tree.leaves(initial), jax.tree.leaves(trained.q_ts.params)
    assert all(np.all(np.isfinite(np.asarray(leaf))) for leaf in after)
    assert any(not np.array_equal(np.asarray(a), np.asarray(b)) for a, b in zip(before, after))
    observations = np.asarray(trained.replay_buffer.data.obs)
    assert observations.shape[-1] == tr.OBS_SIZE and np.all(np.isfinite(observations)) and np.any(observations != 0)
