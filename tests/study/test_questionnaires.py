"""otgym.study.questionnaires: the published scoring of NASA-TLX (raw and weighted, weights
from the 15 pairwise choices) and UEQ-S (pragmatic, hedonic, overall) against hand
computation, and an answer file that refuses bad rows and then writes nothing."""

import math

import pandas as pd
import pytest

from otgym.study.questionnaires import (
    QUESTIONNAIRE_COLUMNS,
    SCORE_COLUMNS,
    TLX_PAIRS,
    TLX_SUBSCALES,
    UEQ_ITEMS,
    append_answers,
    read_answers,
    score,
    weights_from_choices,
)
from tests.study import RATINGS, UEQ_RAW, ranked_choices, rows


def test_the_fifteen_pairs_cover_every_pair_once():
    assert len(TLX_PAIRS) == 15 and len(set(map(frozenset, TLX_PAIRS))) == 15
    assert all(sum(name in pair for pair in TLX_PAIRS) == 5 for name in TLX_SUBSCALES)


def test_weights_from_choices_count_how_often_each_subscale_was_chosen():
    weights = weights_from_choices(ranked_choices())
    assert weights == {
        "weight_mental": 5,
        "weight_effort": 4,
        "weight_temporal": 3,
        "weight_frustration": 2,
        "weight_performance": 1,
        "weight_physical": 0,
    }
    choices = ranked_choices()
    del choices[TLX_PAIRS[3]]
    with pytest.raises(ValueError, match="15 TLX pairs"):
        weights_from_choices(choices)
    with pytest.raises(ValueError, match="one of its two"):
        weights_from_choices({**ranked_choices(), ("mental", "physical"): "effort"})


def test_ueq_s_items_are_the_published_ones_in_order():
    assert UEQ_ITEMS[0] == ("obstructive", "supportive") and UEQ_ITEMS[3] == ("confusing", "clear")
    assert UEQ_ITEMS[4] == ("boring", "exciting") and UEQ_ITEMS[7] == ("usual", "leading edge")


def test_scores_match_hand_computation():
    """Trial 0: weighted (raw 270/6 = 45, weighted (70*5 + 60*4 + 50*3 + 40*2 + 30*1 + 20*0)/15
    = 850/15) with the UEQ-S set above; trial 1: unweighted, every rating 10, no UEQ-S.
    Averaged over the trials that have a score: raw (45 + 10)/2, weighted 850/15 alone."""
    answers = pd.DataFrame(
        rows(ratings=RATINGS, weights=weights_from_choices(ranked_choices()), ueq=UEQ_RAW)
        + rows(trial=1, ratings=dict.fromkeys(TLX_SUBSCALES, 10))
        + rows(mode="shared", ratings=RATINGS, ueq=(4,) * 8)
    )
    scores = score(answers).set_index("mode")
    assert list(score(answers).columns) == SCORE_COLUMNS
    manual, shared = scores.loc["manual"], scores.loc["shared"]
    assert manual["raw_tlx"] == pytest.approx(27.5) and manual["weighted_tlx"] == pytest.approx(850 / 15)
    assert (manual["ueq_pragmatic"], manual["ueq_hedonic"], manual["ueq_overall"]) == pytest.approx((2.0, -0.5, 0.75))
    assert shared["raw_tlx"] == pytest.approx(45.0) and math.isnan(shared["weighted_tlx"])
    assert shared["ueq_overall"] == 0.0


def test_answers_round_trip_and_the_header_is_written_once(tmp_path):
    path = tmp_path / "questionnaires.csv"
    first = rows(ratings=RATINGS, weights=weights_from_choices(ranked_choices()))
    second = rows(trial=1, ueq=UEQ_RAW)
    append_answers(path, first)
    append_answers(path, second)
    assert path.read_text().count("participant") == 1
    back = read_answers(path)
    assert list(back.columns) == QUESTIONNAIRE_COLUMNS and len(back) == len(first) + len(second)
    assert back["value"].tolist() == [row["value"] for row in first + second]
    with pytest.raises(ValueError, match="answered twice"):  # the file's rows count too
        append_answers(path, second)


def _bad(rows_, key, value):
    changed = [dict(row) for row in rows_]
    changed[0][key] = value
    return changed


@pytest.mark.parametrize(
    "make, message",
    [
        (lambda: _bad(rows(ratings=RATINGS), "value", 37), "multiple of 5"),
        (lambda: _bad(rows(ratings=RATINGS), "value", 105), r"\[0, 100\]"),
        (
            lambda: rows(ratings=RATINGS, weights={**weights_from_choices(ranked_choices()), "weight_mental": 4}),
            "sum to 14",
        ),
        (
            lambda: rows(
                ratings=RATINGS,
                weights={**weights_from_choices(ranked_choices()), "weight_mental": 6, "weight_effort": 3},
            ),
            r"\[0, 5\]",
        ),
        (lambda: _bad(rows(ratings=RATINGS), "item", "boredom"), "unknown item 'boredom'"),
        (lambda: _bad(rows(ratings=RATINGS), "instrument", "sus"), "unknown instrument 'sus'"),
        (lambda: rows(ueq=UEQ_RAW[:7]), r"incomplete UEQ-S items .*ueq8"),
        (lambda: rows(ueq=(8,) + UEQ_RAW[1:]), r"\[1, 7\]"),
        (lambda: rows(ueq=(4.5,) + UEQ_RAW[1:]), "whole number"),
        (lambda: rows(ratings={**RATINGS, "weight_mental": 5}), "incomplete TLX weights"),
        (lambda: _bad(rows(ratings=RATINGS), "trial", -1), "trial"),
    ],
)
def test_a_bad_row_is_refused_and_nothing_is_written(tmp_path, make, message):
    path = tmp_path / "questionnaires.csv"
    with pytest.raises(ValueError, match=message):
        append_answers(path, make() + rows(mode="shared", ratings=RATINGS))
    assert not path.exists()
    append_answers(path, rows(participant="P0", ratings=RATINGS))
    before = path.read_text()
    with pytest.raises(ValueError, match=message):
        append_answers(path, make())
    assert path.read_text() == before


def test_a_row_with_missing_or_extra_keys_is_refused(tmp_path):
    row = rows(ratings=RATINGS)[0]
    with pytest.raises(ValueError, match="exactly the keys"):
        append_answers(tmp_path / "q.csv", [{**row, "comment": "x"}])
    with pytest.raises(FileNotFoundError):
        read_answers(tmp_path / "q.csv")
