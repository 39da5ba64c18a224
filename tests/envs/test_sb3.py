"""Stable-Baselines3 compatibility of the Gymnasium adapters: SB3's env checker,
short DQN (SpeedControl-v0) and PPO (CellTransport-v0) runs whose trained models
give in-space actions and finite Q-values / policy outputs, and seeded vectorised
envs that reproduce.

Optional: skipped unless stable-baselines3 (and torch) are installed, i.e. it runs
only with ``pip install ".[test,sb3]"``.
"""

import importlib.util
import warnings

import gymnasium as gym
import numpy as np
import pytest

if importlib.util.find_spec("stable_baselines3") is None:
    pytest.skip("stable-baselines3 is not installed (extra [sb3]): no SB3 check", allow_module_level=True)

import otgym.envs  # noqa: E402,F401  (registers the ids)

# stable-baselines3 and torch are imported inside the tests, not here: every xdist worker
# imports every test module to collect it, and torch alone takes seconds to import.

pytestmark = pytest.mark.xdist_group("gym_envs")  # one worker compiles each task's single and vector step once

ENV_IDS = ["otgym/SpeedControl-v0", "otgym/CellTransport-v0"]


@pytest.fixture(scope="module", autouse=True)
def one_torch_thread():
    """The policies are tiny MLPs: torch's intra-op threads buy nothing, and when
    another process holds a core (2-core CI, JAX's own threads) they make SB3 10-20x
    slower (2000 DQN steps: 4 s with one thread, 50-80 s with two under load)."""
    import torch

    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(threads)


def _parameters(module) -> list[np.ndarray]:
    return [p.detach().cpu().numpy().copy() for p in module.parameters()]


def _changed(before: list[np.ndarray], module) -> bool:
    return any(not np.array_equal(b, a) for b, a in zip(before, _parameters(module), strict=True))


def _rollout(env: gym.Env, model, n: int, seed: int):
    """``n`` observations met by stepping ``env`` with ``model``'s deterministic
    actions (the actions are checked against the space and must be accepted)."""
    obs, _ = env.reset(seed=seed)
    observations, actions = [], []
    for _ in range(n):
        action, _ = model.predict(obs, deterministic=True)
        assert env.action_space.contains(action), f"{action!r} is not in {env.action_space}"
        observations.append(obs)
        actions.append(action)
        obs, reward, terminated, truncated, _ = env.step(action)
        assert np.all(np.isfinite(obs)) and np.isfinite(reward)
        if terminated or truncated:
            obs, _ = env.reset()
    return np.stack(observations), np.stack(actions)


@pytest.mark.slow
@pytest.mark.parametrize("env_id", ENV_IDS)
def test_sb3_env_checker_passes_without_warnings(env_id):
    from stable_baselines3.common.env_checker import check_env

    env = gym.make(env_id)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env, warn=True)
    sb3_warnings = [str(w.message) for w in caught if "stable_baselines3" in w.filename]
    assert sb3_warnings == []
    env.close()


@pytest.fixture
def sb3_log_dir(tmp_path, monkeypatch):
    """SB3's logger folder in the test's own: unset, every model makes an empty
    ``SB3-<date>`` folder in the machine's temporary folder and leaves it there."""
    monkeypatch.setenv("SB3_LOGDIR", str(tmp_path / "sb3"))
    return tmp_path / "sb3"


@pytest.mark.slow
def test_dqn_trains_on_speed_control_and_predicts_in_space(sb3_log_dir):
    import torch
    from stable_baselines3 import DQN

    env = gym.make("otgym/SpeedControl-v0")
    model = DQN("MlpPolicy", env, learning_starts=500, buffer_size=5_000, seed=0, verbose=0)
    initial = _parameters(model.q_net)
    model.learn(2_000)

    assert model.num_timesteps == 2_000
    assert model._n_updates > 0 and _changed(initial, model.q_net), "no gradient step changed the Q-network"
    stored = model.replay_buffer.size()
    assert stored == 2_000
    assert np.all(np.isfinite(model.replay_buffer.observations[:stored]))
    assert np.all(np.isfinite(model.replay_buffer.rewards[:stored]))

    eval_env = gym.make("otgym/SpeedControl-v0")
    observations, actions = _rollout(eval_env, model, n=8, seed=10)
    with torch.no_grad():
        q_values = model.q_net(torch.as_tensor(observations, device=model.device)).cpu().numpy()
    assert q_values.shape == (8, eval_env.action_space.n)
    assert np.all(np.isfinite(q_values))
    # The greedy action is the arg-max of the learned Q-values, batched or one at a time.
    np.testing.assert_array_equal(actions, q_values.argmax(axis=1))
    batched, _ = model.predict(observations, deterministic=True)
    np.testing.assert_array_equal(batched, actions)
    env.close()
    eval_env.close()


@pytest.mark.slow
def test_ppo_trains_on_cell_transport_and_predicts_in_space(sb3_log_dir):
    import torch
    from stable_baselines3 import PPO

    env = gym.make("otgym/CellTransport-v0")
    model = PPO("MlpPolicy", env, n_steps=256, batch_size=64, n_epochs=4, seed=0, verbose=0)
    initial = _parameters(model.policy)
    model.learn(2_048)

    assert model.num_timesteps == 2_048
    assert _changed(initial, model.policy), "no gradient step changed the policy"

    eval_env = gym.make("otgym/CellTransport-v0")
    observations, actions = _rollout(eval_env, model, n=8, seed=11)
    assert actions.shape == (8, 2, 2) and actions.dtype == np.float32
    obs_t = torch.as_tensor(observations, device=model.device)
    with torch.no_grad():
        distribution = model.policy.get_distribution(obs_t).distribution
        mean, std = distribution.mean.cpu().numpy(), distribution.stddev.cpu().numpy()
        values = model.policy.predict_values(obs_t).cpu().numpy()
    assert mean.shape == std.shape == (8, 4) and values.shape == (8, 1)
    assert np.all(np.isfinite(mean)) and np.all(np.isfinite(values))
    assert np.all(np.isfinite(std)) and np.all(std > 0)
    # Deterministic actions are the Gaussian means, clipped to the box and shaped (robot, x/y).
    low, high = eval_env.action_space.low, eval_env.action_space.high
    np.testing.assert_allclose(actions, np.clip(mean.reshape(8, 2, 2), low, high), rtol=1e-6, atol=1e-6)
    # Sampled actions lie in the space too and are accepted by the env.
    eval_env.reset(seed=12)
    for obs in observations[:3]:
        action, _ = model.predict(obs, deterministic=False)
        assert eval_env.action_space.contains(action)
        eval_env.step(action)
    env.close()
    eval_env.close()


@pytest.mark.slow
@pytest.mark.parametrize("env_id", ENV_IDS)
def test_seeded_vec_envs_reproduce_and_differ_between_workers(env_id):
    from stable_baselines3.common.env_util import make_vec_env

    space = gym.make(env_id).action_space
    space.seed(0)
    actions = [np.stack([a, a]) for a in (space.sample() for _ in range(3))]  # the same for both workers

    def run(seed):
        vec = make_vec_env(env_id, n_envs=2, seed=seed)  # worker i is reset with seed + i
        frames = [vec.reset()]
        for action in actions:
            frames.append(vec.step(action)[0])
        vec.close()
        return np.stack(frames)

    first, again, other = run(5), run(5), run(6)
    np.testing.assert_array_equal(first, again)
    assert not np.array_equal(first[:, 0], first[:, 1]), "both workers got the same seed"
    assert not np.array_equal(first, other), "the seed is ignored"
