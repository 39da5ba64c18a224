"""The learned speed policy's training (``otgym.experiments.learned_speed.train``: the
one DQN trainer on task ``interactive-speed``) and its navigator in the batched
trials, tiny: two environments for four decisions; trials of 3 s."""

import numpy as np
import pytest

from otgym.autonomy.rl_navigator import N_FEATURES, SPEEDS_UM_S, SpeedPolicy, load_speed_policy
from otgym.experiments.learned_speed.train import save_speed_policy, train
from otgym.human.params import sample_population
from otgym.runtime.trials import TrialSpec, run_trials
from otgym.task.task import InteractiveConfig, InteractiveTask
from tests.autonomy.test_rl_navigator import Fixed

SCENARIO = 960_000  # a training scenario (otgym.experiments.common.seeds)


class Counting(Fixed):
    def choose(self, features):
        self.rows = getattr(self, "rows", 0) + len(features)
        return super().choose(features)


@pytest.mark.slow
def test_training_saves_a_policy_and_the_trials_give_rl_and_shared_the_learned_speed(tmp_path):
    """Fails if training does not run its decisions, if the saved file does not load back
    to the same Q-values, or if the rl and shared (``shared_autonomy="rl"``) trials do
    not get the learned-speed navigator's dP_r (its policy asked for both of them every
    0.5 s) while the autonomous trial keeps the route follower."""
    task = InteractiveTask(InteractiveConfig(time_limit_s=3.0))
    small = dict(n_envs=2, total_env_steps=8, chunk_iters=2, learning_starts=4, batch_size=4, updates_per_iter=1)
    result = train(seed=31, preset="default", **small)
    assert result.env_steps == 8 and result.meta["task"] == "interactive-speed"
    loaded = load_speed_policy(save_speed_policy(tmp_path / "speed.npz", result))
    policy = SpeedPolicy(result.q_params, (64, 64))
    features = np.random.default_rng(0).normal(size=(3, N_FEATURES))
    assert np.allclose(loaded.q_values(features), policy.q_values(features), atol=1e-6)
    assert loaded.speeds_um_s == SPEEDS_UM_S and loaded.hidden == (64, 64)

    counting = Counting(len(SPEEDS_UM_S) - 1)
    specs = [TrialSpec(0, mode, 0, SCENARIO) for mode in ("autonomous", "rl", "shared")]
    rows = run_trials(
        task,
        specs,
        dict(enumerate(sample_population(1, 97))),
        seed=97,
        shared_autonomy="rl",
        navigator_config={"rl": {"policy": counting}},
    )
    assert [row["autonomy"] for row in rows] == ["route", "rl", "rl"]
    decisions = int(np.ceil(3.0 / 0.5))
    assert counting.calls == decisions and counting.rows == 2 * decisions
    assert all(row["grip_time_s"] < 0.5 for row in rows[:2])
