"""The table of assumed parameters (``otgym.human.assumptions``): every parameter of the
model is either weighed there or cited as measured, and the documentation shows it."""

import dataclasses
from pathlib import Path

import pytest

from otgym.human.assumptions import ASSUMPTIONS, SOURCED, Assumption, unclassified
from otgym.human.participant_task import ParticipantTask


def test_every_parameter_of_the_model_is_assumed_with_a_range_or_cited():
    assert unclassified() == []
    assert len({a.label for a in ASSUMPTIONS}) == len(ASSUMPTIONS)


def test_a_parameter_left_out_of_the_table_is_caught():
    """The check fails for a table missing one assumption, for a new ``ParticipantTask``
    field nobody weighed, and for a parameter both assumed and cited."""
    assert unclassified(ASSUMPTIONS[1:]) == [f"{ASSUMPTIONS[0].kind}:{ASSUMPTIONS[0].name}"]
    sourced_too = {**SOURCED, "motor": {**SOURCED["motor"], "preferred_speed_mm_s": "x"}}
    assert unclassified(ASSUMPTIONS, sourced_too) == ["motor:preferred_speed_mm_s"]

    @dataclasses.dataclass(frozen=True)
    class NewTask(ParticipantTask):
        patience_s: float = 2.0

    import otgym.human.assumptions as module

    original = module.ParticipantTask
    module.ParticipantTask = NewTask
    try:
        assert unclassified() == ["task:patience_s"]
    finally:
        module.ParticipantTask = original


def test_each_range_holds_the_model_value_and_names_its_source():
    for a in ASSUMPTIONS:
        assert a.low <= a.default <= a.high, a
        assert a.source.split(": ", 1)[0] in ("literature", "reasoning"), a
    with pytest.raises(ValueError):
        Assumption("x", "task", 2.0, 1.0, "reasoning: backwards")
    with pytest.raises(ValueError):
        Assumption("x", "task", 1.0, 2.0, "a hunch")


def test_the_human_model_page_shows_every_assumption_with_its_range():
    page = Path(__file__).resolve().parents[2].joinpath("docs", "human-model.md").read_text()
    for a in ASSUMPTIONS:
        assert f"| `{a.label}` | {a.kind} | {a.default:g} | {a.low:g} - {a.high:g} |" in page, a.label
