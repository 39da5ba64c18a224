"""Gymnasium adapters: registration, env checker, rendering, bad actions."""

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import otgym.envs  # noqa: F401  (registers the ids)

pytestmark = pytest.mark.xdist_group("gym_envs")  # one worker compiles each task's single and vector step once


@pytest.mark.parametrize("env_id", ["otgym/SpeedControl-v0", "otgym/CellTransport-v0"])
@pytest.mark.slow
def test_env_checker_passes_and_renders(env_id):
    env = gym.make(env_id, render_mode="rgb_array")
    check_env(env.unwrapped, skip_render_check=False)
    obs, info = env.reset(seed=0)
    assert obs.dtype == np.float32 and obs.shape == env.observation_space.shape
    obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
    assert isinstance(reward, float) and isinstance(terminated, bool) and isinstance(truncated, bool)
    frame = env.render()
    assert frame.shape == (400, 600, 3) and frame.dtype == np.uint8
    env.close()


@pytest.mark.slow
def test_speed_control_rejects_actions_outside_the_space():
    env = gym.make("otgym/SpeedControl-v0").unwrapped
    env.reset(seed=1)
    for bad in (6, -1, 2.5, "fast"):
        with pytest.raises(ValueError, match="action must be an integer"):
            env.step(bad)


@pytest.mark.slow
def test_cell_transport_rejects_nan_wrong_shape_and_out_of_bounds():
    env = gym.make("otgym/CellTransport-v0").unwrapped
    env.reset(seed=2)
    with pytest.raises(ValueError, match="finite"):
        env.step(np.array([[np.nan, 0.0], [0.0, 0.0]]))
    with pytest.raises(ValueError, match="shape"):
        env.step(np.zeros(3))
    with pytest.raises(ValueError, match=r"\[-1.0, 1.0\]"):
        env.step(np.full((2, 2), 5.0))


@pytest.mark.slow
def test_same_seed_same_episode():
    env = gym.make("otgym/SpeedControl-v0").unwrapped
    first = [env.reset(seed=3)[0]] + [env.step(4)[0] for _ in range(3)]
    second = [env.reset(seed=3)[0]] + [env.step(4)[0] for _ in range(3)]
    np.testing.assert_array_equal(np.array(first), np.array(second))
