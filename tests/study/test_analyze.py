"""otgym.study.analyze and questionnaire_stats: scores written as hand-computed, panels (c, d)
drawn only from recorded answers, Holm over a whole panel, and bad folders refused."""

import json
import math

import numpy as np
import pandas as pd
import pingouin as pg
import pytest

from otgym.runtime.trials import TRIAL_COLUMNS
from otgym.study import figures
from otgym.study.analyze import TRIALS_COLUMNS, analyze, load_study
from otgym.study.figures import fig8_figure
from otgym.study.questionnaire_stats import TLX_MEASURES, UEQ_MEASURES, compare_measures
from otgym.study.questionnaires import TLX_SUBSCALES, append_answers, participant_measures, weights_from_choices
from tests.study import RATINGS, UEQ_RAW, make_trials, ranked_choices, rows
from tests.study.fig8_content import brackets, group_bars, group_dots, group_position, mode_bars

PARTICIPANTS = ("P1", "P2", "P3", "P4")
EXPECTED_SCORES = {  # participant, mode: raw TLX, weighted TLX, UEQ-S pragmatic, hedonic, overall
    # P1 manual: trial 0 raw 270/6 = 45, weighted 850/15, UEQ 2, -0.5, 0.75; trial 1 raw 10, unweighted, UEQ 0
    ("P1", "manual"): (27.5, 850 / 15, 1.0, -0.25, 0.375),
    ("P1", "shared"): (20.0, 20.0, 3.0, 3.0, 3.0),  # all ratings 20, all UEQ-S 7
    **{(p, "manual"): (60 + 5 * i, 60 + 5 * i, -1.0, -1.0, -1.0) for i, p in enumerate(PARTICIPANTS) if i},
    **{(p, "shared"): (20 + 5 * i, 20 + 5 * i, 2.0, 2.0, 2.0) for i, p in enumerate(PARTICIPANTS) if i},
}
SCORE_INDEX = {"raw_tlx": 0, "weighted_tlx": 1, "ueq_pragmatic": 2, "ueq_hedonic": 3, "ueq_overall": 4}
"""Where each measure sits in ``EXPECTED_SCORES``' tuples."""


def write_trials(folder, participants=PARTICIPANTS, trials=2):
    """Every participant: ``trials`` trials in manual, autonomous and shared; shared and
    autonomous faster than manual."""
    times = {
        mode: [base + 3 * i for i, _ in enumerate(participants)]
        for mode, base in (("manual", 160), ("autonomous", 54), ("shared", 50))
    }
    frame = make_trials(times, {mode: [9 - i % 2 for i, _ in enumerate(participants)] for mode in times})
    frame["participant"] = frame["participant"].map(dict(enumerate(participants)))
    frame = pd.concat([frame.assign(trial=t, scenario=t) for t in range(trials)], ignore_index=True)
    folder.mkdir(parents=True, exist_ok=True)
    frame.to_csv(folder / "trials.csv", index=False)


def write_answers(folder, ueq=True):
    """The answers behind ``EXPECTED_SCORES`` (no answers after autonomous trials)."""
    weights = weights_from_choices(ranked_choices())
    answers = (
        rows("P1", "manual", 0, RATINGS, weights, UEQ_RAW if ueq else None)
        + rows("P1", "manual", 1, dict.fromkeys(TLX_SUBSCALES, 10), None, (4,) * 8 if ueq else None)
        + rows("P1", "shared", 0, dict.fromkeys(TLX_SUBSCALES, 20), weights, (7,) * 8 if ueq else None)
    )
    for i, p in enumerate(PARTICIPANTS[1:], start=1):
        answers += rows(p, "manual", 0, dict.fromkeys(TLX_SUBSCALES, 60 + 5 * i), weights, (3,) * 8 if ueq else None)
        answers += rows(p, "shared", 1, dict.fromkeys(TLX_SUBSCALES, 20 + 5 * i), weights, (6,) * 8 if ueq else None)
    append_answers(folder / "questionnaires.csv", answers)


def test_trials_columns_are_the_experiments():
    assert TRIALS_COLUMNS == TRIAL_COLUMNS


