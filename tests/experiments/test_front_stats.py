"""The speed front's logic on hand-built outcomes: who is on the front, which constant
speeds a policy covers, and the paired tests behind it (each built to fail if the logic
or a test's direction is wrong)."""

from __future__ import annotations

import numpy as np
import pytest

from otgym.experiments.speed_front.stats import (
    Outcomes,
    compare,
    compare_all,
    measure_goals,
    pareto_front,
)

N = 400


def outcome(name, failures, time_s, speed=None, group="constant", lost=None):
    """``failures`` episodes lost (the first ones, or the indices ``lost``), every
    completed episode taking ``time_s``."""
    success = np.ones(N, bool)
    success[np.arange(failures) if lost is None else np.asarray(lost)] = False
    return Outcomes(name, success, np.full(N, float(time_s)), speed, group)


def test_a_dominated_policy_is_not_on_the_front():
    fast_safe = outcome("A", 2, 30.0, group="family")
    slower_riskier = outcome("B", 10, 35.0, group="family")  # worse in both
    safest = outcome("C", 0, 50.0, group="family")  # slower but safer: on the front
    tie = outcome("D", 2, 30.0, group="family")  # equal to A: neither dominates
    assert pareto_front([fast_safe, slower_riskier, safest, tie]) == ["A", "D", "C"]


def test_a_constant_below_090_is_exempt_and_the_others_need_cover():
    constants = [
        outcome("G1", 0, 55.6, 0.27),
        outcome("G3", 4, 41.0, 0.366),
        outcome("G6", 60, 29.6, 0.51),  # success 0.85 < 0.90: exempt
    ]
    # covers G3 (as safe, 0.8 x its time) but not G1 (loses more than G1's none)
    policy = outcome("P", 4, 0.8 * 41.0, group="family", lost=[0, 1, 2, 3])
    outcomes = constants + [policy]
    goals = measure_goals(outcomes, compare_all(outcomes), reference="G3")
    assert goals.exempt == ["G6"] and goals.eligible == ["G1", "G3"]
    assert goals.covered_by == {"G1": [], "G3": ["P"]}
    assert not goals.every_eligible_covered
    assert goals.seeds_covering_reference == {"family": (1, 1)}
    assert goals.pretrained_covers_reference is None


def test_mcnemar_flags_a_policy_less_safe_by_construction():
    """The policy loses the constant's 2 episodes and 18 more: discordant 18 to 0."""
    constant = outcome("G3", 2, 41.0, 0.366)
    riskier = outcome("P", 20, 30.0, group="family")
    result = compare(riskier, constant)
    assert (result.policy_only_lost, result.constant_only_lost) == (18, 0)
    assert result.less_safe_p == pytest.approx(0.5**18)
    assert not result.as_safe and result.faster and not result.covers
    # the reverse direction is not flagged: the constant is the riskier one
    reverse = compare(outcome("Q", 2, 30.0, group="family"), outcome("G5", 20, 32.0, 0.462))
    assert reverse.less_safe_p == pytest.approx(1.0) and reverse.as_safe


def test_as_safe_needs_a_point_estimate_not_lower_even_when_mcnemar_is_silent():
    constant = outcome("G1", 0, 55.6, 0.27)
    one_more = outcome("P", 1, 40.0, group="family")  # p = 0.5, but 399/400 < 400/400
    result = compare(one_more, constant)
    assert result.less_safe_p == pytest.approx(0.5) and not result.success_not_lower and not result.covers


def test_ten_percent_faster_is_a_sign_test_on_each_shared_completion():
    constant = outcome("G2", 0, 47.2, 0.318)
    only_five_percent = outcome("P", 0, 0.95 * 47.2, group="family")
    eleven_percent = outcome("Q", 0, 0.89 * 47.2, group="family")
    assert not compare(only_five_percent, constant).faster
    fast = compare(eleven_percent, constant)
    assert fast.faster and fast.faster_episodes == N and fast.faster_p == pytest.approx(0.5**N)
    # faster in only half of the episodes: not significant
    mixed = Outcomes("R", np.ones(N, bool), np.where(np.arange(N) % 2 == 0, 30.0, 47.2), None, "family")
    assert not compare(mixed, constant).faster


def test_pretrained_is_held_against_the_reference():
    constants = [outcome("G3", 4, 41.0, 0.366)]
    shipped = outcome("pretrained", 30, 31.8, group="pretrained")
    outcomes = constants + [shipped]
    goals = measure_goals(outcomes, compare_all(outcomes), reference="G3")
    assert goals.pretrained_covers_reference is False
    assert goals.seeds_covering_reference == {}
