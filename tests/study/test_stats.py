"""otgym.study.stats: the repeated-measures ANOVA and Holm post-hoc tests behave as the
statistics say (power on a big effect, a 5 % false-positive rate under H0, the textbook
F), stars, Wilson intervals, participant means and bad or degenerate input."""

import math

import numpy as np
import pandas as pd
import pytest
from scipy import stats as sps

from otgym.study.stats import compare_modes, participant_means, stars, wilson_interval
from tests.study import make_trials

PAPER_MODES = ("manual", "autonomous", "shared")


def _big_effect(seed: int = 1, n: int = 8) -> pd.DataFrame:
    """Times like the paper's: manual 160 +- 8 s, autonomous and shared both 54 +- 1 s.
    Autonomous and shared are equal, so a given seed calls them different with 5 %
    probability (seed 0 does, p = 0.0016); the rate itself is checked by
    ``test_no_effect_gives_the_nominal_false_positive_rate``."""
    rng = np.random.default_rng(seed)
    return make_trials(
        {"manual": rng.normal(160, 8, n), "autonomous": rng.normal(54, 1, n), "shared": rng.normal(54, 1, n)}
    )


def _pair(result: dict, a: str, b: str) -> dict:
    return next(p for p in result["posthoc"] if (p["a"], p["b"]) == (a, b))


def test_big_effect_is_found_and_equal_modes_are_not():
    result = compare_modes(_big_effect(), "time")
    assert result["n_participants"] == 8 and result["note"] == ""
    assert result["anova"]["p_unc"] < 0.001 and result["anova"]["p_gg_corr"] < 0.001
    assert [(p["a"], p["b"]) for p in result["posthoc"]] == [
        ("manual", "autonomous"),
        ("manual", "shared"),
        ("autonomous", "shared"),
    ]
    for other in ("autonomous", "shared"):
        pair = _pair(result, "manual", other)
        assert pair["p_holm"] < 0.001 and pair["stars"] == "***"
        assert pair["T"] > 0  # T is a minus b: manual is slower
        assert pair["dof"] == 7
    pair = _pair(result, "autonomous", "shared")
    assert pair["p_holm"] > 0.05 and pair["stars"] == "ns"


def test_holm_is_the_step_down_correction_of_the_unadjusted_p_values():
    pairs = compare_modes(_big_effect(seed=3), "time")["posthoc"]
    p = np.array([pair["p_unc"] for pair in pairs])
    order = np.argsort(p)
    expected = np.empty_like(p)
    expected[order] = np.minimum(1.0, np.maximum.accumulate(p[order] * (len(p) - np.arange(len(p)))))
    assert [pair["p_holm"] for pair in pairs] == pytest.approx(expected, rel=1e-12)
    assert all(pair["p_holm"] >= pair["p_unc"] for pair in pairs)


@pytest.mark.slow
def test_no_effect_gives_the_nominal_false_positive_rate():
    """Under H0 an exact test rejects at p < 0.05 in 5 % of data sets; 200 seeded data
    sets must give a count inside the binomial(200, 0.05) 99.9 % range. Holm keeps the
    family-wise rate at or below 5 %, so its count must not exceed that range's top."""
    low, high = sps.binom.interval(0.999, 200, 0.05)
    anova_hits = holm_hits = 0
    for seed in range(200):
        rng = np.random.default_rng(1000 + seed)
        subject = rng.normal(0, 5, 8)  # participants differ; modes do not
        result = compare_modes(make_trials({m: 100 + subject + rng.normal(0, 3, 8) for m in PAPER_MODES}), "time")
        anova_hits += result["anova"]["p_unc"] < 0.05
        holm_hits += any(pair["p_holm"] < 0.05 for pair in result["posthoc"])
        assert all(pair["p_holm"] >= pair["p_unc"] for pair in result["posthoc"])
    assert low <= anova_hits <= high
    assert holm_hits <= high


