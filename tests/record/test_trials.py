"""Trial rows from recordings (``otgym.record.trials``; the study analysis of them:
tests/cli/test_study_analyze.py): the rows of trial_end events, null read as NaN, a
trial that never ended has none, and a folder's sessions in the order written."""

import math

from otgym.bus import messages as m
from otgym.bus import schemas
from otgym.record.mcap_file import McapRecorder
from otgym.record.trials import folder_recordings, trial_rows


def test_rows_come_from_trial_end_events_only(tmp_path):
    path = tmp_path / "session.mcap"
    with McapRecorder(path) as recorder:
        for event in (
            m.event("trial_start", trial=1),
            m.event("trial_end", trial=1, participant="P1", success=None),
            m.event("mode", trial=2, mode="manual"),
            m.event("trial_start", trial=2),
        ):
            recorder.write(m.EVENTS, m.STRING, schemas.SCHEMAS[m.STRING], event)
    rows = trial_rows(path)
    assert len(rows) == 1 and rows[0]["participant"] == "P1" and math.isnan(rows[0]["success"])
    assert "event" not in rows[0]


def test_a_folders_sessions_in_the_order_written(tmp_path):
    for name in ("session-10.mcap", "session.mcap", "session-2.mcap", "other.mcap"):
        (tmp_path / name).write_bytes(b"")
    assert [p.name for p in folder_recordings(tmp_path)] == ["session.mcap", "session-2.mcap", "session-10.mcap"]
