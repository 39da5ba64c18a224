"""``otgym experiment human-sensitivity``: the design over the assumptions' ranges, the
per-sample outputs on a synthetic trial table, and a tiny Morris screening of the real
model that must rank a parameter that decides (b) above one the model never reads."""

import math

import numpy as np
import pandas as pd
import pytest

from otgym.experiments.human_sensitivity.config import DUMMY, check_arguments, parse_parameters, size_of
from otgym.experiments.human_sensitivity.run import (
    analyse,
    deciding,
    design,
    run_design,
    sample_outputs,
    sample_settings,
)
from otgym.human.assumptions import ASSUMPTIONS, by_label
from otgym.human.params import POPULATION_CV, HumanParams
from otgym.human.participant_task import ParticipantTask


def test_parameters_are_every_assumption_each_once():
    assert parse_parameters("all") == [a.label for a in ASSUMPTIONS]
    assert "carry_speed_um_s" in parse_parameters("all") and "cv_tremor_rms_mm" in parse_parameters("all")
    assert "display_latency_s" in parse_parameters("all") and "reaction_time_s" not in parse_parameters("all")
    assert parse_parameters("hurry_factor, cv_reaction_time_s") == ["hurry_factor", "cv_reaction_time_s"]
    for bad in ("", "reaction_time_s", "hurry_factor,hurry_factor", "no_such"):
        with pytest.raises(ValueError):
            parse_parameters(bad)
    for bad in (("sobol", 6), ("morris", 1), ("latin", 4)):
        with pytest.raises(ValueError):
            check_arguments(*bad, participants=1, trials=1, seed=0)


def test_the_design_spans_each_range_and_sets_the_model_from_a_sample():
    labels = ["carry_speed_um_s", "cv_reaction_time_s", "correction_jitter_fraction", "display_latency_s"]
    points = design("morris", labels, 3, seed=1)
    assert points.shape == (size_of("morris", 3, len(labels) + 1), len(labels) + 1)
    table = by_label()
    for j, label in enumerate(labels):
        assert points[:, j].min() >= table[label].low and points[:, j].max() <= table[label].high
    assert design("sobol", labels, 4, seed=1).shape == (size_of("sobol", 4, len(labels) + 1), len(labels) + 1)
    mean, cv, task, latency = sample_settings(np.array([3.0, 0.2, 0.3, 0.05, 0.9]), labels)
    assert task == ParticipantTask(carry_speed_um_s=3.0)
    assert cv == {**POPULATION_CV, "reaction_time_s": 0.2}
    assert mean == HumanParams(correction_jitter_fraction=0.3) and latency == 0.05


def test_outputs_pool_success_per_participant_and_extrapolate_a_cut_trial_to_the_goal():
    """Sample 0: manual 100 s, and a trial cut by the 60 s limit half way along the
    300 um route (time to goal 120 s at its pace): mean 110 s; shared 80 s twice: (b) =
    1.375. Success pooled per participant: manual 3 of 4 and 1 of 2 obstacles (0.75 and
    0.5, mean 0.625), shared all: (d) = 0.375. Sample 1 met no obstacle in shared mode:
    (d) NaN; its trial that ended by a trap loss after 8 s is left out of the time."""
    columns = ["sample", "participant", "mode", "completion_time_s", "reached_goal", "arc_reached_um"]
    columns += ["obstacles_avoided", "obstacles_encountered", "success"]
    rows = [
        (0, 0, "manual", 100.0, True, 300.0, 3, 4, 0.75),
        (0, 1, "manual", 60.0, False, 150.0, 1, 2, 0.5),
        (0, 0, "shared", 80.0, True, 300.0, 4, 4, 1.0),
        (0, 1, "shared", 80.0, True, 300.0, 2, 2, 1.0),
        (1, 0, "manual", 100.0, True, 300.0, 1, 1, 1.0),
        (1, 0, "shared", 50.0, True, 300.0, 0, 0, math.nan),
        (1, 0, "manual", 8.0, False, 2.0, 0, 0, math.nan),  # a trap loss at 8 s: no time
    ]
    trials = pd.DataFrame(rows, columns=columns).assign(route_um=300.0)
    out = sample_outputs(trials, 2, 60.0).set_index("sample")
    assert out.loc[0, "manual_time_s"] == pytest.approx(110.0)
    assert out.loc[0, "b"] == pytest.approx(1.375) and out.loc[0, "d"] == pytest.approx(0.375)
    assert out.loc[1, "b"] == pytest.approx(2.0) and math.isnan(out.loc[1, "d"])


def test_morris_on_a_known_function_ranks_what_it_reads_above_the_dummy():
    """The analysis alone: (b) = 2 x the first parameter's share of its range, (d) reads
    nothing: (b)'s mu* is 2 (the effect of the whole range), the second parameter's and
    the dummy's 0; nothing decides (d)."""
    labels = ["carry_speed_um_s", "horizon_s"]
    points = design("morris", labels, 4, seed=0)
    low, high = by_label()["carry_speed_um_s"].low, by_label()["carry_speed_um_s"].high
    outputs = pd.DataFrame({"b": 2 * (points[:, 0] - low) / (high - low), "d": np.zeros(len(points))})
    indices = analyse("morris", points, outputs, labels, seed=0).set_index(["item", "parameter"])
    assert indices.loc[("b", "carry_speed_um_s"), "mu_star"] == pytest.approx(2.0)
    assert indices.loc[("b", "horizon_s"), "mu_star"] == pytest.approx(0.0)
    assert indices.loc[("b", DUMMY), "mu_star"] == pytest.approx(0.0)
    assert deciding(indices.reset_index()) == {"b": ["carry_speed_um_s"], "d": []}


@pytest.mark.slow
def test_morris_on_the_model_ranks_the_manual_pace_above_the_dummy():
    """The real model, trials cut at 20 s (each trial's time to the goal extrapolated at
    the pace it kept), 1 participant, 2 trajectories over the manual pace (1-5 um/s) and
    the dummy: the manual pace decides (b), manual time over shared time, far above
    what noise gives the dummy, and the samples at the slowest pace take longer by hand
    than those at the fastest. Fails if the pace did not reach the participants, or the samples were mixed
    up."""
    labels = ["carry_speed_um_s"]
    points = design("morris", labels, 2, seed=3)
    trials = run_design(points, labels, 1, 1, seed=3, report=lambda line: None, time_limit_s=20.0)
    assert len(trials) == len(points) * 2 and (trials.arc_reached_um > 5.0).all(), trials.arc_reached_um
    outputs = sample_outputs(trials, len(points), 20.0)
    indices = analyse("morris", points, outputs, labels, seed=3).set_index(["item", "parameter"])
    pace, dummy = indices.loc[("b", "carry_speed_um_s"), "mu_star"], indices.loc[("b", DUMMY), "mu_star"]
    assert pace > 3 * dummy and pace > 0.5, (pace, dummy, outputs)
    slowest, fastest = points[:, 0] == points[:, 0].min(), points[:, 0] == points[:, 0].max()
    assert outputs.manual_time_s[slowest].min() > outputs.manual_time_s[fastest].max(), outputs
