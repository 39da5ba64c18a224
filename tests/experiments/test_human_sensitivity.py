"""``otgym experiment human-sensitivity``: its arithmetic on a synthetic trial table, its
parameter list, and a tiny run end to end from the command line."""

import math

import numpy as np
import pandas as pd
import pytest

from otgym.experiments.human_sensitivity import (
    ASSUMED,
    ASSUMED_TASK,
    parse_parameters,
    summarise,
    variants,
)
from tests.otgym_cli import run_otgym


def _trials(rows):
    return pd.DataFrame(rows, columns=["parameter", "scale", "participant", "mode", "success"])


def test_d_is_shared_minus_manual_per_participant_and_its_move_is_paired():
    """Two participants. Baseline: participant 0 manual 0.5 / shared 1.0 (d 0.5),
    participant 1 manual 1.0 / shared 0.5 and 1.0 over two trials (d -0.25): (d) is
    0.125. Parameter x at 0.5x: d 0.0 and -0.5, each 0.5 and 0.25 below its own
    baseline: the move is -0.375 with a paired interval of half-width t(0.975, 1) *
    0.177 / sqrt(2) = 1.588; a trial with no obstacle met (success NaN) is left out."""
    rows = [
        ("baseline", 1.0, 0, "manual", 0.5),
        ("baseline", 1.0, 0, "shared", 1.0),
        ("baseline", 1.0, 0, "shared", math.nan),
        ("baseline", 1.0, 1, "manual", 1.0),
        ("baseline", 1.0, 1, "shared", 0.5),
        ("baseline", 1.0, 1, "shared", 1.0),
        ("x", 0.5, 0, "manual", 1.0),
        ("x", 0.5, 0, "shared", 1.0),
        ("x", 0.5, 1, "manual", 1.0),
        ("x", 0.5, 1, "shared", 0.5),
    ]
    summary = summarise(_trials(rows)).set_index("scale")
    assert list(summary.parameter) == ["x", "x"]
    assert summary.loc[1.0, "d"] == pytest.approx(0.125)
    assert summary.loc[1.0, "manual_success"] == pytest.approx(0.75)
    assert summary.loc[0.5, "d"] == pytest.approx(-0.25)
    assert summary.loc[0.5, "d_move"] == pytest.approx(-0.375)
    half = summary.loc[0.5, "d_move_ci_high"] - summary.loc[0.5, "d_move"]
    assert half == pytest.approx(12.706 * np.std([-0.5, -0.25], ddof=1) / math.sqrt(2), rel=1e-3)


def test_parameters_are_the_assumed_ones_each_once():
    assert parse_parameters("all") == list(ASSUMED)
    assert parse_parameters("motor") + parse_parameters("task") == list(ASSUMED)
    assert "carry_speed_um_s" in ASSUMED_TASK and "bimanual" not in ASSUMED
    assert "reaction_time_s" not in ASSUMED and "tremor_rms_mm" not in ASSUMED  # sourced
    assert parse_parameters("hurry_factor, population_cv") == ["hurry_factor", "population_cv"]
    for bad in ("", "reaction_time_s", "hurry_factor,hurry_factor", "no_such"):
        with pytest.raises(ValueError):
            parse_parameters(bad)
    assert variants(["a"]) == [("baseline", 1.0), ("a", 0.5), ("a", 1.5)]


@pytest.mark.slow
def test_tiny_run_writes_every_file(tmp_path):
    """2 participants x 1 trial, a motor and a task parameter, cut at 2 s: fails if a
    file is missing, a variant or trial is lost, variants do not share their scenarios,
    or the development seed is not said."""
    out = tmp_path / "sensitivity"
    run = run_otgym(
        ["experiment", "human-sensitivity", "--participants", "2", "--trials", "1"]
        + ["--parameters", "signal_dependent_noise,hurry_factor", "--time-limit-s", "2", "--out", str(out)]
    )
    assert run.returncode == 0, run.stderr
    for name in ("sensitivity.csv", "sensitivity.md", "sensitivity.png", "trials.csv"):
        assert (out / name).stat().st_size > 0, name
    trials = pd.read_csv(out / "trials.csv")
    assert len(trials) == 5 * 2 * 1 * 2  # variants x participants x trials x modes
    assert trials.groupby("variant").scenario.apply(lambda s: tuple(sorted(s))).nunique() == 1
    summary = pd.read_csv(out / "sensitivity.csv")
    assert list(zip(summary.parameter, summary.scale)) == [
        (name, scale) for name in ("signal_dependent_noise", "hurry_factor") for scale in (0.5, 1.0, 1.5)
    ]
    assert "% of trials done" in run.stdout and "development seed: seed 90" in run.stdout
    assert (out / "sensitivity.md").read_text().startswith("**development seed")