@pytest.mark.slow
def test_scores_figure_and_summary_with_answers(tmp_path, monkeypatch):
    """Two folders (P1, P2 | P3, P4): the scores CSV matches hand computation, the figure
    has four panels, summary.md has the questionnaire table and tests. The figure shows
    them (its matplotlib objects, ``tests.study.fig8_content``): in (a, b) the per-mode
    means of the participants' values (each folder's two: avoided 0.9 and 0.8, 85 %;
    times base and base + 3 s, base + 1.5 s); in (c, d) one bar per measure and mode at the mean of the
    hand-computed scores (raw TLX 59.375 manual, 27.5 shared...), one dot per participant
    at their score; brackets exactly on the pairs whose Holm p is below 0.05, with their
    stars. Catches panels fed the wrong measure or mode, scores swapped between modes,
    brackets not from analysis.json's tests."""
    drawn = []

    def keep_figure(*arguments):
        drawn.append(fig8_figure(*arguments))
        return drawn[-1]

    monkeypatch.setattr(figures, "fig8_figure", keep_figure)
    first, second = tmp_path / "day1", tmp_path / "day2"
    write_trials(first, PARTICIPANTS[:2])
    write_trials(second, PARTICIPANTS[2:])
    answers_all = tmp_path / "all"
    write_answers(answers_all)
    answers = pd.read_csv(answers_all / "questionnaires.csv", dtype={"participant": str})
    for folder, people in ((first, PARTICIPANTS[:2]), (second, PARTICIPANTS[2:])):
        answers[answers["participant"].isin(people)].to_csv(folder / "questionnaires.csv", index=False)
    result = analyze([first, second], tmp_path / "out")
    scores = pd.read_csv(tmp_path / "out" / "questionnaire_scores.csv", dtype={"participant": str})
    assert list(scores.columns) == [
        "participant",
        "mode",
        "raw_tlx",
        "weighted_tlx",
        "ueq_pragmatic",
        "ueq_hedonic",
        "ueq_overall",
    ]
    got = {(row.participant, row.mode): tuple(row[2:]) for row in scores.itertuples(index=False)}
    assert got.keys() == EXPECTED_SCORES.keys()
    for key, expected in EXPECTED_SCORES.items():
        assert got[key] == pytest.approx(expected), key
    assert result["panels"] == [
        "(a) Success rate",
        "(b) Task completion time",
        "(c) NASA-TLX (lower: less workload)",
        "(d) UEQ-S (higher: better)",
    ]
    assert json.loads((tmp_path / "out" / "analysis.json").read_text())["panels"] == result["panels"]
    summary = (tmp_path / "out" / "summary.md").read_text()
    assert "| raw_tlx | 59.38 ± 21.64 (n = 4) | 27.50 ± 6.45 (n = 4) |" in summary  # (27.5+65+70+75)/4, (20+25+30+35)/4
    assert "raw_tlx: manual vs shared (n = 4)" in summary and "ueq_overall: manual vs shared" in summary
    assert (tmp_path / "out" / "fig8.png").stat().st_size > 0  # written (its pixels: tests/study/test_figures.py)
    (figure,) = drawn
    success_ax, time_ax, tlx_ax, ueq_ax = figure.axes
    assert mode_bars(success_ax) == pytest.approx({"manual": 85.0, "autonomous": 85.0, "shared": 85.0})
    assert mode_bars(time_ax) == pytest.approx({"manual": 161.5, "autonomous": 55.5, "shared": 51.5})
    modes = ["manual", "shared"]
    for ax, measures in ((tlx_ax, TLX_MEASURES), (ueq_ax, UEQ_MEASURES)):
        labels = [tick.get_text() for tick in ax.get_xticklabels()]
        assert len(labels) == len(measures)
        measure_of = dict(zip(labels, measures))
        bars, dots = group_bars(ax, modes), group_dots(ax, modes)
        assert set(bars) == set(dots) == {(label, mode) for label in labels for mode in modes}
        for (label, mode), height in bars.items():
            if measure_of[label] in SCORE_INDEX:
                scores = [EXPECTED_SCORES[(p, mode)][SCORE_INDEX[measure_of[label]]] for p in PARTICIPANTS]
                assert height == pytest.approx(sum(scores) / len(scores)), (label, mode)
                np.testing.assert_allclose(dots[(label, mode)], np.sort(scores))
            assert len(dots[(label, mode)]) == len(PARTICIPANTS)
        key = "tlx" if measures == TLX_MEASURES else "ueq"
        label_of = {measure: label for label, measure in measure_of.items()}
        significant = {
            frozenset(((label_of[t["measure"]], t["a"]), (label_of[t["measure"]], t["b"]))): t["stars"]
            for t in result["questionnaire_tests"][key]["tests"]
            if t["p_holm"] < 0.05
        }
        assert significant and brackets(ax, group_position(ax, modes)) == significant, key
    assert {"Raw\nTLX", "Weighted\nTLX"} <= {tick.get_text() for tick in tlx_ax.get_xticklabels()}