def test_anova_f_matches_the_textbook_formula():
    y = np.array([[4.0, 6.0, 8.0], [5.0, 7.0, 12.0], [3.0, 6.0, 9.0]])  # participants x modes
    n, k = y.shape
    grand = y.mean()
    ss_modes = n * ((y.mean(axis=0) - grand) ** 2).sum()
    ss_subjects = k * ((y.mean(axis=1) - grand) ** 2).sum()
    ss_error = ((y - grand) ** 2).sum() - ss_modes - ss_subjects
    f = (ss_modes / (k - 1)) / (ss_error / ((n - 1) * (k - 1)))
    anova = compare_modes(make_trials({m: y[:, j] for j, m in enumerate(PAPER_MODES)}), "time")["anova"]
    assert (anova["ddof1"], anova["ddof2"]) == (2, 4)
    assert anova["F"] == pytest.approx(f, rel=1e-10)
    assert anova["p_unc"] == pytest.approx(sps.f.sf(f, 2, 4), rel=1e-8)


def test_two_modes_have_no_sphericity_correction_and_match_a_paired_t_test():
    rng = np.random.default_rng(5)
    a, b = rng.normal(10, 1, 8), rng.normal(11, 1, 8)
    result = compare_modes(make_trials({"manual": a, "shared": b}), "time")
    t = sps.ttest_rel(a, b)
    assert math.isnan(result["anova"]["p_gg_corr"]) and result["anova"]["p"] == result["anova"]["p_unc"]
    assert result["anova"]["F"] == pytest.approx(t.statistic**2, rel=1e-9)
    (pair,) = result["posthoc"]
    assert pair["T"] == pytest.approx(t.statistic, rel=1e-9) and pair["p_holm"] == pytest.approx(t.pvalue, rel=1e-9)


@pytest.mark.parametrize(
    "p, expected",
    [
        (0.0, "***"),
        (0.00099, "***"),
        (0.001, "**"),
        (0.0099, "**"),
        (0.01, "*"),
        (0.0499, "*"),
        (0.05, "ns"),
        (1.0, "ns"),
        (math.nan, ""),
        (None, ""),
    ],
)
def test_stars_thresholds(p, expected):
    assert stars(p) == expected


@pytest.mark.parametrize("p", [-0.1, 1.5])
def test_stars_rejects_impossible_p(p):
    with pytest.raises(ValueError, match=r"\[0, 1\]"):
        stars(p)


def test_wilson_interval_textbook_values():
    assert wilson_interval(8, 10) == pytest.approx((0.4902, 0.9433), abs=1e-4)
    assert wilson_interval(0, 10) == pytest.approx((0.0, 0.2775), abs=1e-4)
    low, high = wilson_interval(8, 10, confidence=0.99)
    assert low < 0.4902 and high > 0.9433
    assert all(math.isnan(v) for v in wilson_interval(0, 0))


@pytest.mark.parametrize("args", [(11, 10), (-1, 10), (5, 10, 1.0), (5, 10, 0.0)])
def test_wilson_interval_rejects_bad_input(args):
    with pytest.raises(ValueError):
        wilson_interval(*args)


def test_participant_means_pool_success_and_average_times_of_goals_only():
    trials = make_trials({"manual": [100.0, 200.0], "shared": [50.0, 60.0]})
    extra = trials.iloc[[0]].assign(
        obstacles_encountered=3, obstacles_avoided=0, completion_time_s=999.0, reached_goal=False
    )
    trials = pd.concat([trials, extra], ignore_index=True)
    success = participant_means(trials, "success").set_index(["participant", "mode"])["value"]
    assert success[(0, "manual")] == pytest.approx(10 / 13)  # pooled, not the mean of 1.0 and 0.0
    assert success[(1, "shared")] == 1.0
    time = participant_means(trials, "time").set_index(["participant", "mode"])["value"]
    assert time[(0, "manual")] == 100.0  # the trial that missed the goal does not count
    assert list(participant_means(trials, "time")["mode"]) == ["manual", "manual", "shared", "shared"]


def test_participant_means_are_nan_without_goals_or_obstacles():
    trials = make_trials({"manual": [100.0, 200.0], "shared": [50.0, 60.0]}, encountered=0)
    trials.loc[0, "reached_goal"] = False
    assert participant_means(trials, "success")["value"].isna().all()
    assert math.isnan(participant_means(trials, "time")["value"].iloc[0])


def test_participants_without_a_value_in_every_mode_are_dropped_with_a_note():
    trials = _big_effect(n=8)
    trials.loc[(trials["participant"] == 3) & (trials["mode"] == "shared"), "reached_goal"] = False
    result = compare_modes(trials, "time")
    assert result["n_participants"] == 7
    assert result["anova"]["ddof2"] == 2 * 6
    assert "participant 3: shared" in result["note"] and "reached the goal" in result["note"]


