"""Native vector envs (``otgym.envs.gym_vector``): ``make_vec`` returns them, spaces,
dtypes and seeding, progress of one step per speed level, same-step autoreset with
``final_obs``/``final_info``, rendering, bad actions and bad ``num_envs``.

Every test uses 4 environments of the ``paper`` preset, so each task's batched
reset/step compile once for the module."""

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode
from gymnasium.vector.utils import batch_space

import otgym.envs  # noqa: F401  (registers the ids)
from otgym.envs.gym_adapter import TaskEnv
from otgym.envs.gym_vector import TaskVectorEnv

pytestmark = pytest.mark.xdist_group("gym_envs")  # one worker compiles each task's single and vector step once

N = 4
SPEED_ID, CELL_ID = "otgym/SpeedControl-v0", "otgym/CellTransport-v0"


@pytest.fixture(scope="module")
def speed_env():
    env = gym.make_vec(SPEED_ID, num_envs=N, vectorization_mode="vector_entry_point")
    yield env
    env.close()


@pytest.fixture(scope="module")
def cell_env():
    env = gym.make_vec(CELL_ID, num_envs=N, vectorization_mode="vector_entry_point")
    yield env
    env.close()


@pytest.mark.parametrize("env_id, task", [(SPEED_ID, "speed-control"), (CELL_ID, "cell-transport")])
def test_make_vec_returns_the_native_vector_env_and_make_the_single_one(env_id, task):
    env = gym.make_vec(env_id, num_envs=N, vectorization_mode="vector_entry_point")
    assert type(env) is TaskVectorEnv and env.num_envs == N and env.task.name == task
    assert type(gym.make_vec(env_id, num_envs=2)) is TaskVectorEnv  # the default mode for these ids
    assert type(gym.make_vec(env_id, num_envs=2, vectorization_mode="sync")) is gym.vector.SyncVectorEnv
    single = gym.make(env_id)
    assert type(single.unwrapped) is TaskEnv and single.unwrapped.task.name == task
    assert env.metadata["autoreset_mode"] is AutoresetMode.SAME_STEP
    assert env.single_observation_space == single.observation_space
    assert env.single_action_space == single.action_space
    assert env.observation_space == batch_space(single.observation_space, N)
    assert env.action_space == batch_space(single.action_space, N)
    other = TaskVectorEnv(N, task)
    assert other._step is env._step and other.params is env.params  # compiled once per (task, preset)


@pytest.mark.slow
def test_reset_shapes_dtypes_and_seed_reproducibility(speed_env):
    obs, info = speed_env.reset(seed=7)
    assert obs.shape == (N, 21) and obs.dtype == np.float32 and info == {} and obs.flags.writeable
    assert speed_env.observation_space.contains(obs)
    assert len({row.tobytes() for row in obs}) == N  # four different episodes
    steps = [speed_env.step(np.array([5, 0, 3, 1])) for _ in range(3)]
    again, _ = speed_env.reset(seed=7)
    np.testing.assert_array_equal(again, obs)
    for obs_1, reward_1, *_ in steps:
        obs_2, reward_2, terminated, truncated, info = speed_env.step(np.array([5, 0, 3, 1]))
        np.testing.assert_array_equal(obs_2, obs_1)
        np.testing.assert_array_equal(reward_2, reward_1)
        assert not np.shares_memory(obs_1, obs_2)
        assert all(array.flags.writeable for array in (obs_2, reward_2, terminated, truncated, info["progress"]))
    assert not np.array_equal(speed_env.reset(seed=8)[0], obs)


@pytest.mark.slow
def test_one_step_advances_progress_by_the_chosen_speed(speed_env):
    config = speed_env.params.config
    period = config.scene.control_period_s
    assert (config.segment_um, period) == (15.0, 0.2)  # the paper preset
    for actions in (np.array([0, 1, 2, 3]), np.array([4, 5, 5, 4])):
        speed_env.reset(seed=11)
        obs, reward, terminated, truncated, info = speed_env.step(actions)
        expected = np.asarray(config.speed_levels_um_s)[actions] * period / config.segment_um
        np.testing.assert_allclose(info["progress"], expected, rtol=0, atol=2e-5)  # float32 arcs of ~500 um
        np.testing.assert_allclose(obs[:, 0], expected, rtol=0, atol=2e-5)
        np.testing.assert_allclose(
            obs[:, 1], np.asarray(config.speed_levels_um_s)[actions] / max(config.speed_levels_um_s), rtol=1e-5
        )
        assert reward.dtype == np.float32 and reward.shape == (N,) and np.all(np.isfinite(reward))
        assert terminated.dtype == truncated.dtype == np.bool_ and terminated.shape == truncated.shape == (N,)
        assert not terminated.any() and not truncated.any() and "final_obs" not in info
        np.testing.assert_allclose(info["time_s"], period)
        assert info["success"].dtype == info["failed"].dtype == np.bool_
        assert info["contact_force_pn"].shape == (N, 2) and info["trap_distance_um"].shape == (N, 4)
        assert info["_progress"].all() and info["_trap_distance_um"].shape == (N,)