@pytest.mark.slow
def test_without_answers_only_panels_a_and_b(tmp_path):
    write_trials(tmp_path / "s")
    result = analyze([tmp_path / "s"], tmp_path / "out")
    assert result["panels"] == ["(a) Success rate", "(b) Task completion time"]
    assert "No questionnaire answers were recorded" in (tmp_path / "out" / "summary.md").read_text()
    assert pd.read_csv(tmp_path / "out" / "questionnaire_scores.csv").empty


@pytest.mark.slow
def test_tlx_only_draws_panel_c_alone(tmp_path):
    write_trials(tmp_path / "s")
    write_answers(tmp_path / "s", ueq=False)
    result = analyze([tmp_path / "s"], tmp_path / "out")
    assert result["panels"][2:] == ["(c) NASA-TLX (lower: less workload)"]
    assert pd.read_csv(tmp_path / "out" / "questionnaire_scores.csv")["ueq_overall"].isna().all()


def test_holm_runs_over_the_whole_panel_and_needs_two_pairs_of_answers():
    weights = weights_from_choices(ranked_choices())
    answers = []
    for i, p in enumerate(PARTICIPANTS):
        answers += rows(
            p, "manual", 0, {**dict.fromkeys(TLX_SUBSCALES, 50 + 5 * i), "mental": 80 - 5 * (i % 2)}, weights
        )
        answers += rows(p, "shared", 0, dict.fromkeys(TLX_SUBSCALES, 20 + 10 * (i % 3)), weights)
    answers += rows("P9", "mpc", 0, RATINGS)  # one participant: no test against mpc
    result = compare_measures(participant_measures(pd.DataFrame(answers)), TLX_MEASURES)
    defined = [t for t in result["tests"] if not math.isnan(t["p_unc"])]
    assert len(defined) == 8 and all(t["n"] == 4 for t in defined)
    _, expected = pg.multicomp([t["p_unc"] for t in defined], method="holm")
    assert [t["p_holm"] for t in defined] == pytest.approx(list(expected))
    assert min(t["p_holm"] for t in defined) == pytest.approx(8 * min(t["p_unc"] for t in defined))
    assert "fewer than 2 participants" in result["note"] and "mpc" in result["note"]


@pytest.mark.parametrize(
    "damage, message",
    [
        (lambda f: f.drop(columns="detached"), r"lacks column\(s\) \['detached'\]"),
        (lambda f: f.assign(success=1.5), "success must lie in"),
        (lambda f: f.assign(obstacles_avoided=f["obstacles_encountered"] + 1), "exceeds"),
        (lambda f: f.assign(completion_time_s=-1.0), "completion_time_s"),
        (lambda f: f.assign(trap_losses=0.5), "trap_losses"),
        (lambda f: f.assign(reached_goal="maybe"), "reached_goal"),
    ],
)
def test_bad_trials_are_refused(tmp_path, damage, message):
    write_trials(tmp_path / "s")
    frame = pd.read_csv(tmp_path / "s" / "trials.csv")
    damage(frame).to_csv(tmp_path / "s" / "trials.csv", index=False)
    with pytest.raises(ValueError, match=message):
        load_study([tmp_path / "s"])


def test_the_same_trial_twice_across_folders_and_orphan_answers_are_refused(tmp_path):
    write_trials(tmp_path / "a", PARTICIPANTS[:2])
    write_trials(tmp_path / "b", PARTICIPANTS[1:])
    with pytest.raises(ValueError, match="participant P2, mode manual, trial 0 appears twice"):
        load_study([tmp_path / "a", tmp_path / "b"])
    write_answers(tmp_path / "a")  # answers for P3, P4, who are not in a's trials
    with pytest.raises(ValueError, match=r"answers \(participant, mode, trial\) \('P3'"):
        load_study([tmp_path / "a"])
    with pytest.raises(FileNotFoundError, match="no study folder"):
        load_study([tmp_path / "missing"])
    (tmp_path / "empty").mkdir()
    with pytest.raises(FileNotFoundError, match="has no trials.csv"):
        load_study([tmp_path / "empty"])
