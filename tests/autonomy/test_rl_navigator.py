"""The learned-speed navigator (``otgym.autonomy.rl_navigator``) on a straight route
along x, numpy only: its features put an obstacle where it is along and across the
route, the shipped policy stops or slows for an obstacle about to cross just ahead and
cruises on a clear way, it sets the speed it chose, and bad input is refused."""

import numpy as np
import pytest

from otgym.autonomy import rl_navigator as rn
from otgym.rl.policy import PRETRAINED_POLICY
from otgym.task.task import CARRY
from tests.human.test_participants import OFFSETS_UM, TICK_S, scene

ROUTE = np.stack([np.linspace(0.0, 300.0, 2401), np.zeros(2401)], axis=1)
ARC = ROUTE[:, 0].copy()
CELL_X_UM = 100.0
ESCAPE_UM = 0.6


class Fixed:
    """A policy that always chooses speed index ``action``."""

    speeds_um_s = rn.SPEEDS_UM_S
    decision_s = rn.DECISION_S

    def __init__(self, action):
        self.action, self.calls = action, 0

    def choose(self, features):
        self.calls += 1
        return np.full(len(features), self.action)


def navigator(policy):
    nav = rn.RLNavigator(ROUTE, ARC, OFFSETS_UM, TICK_S, policy, ESCAPE_UM)
    nav.reset(1)
    return nav


def observation(obstacle_xy, gap_um, time_s=0.0):
    obs = scene([[CELL_X_UM, 0.0]], (OFFSETS_UM + [CELL_X_UM, 0.0])[None], CARRY, obstacle_xy)
    obs.obstacle_gap_um = np.asarray(gap_um, float)[None]
    obs.time_s = np.array([time_s])
    return obs


def crossing(ticks, start_y_um=16.0, ahead_um=14.0, speed_um_s=2.0):
    """Observations of an obstacle ``ahead_um`` ahead of the cell moving towards the
    route from ``start_y_um`` at ``speed_um_s`` (three others far away)."""
    far = [(250.0, 60.0), (280.0, -60.0), (20.0, 60.0)]
    out = []
    for tick in range(ticks):
        y = start_y_um - speed_um_s * tick * TICK_S
        xy = [(CELL_X_UM + ahead_um, y)] + far
        gap = [np.hypot(ahead_um - 3.5, max(y - 6.5, 0.0)) - 3.0 - 1.5] + [60.0] * 3
        out.append(observation(xy, gap, tick * TICK_S))
    return out


def clear(ticks):
    far = [(250.0, 60.0), (280.0, -60.0), (20.0, 60.0), (40.0, -60.0)]
    return [observation(far, [60.0] * 4, tick * TICK_S) for tick in range(ticks)]


def test_features_place_an_obstacle_along_and_across_the_route_and_its_closing_speed():
    """An obstacle 14 um ahead, 16 um off the route and closing at 2 um/s (fit over the
    tracker's 1 s window of noise-free positions: exact) is the nearest one, first."""
    nav = navigator(Fixed(3))
    for obs in crossing(51):
        nav.increments(obs)
    features = nav.features(obs)[0]
    y = 16.0 - 2.0 * 50 * TICK_S
    assert features[0] == pytest.approx(14.0 / rn.ALONG_SCALE_UM, abs=1e-3)
    assert features[1] == pytest.approx(y / rn.ACROSS_SCALE_UM, abs=1e-3)
    assert features[2] == pytest.approx(2.0 / rn.CLOSING_SCALE_UM_S, abs=1e-3)  # towards the route: positive
    assert features[-4:] == pytest.approx([5.0 / rn.SPEED_SCALE_UM_S, 200.0 / 300.0, 0.0, 1.0], abs=1e-3)
    # the same obstacle on the other side moving away opens: negative
    mirrored = observation([(CELL_X_UM + 14.0, -y)], [5.0])
    assert rn.speed_features(
        ROUTE,
        ARC,
        rn.route_tangents(ROUTE),
        [CELL_X_UM],
        mirrored.obstacle_xy_um,
        [[[0.0, -2.0]]],
        [[5.0]],
        [5.0],
        [0.0],
        [True],
    )[0, 2] == pytest.approx(-1.0)