def test_identical_success_everywhere_gives_nan_and_a_note_not_significance():
    result = compare_modes(make_trials({m: np.full(8, 50.0) for m in PAPER_MODES}), "success")
    assert math.isnan(result["anova"]["F"]) and math.isnan(result["anova"]["p"])
    assert all(math.isnan(p["p_holm"]) and p["stars"] == "" for p in result["posthoc"])
    assert "undefined" in result["note"]


def test_a_pair_with_constant_differences_is_nan_and_left_out_of_holm():
    rng = np.random.default_rng(2)
    avoided = {"manual": np.full(8, 9), "autonomous": rng.integers(4, 8, 8), "shared": np.full(8, 10)}
    result = compare_modes(make_trials({m: np.full(8, 50.0) for m in PAPER_MODES}, avoided), "success")
    constant = _pair(result, "manual", "shared")
    assert math.isnan(constant["T"]) and math.isnan(constant["p_holm"]) and constant["stars"] == ""
    assert "manual vs shared" in result["note"]
    defined = [p for p in result["posthoc"] if p is not constant]
    p = sorted(pair["p_unc"] for pair in defined)
    assert sorted(pair["p_holm"] for pair in defined) == pytest.approx([min(1, 2 * p[0]), min(1, max(2 * p[0], p[1]))])
    assert result["anova"]["F"] > 0 and result["anova"]["p"] < 0.05


def test_too_few_complete_participants_give_nan_not_an_exception():
    trials = make_trials({"manual": [100.0, 200.0], "shared": [50.0, 60.0]})
    trials.loc[0, "reached_goal"] = False
    result = compare_modes(trials, "time")
    assert result["n_participants"] == 1 and math.isnan(result["anova"]["p"])
    assert "no test is possible with n < 2 (n = 1 participant(s)" in result["note"]


@pytest.mark.parametrize(
    "change, message",
    [
        (lambda t: t.drop(columns="completion_time_s"), "completion_time_s"),
        (lambda t: t.iloc[0:0], "no rows"),
        (lambda t: t.assign(obstacles_avoided=t["obstacles_encountered"] + 1), "obstacles_avoided <="),
    ],
)
def test_bad_input_raises_a_clear_value_error(change, message):
    metric = "success" if "obstacles" in message else "time"
    with pytest.raises(ValueError, match=message):
        compare_modes(change(_big_effect()), metric)


def test_one_participant_or_one_mode_gives_no_test_and_says_why():
    one_person = compare_modes(_big_effect().query("participant == 0"), "time")
    assert one_person["n_participants"] == 1 and all(math.isnan(v) for v in one_person["anova"].values())
    assert all(math.isnan(pair["p_holm"]) for pair in one_person["posthoc"]) and "n < 2" in one_person["note"]
    one_mode = compare_modes(_big_effect().query("mode == 'manual'"), "time")
    assert one_mode["modes"] == ["manual"] and one_mode["posthoc"] == [] and math.isnan(one_mode["anova"]["p"])
    assert "only one mode (manual)" in one_mode["note"]


def test_unknown_metric_raises():
    with pytest.raises(ValueError, match="metric"):
        compare_modes(_big_effect(), "speed")


def test_anova_survives_a_sample_on_which_mauchlys_test_fails():
    """Two participants with times in every mode (as a seed-2 run of the experiment gave):
    pingouin's Mauchly test divides by zero there, which used to abort the experiment
    before its summary. The ANOVA falls back to statsmodels' uncorrected AnovaRM, says
    so, and that fallback gives the same uncorrected F and p as pingouin where both run."""
    import otgym.study.stats as st

    two = make_trials({"manual": [145.37, 146.42], "autonomous": [60.72, 60.73], "shared": [88.79, 148.77]})
    result = compare_modes(two, "time")
    assert np.isfinite(result["anova"]["F"]) and math.isnan(result["anova"]["p_gg_corr"])
    assert result["anova"]["p"] == result["anova"]["p_unc"] and "Mauchly" in result["note"]
    big = compare_modes(_big_effect(), "time")
    fallback = st._anova_uncorrected(participant_means(_big_effect(), "time"), [])
    assert fallback["F"] == pytest.approx(big["anova"]["F"], rel=1e-9)
    assert fallback["p_unc"] == pytest.approx(big["anova"]["p_unc"], rel=1e-6)