@pytest.mark.slow
def test_same_step_autoreset_returns_a_fresh_episode_and_the_final_obs_in_infos(speed_env):
    config = speed_env.params.config
    levels = np.asarray(config.speed_levels_um_s)
    actions = np.array([5, 5, 4, 3])  # the fastest in two envs, so that the others are still running
    step_progress = levels[actions] * config.scene.control_period_s / config.segment_um
    env = gym.wrappers.vector.RecordEpisodeStatistics(speed_env)
    env.reset(seed=3)
    for _ in range(config.max_steps):
        obs, reward, terminated, truncated, info = env.step(actions)
        done = terminated | truncated
        if done.any():
            break
        assert "final_obs" not in info
        np.testing.assert_allclose(obs[:, 0], info["progress"], rtol=1e-6)
    assert done.any(), "no episode ended within max_steps"
    assert not done.all(), "choose a seed where some episodes go on"
    np.testing.assert_array_equal(info["_final_obs"], done)
    np.testing.assert_array_equal(info["_final_info"], done)
    for i in range(N):
        if done[i]:
            final = info["final_obs"][i]
            assert final.shape == (21,) and final.dtype == np.float32
            assert final[0] == pytest.approx(info["final_info"]["progress"][i]) and final[0] > 5 * step_progress[i]
            assert abs(obs[i, 0]) < 1e-6 and obs[i, 1] == 0.0  # a new episode: no progress, no speed yet
            if terminated[i]:
                assert info["final_info"]["success"][i] or info["final_info"]["failed"][i]
            steps = round(float(info["final_info"]["time_s"][i]) / config.scene.control_period_s)
            assert info["episode"]["l"][i] == steps and info["_episode"][i]
        else:
            assert info["final_obs"][i] is None and not info["_episode"][i]
            assert obs[i, 0] == pytest.approx(info["progress"][i]) and obs[i, 0] > 5 * step_progress[i]
    before = obs[:, 0].copy()
    obs, *_ = env.step(actions)
    # the state was reset, not only the observation: the new episodes made one step of progress
    np.testing.assert_allclose(obs[done, 0], step_progress[done], rtol=0, atol=2e-5)
    assert np.all(obs[~done, 0] > before[~done])


@pytest.mark.slow
def test_cell_transport_step_shapes_and_reproducibility(cell_env):
    first, _ = cell_env.reset(seed=5)
    action = np.zeros((N, 2, 2), np.float32)
    action[:, :, 0] = 0.5
    out_1 = cell_env.step(action)
    cell_env.reset(seed=5)
    out_2 = cell_env.step(action)
    obs, reward, terminated, truncated, info = out_1
    assert obs.shape == (N, 21) and obs.dtype == np.float32 and reward.dtype == np.float32
    assert terminated.dtype == np.bool_ and truncated.shape == (N,)
    assert info["contact_force_pn"].shape == (N, 2) and info["progress"].shape == (N,)
    assert not np.array_equal(obs, first)
    for a, b in zip(out_1[:4], out_2[:4], strict=True):
        np.testing.assert_array_equal(a, b)


@pytest.mark.slow
def test_render_gives_one_frame_per_environment(speed_env):
    assert speed_env.render() is None  # no render_mode
    env = TaskVectorEnv(N, "speed-control", render_mode="rgb_array")
    assert env.render() is None  # before reset
    env.reset(seed=2)
    frames = env.render()
    assert len(frames) == N
    assert all(frame.shape == (400, 600, 3) and frame.dtype == np.uint8 for frame in frames)
    assert not np.array_equal(frames[0], frames[1])  # different places on the path
    env.close()


@pytest.mark.slow
def test_speed_control_rejects_bad_actions(speed_env):
    speed_env.reset(seed=1)
    for bad, match in (
        (np.zeros(3, int), r"shape \(4,\)"),
        (2, r"shape \(4,\)"),
        (np.zeros((4, 1), int), "shape"),
        (np.array([6, 0, 0, 0]), r"integers in 0..5"),
        (np.array([0, -1, 0, 0]), r"integers in 0..5"),
        (np.array([0.0, 1.0, 2.0, 3.0]), "integers"),
        (np.array([True] * 4), "integers"),
        (["fast"] * 4, "integers"),
    ):
        with pytest.raises(ValueError, match=match):
            speed_env.step(bad)
    obs, *_ = speed_env.step([0, 1, 2, 3])  # a list of ints is fine, and the rejected calls left no trace
    assert obs.shape == (N, 21)


def test_cell_transport_rejects_nan_wrong_shape_and_out_of_bounds(cell_env):
    cell_env.reset(seed=1)
    nan = np.zeros((N, 2, 2))
    nan[2, 1, 0] = np.nan
    with pytest.raises(ValueError, match=r"finite.*\[2\]"):
        cell_env.step(nan)
    with pytest.raises(ValueError, match=r"shape \(4, 2, 2\)"):
        cell_env.step(np.zeros((N, 2)))
    with pytest.raises(ValueError, match="float array"):
        cell_env.step("fast")
    far = np.zeros((N, 2, 2))
    far[1, 0, 1] = -1.5
    with pytest.raises(ValueError, match=r"\[-1.0, 1.0\] um/s.*\[1\]"):
        cell_env.step(far)


@pytest.mark.parametrize("num_envs", [0, -2, 2.0, True])
def test_bad_num_envs(num_envs):
    with pytest.raises(ValueError, match="num_envs must be a positive integer"):
        TaskVectorEnv(num_envs, "speed-control")


def test_bad_render_mode_and_reset_options():
    with pytest.raises(ValueError, match="render_mode"):
        TaskVectorEnv(N, "speed-control", render_mode="human")
    with pytest.raises(ValueError, match="options"):
        TaskVectorEnv(N, "speed-control").reset(seed=0, options={"reset_mask": np.ones(N, bool)})
