"""The statistics of ``otgym experiment assemble`` / ``orient``
(``otgym.experiments.task_report.run``) on made-up paired outcomes whose answers are known:
the plan's decision rule in each of its branches, Wilson intervals, McNemar's exact p
from the binomial, the median's distribution-free interval. Nothing is simulated."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import binom

from otgym.experiments.task_report import run as tr

N = 256


def outcome(success, time_s):
    return {"success": np.asarray(success, bool), "time_s": np.asarray(time_s, float)}


def test_wilson_intervals_are_those_docs_tasks_md_reports():
    low, high = tr.wilson(64, 64)
    assert (round(low, 3), high) == (0.943, 1.0)
    low, high = tr.wilson(0, 64)
    assert (low, round(high, 3)) == (0.0, 0.057)


def test_faster_at_equal_success_beats_the_baseline():
    rng = np.random.default_rng(0)
    base = outcome(np.ones(N), 3.0 + rng.normal(0, 0.1, N))
    learned = outcome(np.ones(N), base["time_s"] - 1.0 + rng.normal(0, 0.1, N))
    result = tr.compare(base, learned)
    assert result["mcnemar_exact_p"] == 1.0 and result["wilcoxon_p"] < 1e-10
    low, high = result["median_time_difference_ci95_s"]
    assert low <= result["median_time_difference_s"] <= high < -0.9
    assert result["verdict"].startswith("beats: same success")


def test_slower_at_equal_success_is_a_miss():
    base = outcome(np.ones(N), np.linspace(2, 4, N))
    learned = outcome(np.ones(N), np.linspace(2, 4, N) + 0.5)
    assert tr.compare(base, learned)["verdict"].startswith("miss: same success")


def test_losing_twenty_episodes_is_a_miss_however_fast():
    success = np.ones(N, bool)
    success[:20] = False
    base = outcome(np.ones(N), np.full(N, 3.0))
    learned = outcome(success, np.full(N, 1.0))
    result = tr.compare(base, learned)
    assert result["table"] == {"both": N - 20, "baseline_only": 20, "learned_only": 0, "neither": 0}
    assert result["mcnemar_exact_p"] == pytest.approx(2 * 0.5**20)  # the exact binomial, two-sided
    assert result["verdict"].startswith("miss: lower success rate")


def test_more_successes_beats_the_baseline_and_a_few_more_do_not():
    success = np.ones(N, bool)
    success[:20] = False
    assert tr.compare(outcome(success, np.ones(N)), outcome(np.ones(N), np.ones(N)))["verdict"].startswith(
        "beats: higher success"
    )
    success[:18] = True  # 2 discordant pairs: p = 0.5
    result = tr.compare(outcome(success, np.ones(N)), outcome(np.ones(N), np.ones(N)))
    assert result["mcnemar_exact_p"] == pytest.approx(0.5) and result["verdict"].startswith("miss")


def test_the_median_interval_is_the_binomial_order_statistics():
    d = np.arange(N, dtype=float)  # the i-th smallest difference is i - 1
    low, high = tr.median_interval(d)
    k = int(low) + 1
    assert binom.cdf(k - 1, N, 0.5) <= 0.025 < binom.cdf(k, N, 0.5)  # the widest k that keeps 95 %
    assert high == N - k
    assert tr.median_interval(np.arange(5.0)) is None  # 2 x 0.5**5 > 0.05: no interval


def test_a_higher_secondary_metric_at_equal_success_beats_and_a_lower_one_misses():
    """sort-cells' plan: the secondary outcome is a per-episode metric on all episodes,
    higher is better (its throughput), its direction that of the signed ranks."""
    rng = np.random.default_rng(1)
    base = outcome(np.ones(N), np.full(N, 120.0)) | {"throughput": rng.integers(8, 12, N) / 2.0}
    more = base["throughput"] + np.where(rng.random(N) < 0.3, 0.5, 0.0)  # one more cell in 30 % of episodes
    result = tr.compare(base, outcome(np.ones(N), np.full(N, 120.0)) | {"throughput": more}, "throughput")
    assert result["secondary"] == "throughput" and result["signed_rank_direction"] == 1
    assert result["median_difference"] == 0.0 and result["wilcoxon_p"] < 1e-10  # the median alone can't tell
    assert result["verdict"] == "beats: same success (McNemar p >= 0.05) and higher throughput (Wilcoxon p < 0.05)"
    fewer = base["throughput"] - np.where(rng.random(N) < 0.3, 0.5, 0.0)
    result = tr.compare(base, outcome(np.ones(N), np.full(N, 120.0)) | {"throughput": fewer}, "throughput")
    assert result["signed_rank_direction"] == -1 and result["verdict"].startswith("miss: same success")
    same = tr.compare(base, base, "throughput")
    assert same["wilcoxon_p"] == 1.0 and same["verdict"].startswith("miss: no difference")
