"""``otgym experiment calibrate-scenarios``: its parsing, its pooled rates with Wilson
intervals, and a tiny end-to-end sweep (2 values x 2 scenarios of development seed 90)."""

import math

import pandas as pd
import pytest
from scipy.stats import fisher_exact

from otgym.experiments.calibration.run import TARGET_AVOIDED, parse_values, summarise
from otgym.study.stats import wilson_interval
from tests.otgym_cli import run_otgym


def test_parse_values():
    assert parse_values("timing_jitter_s=8, 15,20") == ("timing_jitter_s", (8.0, 15.0, 20.0))
    assert parse_values("obstacle_speed_um_s=2") == ("obstacle_speed_um_s", (2.0,))
    for bad, word in [
        ("n_obstacles=2,3", "NAME"),  # changes the scene, not the tracks
        ("timing_jitter_s", "NAME"),
        ("timing_jitter_s=", "finite"),
        ("timing_jitter_s=1,inf", "finite"),
        ("timing_jitter_s=4,4", "twice"),
        ("obstacle_speed_um_s=0", "obstacle_speed_um_s"),  # the configuration refuses it
    ]:
        with pytest.raises(ValueError, match=word):
            parse_values(bad)


def test_summary_pools_obstacles_per_value():
    """Fails if obstacles are averaged per trial instead of pooled, if the intervals are
    not Wilson's, or if a value with nothing met claims the target."""
    frame = pd.DataFrame(
        {
            "parameter": "timing_jitter_s",
            "value": [8.0, 8.0, 15.0, 15.0, 30.0, 40.0],
            "obstacles_encountered": [4, 1, 3, 4, 8, 0],
            "obstacles_avoided": [0, 1, 2, 2, 0, 0],
            "reached_goal": [True, False, True, True, True, True],
            "completion_time_s": [70.0, 300.0, 66.0, 68.0, 60.0, 60.0],
        }
    )
    summary = summarise(frame).set_index("value")
    assert summary.loc[8.0, "avoided_rate"] == 1 / 5  # pooled; the mean of per-trial rates would be 0.5
    assert (summary.loc[8.0, "avoided_rate_ci_low"], summary.loc[8.0, "avoided_rate_ci_high"]) == wilson_interval(1, 5)
    assert summary.loc[8.0, "obstacles_collided"] == 4 and summary.loc[8.0, "goals_reached"] == 1
    assert summary.loc[15.0, "avoided_rate"] == 4 / 7 and summary.loc[15.0, "target_in_ci"]
    assert summary.loc[8.0, "target_in_ci"]  # Wilson's [4 %, 62 %] for 1 of 5
    assert not summary.loc[30.0, "target_in_ci"]  # Wilson's [0 %, 32 %] for 0 of 8
    assert math.isnan(summary.loc[40.0, "avoided_rate"]) and not summary.loc[40.0, "target_in_ci"]
    assert (summary.target_avoided == TARGET_AVOIDED).all() and TARGET_AVOIDED == 0.59


@pytest.mark.slow
def test_tiny_sweep_end_to_end(tmp_path):
    """timing_jitter_s 0 against 200 s on the same 2 scenarios: with no spread every
    obstacle crosses the route when an assembly at the assumed pace gets there, with a
    very wide one most cross long before or after, so the autonomous mode must avoid
    fewer at 0 s (Fisher's exact test, one-sided p < 0.05 on the pooled obstacles: a
    sweep that ignored the parameter or reversed it fails). Also fails if a file is
    missing, the values do not share their scenarios, or the output does not say that
    the seed is a development seed."""
    out = tmp_path / "calibration"
    run = run_otgym(
        ["experiment", "calibrate-scenarios", "--values", "timing_jitter_s=0,200", "--trials", "2"]
        + ["--time-limit-s", "42", "--out", out]
    )
    assert run.returncode == 0, run.stderr
    for name in ("calibration.csv", "calibration_trials.csv", "calibration.md", "calibration.png"):
        assert (out / name).stat().st_size > 0, name
    trials = pd.read_csv(out / "calibration_trials.csv")
    assert set(trials["mode"]) == {"autonomous"} and len(trials) == 4
    assert trials.groupby("value")["scenario"].apply(tuple).tolist() == [(900000, 900001)] * 2
    summary = pd.read_csv(out / "calibration.csv").set_index("value")
    assert (summary.obstacles_avoided <= summary.obstacles_encountered).all() and (summary.trials == 2).all()
    table = [[row.obstacles_avoided, row.obstacles_collided] for row in summary.loc[[0.0, 200.0]].itertuples()]
    assert fisher_exact(table, alternative="less").pvalue < 0.05, table
    md = (out / "calibration.md").read_text()
    assert md.startswith("**development seed: seed 90") and "--seed 90" in md and "59%" in md
    assert "calibration is development" in run.stdout
