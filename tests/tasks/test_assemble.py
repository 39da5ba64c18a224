"""The ``assemble`` task: registration, Gymnasium's and SB3's checkers, bad actions and
configs rejected, the frame and the pointing-device action, the plan's assignment."""

import math

import gymnasium as gym
import jax
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from scipy.optimize import linear_sum_assignment

import otgym  # noqa: F401  (registers the ids)
from otgym import registry, tasks
from otgym.tasks.assemble import plan
from otgym.tasks.assemble.config import AssembleConfig, preset
from tests.tasks import sb3_checker_warnings

ENV_ID = "otgym/assemble-v0"


def test_registered_with_its_gym_id():
    assert "assemble" in registry.names("tasks")
    assert ENV_ID in gym.registry
    assert isinstance(tasks.load("assemble"), tasks.Task)


@pytest.mark.slow
def test_gymnasium_checker_passes_and_frame_renders():
    env = gym.make(ENV_ID, render_mode="rgb_array")
    check_env(env.unwrapped, skip_render_check=False)
    obs, _ = env.reset(seed=0)
    assert obs.dtype == np.float32 and obs.shape == env.observation_space.shape
    obs, reward, terminated, truncated, info = env.step(1)
    assert isinstance(reward, float) and isinstance(terminated, bool) and isinstance(truncated, bool)
    for key in ("rms_error_um", "time_s", "beads_lost", "collisions", "success"):
        assert key in info
    assert info["time_s"] == pytest.approx(1 / preset("ring").slm_refresh_hz)
    frame = env.render()
    assert frame.shape == (400, 600, 3) and frame.dtype == np.uint8
    bead_yellow = np.all(np.abs(frame.astype(int) - [230, 200, 60]) < 30, axis=-1)
    assert bead_yellow.sum() > 8 * 10  # eight beads, each many pixels wide
    env.close()


@pytest.mark.slow
def test_sb3_checker_passes_without_warnings():
    assert sb3_checker_warnings(ENV_ID) == []


def test_bad_actions_raise():
    env = gym.make(ENV_ID).unwrapped
    env.reset(seed=1)
    n = len(preset("ring").pace_levels_um)
    for bad in (n, -1, 2.5, "fast", True, np.array([1, 2])):
        with pytest.raises(ValueError, match="action must be an integer"):
            env.step(bad)
    task = tasks.load("assemble")
    with pytest.raises(ValueError, match="actions must be integers"):
        task.check_actions(np.array([0, n]), env.params, 2)


def test_bad_configs_raise():
    with pytest.raises(ValueError, match="max_traps"):
        AssembleConfig(n_beads=17, max_traps=16)
    with pytest.raises(ValueError, match="collision-free separation"):
        AssembleConfig(target_spacing_um=1.5)
    with pytest.raises(ValueError, match="pattern"):
        AssembleConfig(pattern="spiral")
    with pytest.raises(ValueError, match="slm_refresh_hz"):
        AssembleConfig(slm_refresh_hz=0.0)
    with pytest.raises(ValueError, match="no preset"):
        tasks.load("assemble").config("star")


def test_power_is_shared_between_the_traps():
    single = AssembleConfig(n_beads=4)
    double = AssembleConfig(n_beads=8)
    assert double.trap_stiffness_pn_per_um == pytest.approx(single.trap_stiffness_pn_per_um / 2)
    assert single.trap_law.stiffness_pn_per_um == pytest.approx(
        single.stiffness_per_power_pn_per_um_mw * single.laser_power_mw / 4
    )


def test_device_action_picks_the_nearest_pace():
    task = tasks.load("assemble")
    params = gym.make(ENV_ID).unwrapped.params
    config = params.config
    assert task.device_action(np.zeros(2), params) == 0
    assert task.device_action(np.array([1e3, 0.0]), params) == config.n_actions - 1
    per_frame = config.pace_levels_um[3]
    velocity = np.array([0.6, 0.8]) * per_frame / config.frame_period_s
    action = task.device_action(velocity, params)
    assert action == 3
    task.check_action(action, params)
    with pytest.raises(ValueError, match="velocity_um_s"):
        task.device_action(np.array([np.nan, 0.0]), params)


@pytest.mark.parametrize("pattern,n", [("ring", 8), ("lattice", 9), ("letter", 8)])
def test_patterns_keep_their_spacing(pattern, n):
    points = plan.pattern_um(pattern, n, 3.0)
    distance = np.linalg.norm(points[:, None] - points[None], axis=-1) + np.eye(n) * 1e9
    assert points.shape == (n, 2)
    assert np.min(distance) == pytest.approx(3.0, rel=1e-6)
    np.testing.assert_allclose(points.mean(axis=0), 0.0, atol=1e-9)


def test_assignment_is_swap_stable_and_its_straight_moves_keep_beads_apart():
    """On 64 random instances: no pair lowers the summed squared distance by exchanging
    targets, the cost is never below the Hungarian optimum (scipy), and the
    synchronised straight moves keep every pair at least min(start, goal distance) /
    sqrt(2) apart (CAPT). The identity assignment breaks the last on these instances,
    so the check can fail."""
    rng = np.random.default_rng(5)
    assign = jax.jit(plan.swap_stable_assignment)
    config = AssembleConfig()
    target_pattern = plan.pattern_um("ring", 8, config.target_spacing_um) + 20.0
    identity_violations = 0
    for _ in range(64):
        cells = rng.choice(100, 8, replace=False)
        start = np.column_stack([cells % 10, cells // 10]) * 4.0 + 2.0 + rng.uniform(-0.9, 0.9, (8, 2))
        order = np.asarray(assign(start.astype(np.float32), target_pattern.astype(np.float32)))
        assert sorted(order.tolist()) == list(range(8))
        goal = target_pattern[order]
        cost = np.sum((start - goal) ** 2)
        cost_matrix = np.sum((start[:, None] - target_pattern[None]) ** 2, axis=-1)
        rows, cols = linear_sum_assignment(cost_matrix)
        assert cost >= cost_matrix[rows, cols].sum() - 1e-6
        for i in range(8):
            for j in range(i + 1, 8):
                assert np.dot(start[i] - start[j], goal[i] - goal[j]) >= -1e-3
        bound = min(
            np.min(np.linalg.norm(start[:, None] - start[None], axis=-1) + np.eye(8) * 1e9),
            np.min(np.linalg.norm(goal[:, None] - goal[None], axis=-1) + np.eye(8) * 1e9),
        ) / math.sqrt(2)
        assert plan.min_plan_separation_um(start, goal) >= bound - 1e-6
        identity_violations += plan.min_plan_separation_um(start, target_pattern) < bound
    assert identity_violations > 0


def test_baseline_pace_is_the_largest_level_within_half_the_waist():
    from otgym.experiments.assemble.run import baseline_action

    config = preset("ring")
    action = baseline_action(config)
    assert config.pace_levels_um[action] <= config.waist_um / 2
    assert action == config.n_actions - 1 or config.pace_levels_um[action + 1] > config.waist_um / 2
