"""The obstacle tracker's constant-velocity fit (``otgym.autonomy.obstacle_prediction``)."""

import numpy as np
import pytest

from otgym.autonomy.obstacle_prediction import ObstacleTracker

TICK_S = 0.02


def _observe_path(tracker, velocity, start, ticks, noise_um=0.0, seed=0, t0=0.0):
    rng = np.random.default_rng(seed)
    velocity, start = np.asarray(velocity, float), np.asarray(start, float)
    for i in range(ticks):
        t = t0 + i * TICK_S
        xy = start + velocity * t + rng.normal(0.0, noise_um, start.shape)
        tracker.observe(np.full(start.shape[0], t), xy)
    return t0 + (ticks - 1) * TICK_S


def test_recovers_a_known_constant_velocity_per_obstacle():
    velocity = np.array([[[2.0, -1.0], [0.0, 0.0], [-3.0, 0.5]]])  # (E=1, K=3, 2)
    tracker = ObstacleTracker(window_s=1.0, tick_s=TICK_S)
    tracker.reset(1, 3)
    _observe_path(tracker, velocity, np.array([[[10.0, 5.0], [0.0, 0.0], [-4.0, 2.0]]]), ticks=120)
    np.testing.assert_allclose(tracker.velocity_um_s(), velocity, atol=1e-9)


def test_velocity_noise_matches_least_squares_statistics():
    """Independent position noise sigma on n samples spread over T gives a slope SD of
    sigma * sqrt(12 / (n T^2)) (n = 51 over 1 s, sigma = 0.1 um: 0.049 um/s). Over 400
    environments x 2 axes the SD of the estimates is within 10 % of it (the SD of an
    SD estimate from 800 samples is 2.5 %)."""
    n_env, sigma = 400, 0.1
    tracker = ObstacleTracker(window_s=1.0, tick_s=TICK_S)
    tracker.reset(n_env, 1)
    _observe_path(tracker, np.zeros((n_env, 1, 2)), np.zeros((n_env, 1, 2)), ticks=200, noise_um=sigma)
    n = tracker.capacity
    span = (n - 1) * TICK_S
    expected = sigma * np.sqrt(12.0 / (n * span**2) * (n - 1) / (n + 1))
    measured = tracker.velocity_um_s().reshape(-1).std()
    assert measured == pytest.approx(expected, rel=0.10)


def test_window_forgets_an_old_velocity():
    tracker = ObstacleTracker(window_s=0.5, tick_s=TICK_S)
    tracker.reset(1, 1)
    end = _observe_path(tracker, [[[5.0, 0.0]]], [[[0.0, 0.0]]], ticks=100)
    _observe_path(tracker, [[[0.0, 0.0]]], [[[5.0 * end, 0.0]]], ticks=30, t0=end + TICK_S)
    np.testing.assert_allclose(tracker.velocity_um_s(), 0.0, atol=1e-9)


def test_no_velocity_before_two_observations_and_tracks_start_where_last_seen():
    tracker = ObstacleTracker(window_s=1.0, tick_s=TICK_S)
    tracker.reset(2, 1)
    tracker.observe(np.zeros(2), np.array([[[1.0, 2.0]], [[3.0, 4.0]]]))
    np.testing.assert_array_equal(tracker.velocity_um_s(), 0.0)
    tracker.observe(np.full(2, TICK_S), np.array([[[1.0, 2.0]], [[3.0 + 0.1, 4.0]]]))
    tracks = tracker.predicted_tracks(np.full(2, TICK_S))
    velocity = tracker.velocity_um_s()
    np.testing.assert_allclose(velocity[1, 0], [5.0, 0.0], atol=1e-9)
    # the track passes through the last seen position at the present time
    elapsed = TICK_S - tracks["depart_s"]
    position = tracks["start_um"] + tracks["direction"] * (tracks["speed_um_s"] * elapsed)[..., None]
    np.testing.assert_allclose(position, [[[1.0, 2.0]], [[3.1, 4.0]]], atol=1e-9)


def test_rejects_bad_window():
    with pytest.raises(ValueError, match="window_s"):
        ObstacleTracker(window_s=0.0, tick_s=TICK_S)


def test_idle_until_seen_moving_then_parked_is_not_idle():
    """An obstacle is idle (may still start) until its fitted speed has exceeded 1 um/s;
    one that moved and stopped stays marked as having moved."""
    tracker = ObstacleTracker(window_s=1.0, tick_s=TICK_S)
    tracker.reset(1, 2)
    end = _observe_path(tracker, [[[0.0, 0.0], [0.0, 0.0]]], [[[0.0, 0.0], [10.0, 0.0]]], ticks=60)
    np.testing.assert_array_equal(tracker.predicted_tracks(np.array([end]))["idle"], [[1.0, 1.0]])
    end = _observe_path(
        tracker,
        [[[0.0, 0.0], [2.0, 0.0]]],
        [[[0.0, 0.0], [10.0 - 2.0 * (end + TICK_S), 0.0]]],
        ticks=60,
        t0=end + TICK_S,
    )
    end = _observe_path(
        tracker, [[[0.0, 0.0], [0.0, 0.0]]], [[[0.0, 0.0], [10.0 + 2.0 * 1.2, 0.0]]], ticks=80, t0=end + TICK_S
    )
    np.testing.assert_allclose(tracker.velocity_um_s(), 0.0, atol=1e-9)  # at rest again
    np.testing.assert_array_equal(tracker.predicted_tracks(np.array([end]))["idle"], [[1.0, 0.0]])