def test_each_decision_sets_the_chosen_speed_and_decisions_come_every_half_second():
    for action in (0, len(rn.SPEEDS_UM_S) - 1):
        policy = Fixed(action)
        nav = navigator(policy)
        for obs in clear(60):
            nav.increments(obs)
        assert policy.calls == 3  # ticks 0, 25 and 50
        assert nav.cruise_speed_um_s[0] == rn.SPEEDS_UM_S[action]
    stopped, fastest = navigator(Fixed(0)), navigator(Fixed(len(rn.SPEEDS_UM_S) - 1))
    for nav in (stopped, fastest):
        nav.increments(clear(1)[0])
    assert stopped.commanded_arc_um[0] == CELL_X_UM  # speed 0: the arc stays at the cell
    assert fastest.commanded_arc_um[0] == pytest.approx(CELL_X_UM + 8.0 * TICK_S)


def shipped_speed_and_q(observations):
    nav = navigator(rn.load_speed_policy())
    for obs in observations:
        nav.increments(obs)
    return nav.cruise_speed_um_s[0], nav.policy.q_values(nav.last_features)[0]


def test_the_shipped_policy_waits_for_an_obstacle_about_to_cross_and_cruises_on_a_clear_way():
    """The decision at 1 s (tick 50), after the tracker has seen the obstacle close for
    a second. A network that had learned nothing would not order its values by the
    scene: the danger must make stopping or creeping (<= 2 um/s) the best choice by a
    clear margin over every cruising speed (>= 5 um/s), the clear way the reverse."""
    danger_speed, danger_q = shipped_speed_and_q(crossing(51))
    clear_speed, clear_q = shipped_speed_and_q(clear(51))
    slow = [i for i, v in enumerate(rn.SPEEDS_UM_S) if v <= 2.0]
    fast = [i for i, v in enumerate(rn.SPEEDS_UM_S) if v >= 5.0]
    assert danger_speed <= 2.0 and clear_speed >= 5.0
    assert danger_q[slow].max() > danger_q[fast].max()
    assert clear_q[fast].max() > clear_q[slow].max()


def test_bad_input_is_refused(tmp_path):
    with pytest.raises(ValueError, match="not an interactive-task speed policy"):
        rn.load_speed_policy(PRETRAINED_POLICY)  # the transport task's DQN
    with pytest.raises(FileNotFoundError):
        rn.load_speed_policy(tmp_path / "missing.npz")
    policy = rn.load_speed_policy()
    with pytest.raises(ValueError, match="features must be"):
        policy.q_values(np.zeros((1, rn.N_FEATURES + 1)))
    with pytest.raises(ValueError, match="reset"):
        navigator(Fixed(0)).increments(scene([[1.0, 0.0]] * 2, np.zeros((2, 4, 2)), CARRY))
    with pytest.raises(ValueError, match="escape_distance_um"):
        rn.RLNavigator(ROUTE, ARC, OFFSETS_UM, TICK_S, Fixed(0), 0.0)
    bad = Fixed(0)
    bad.speeds_um_s = (5.0, -1.0)
    with pytest.raises(ValueError, match="speeds_um_s"):
        rn.RLNavigator(ROUTE, ARC, OFFSETS_UM, TICK_S, bad, ESCAPE_UM)


def test_the_trial_autonomy_resets_the_navigator_when_a_new_trial_starts():
    nav = navigator(Fixed(4))
    autonomy = rn.TrialAutonomy(nav)
    for obs in clear(30):
        autonomy(obs)
    assert nav.ticks[0] == 30
    autonomy(clear(1)[0])  # time 0 again: a new trial
    assert nav.ticks[0] == 1
