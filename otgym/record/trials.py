"""A study's trial rows read from MCAP recordings: each ``trial_end`` event on
``/otgym/trial/events`` carries its trial's row (``otgym play`` writes the row it also
appends to ``trials.csv``: participant, mode, trial, scenario, the task's metrics,
modes_used, ended_by), so ``otgym study analyze`` can read recordings as it reads
``trials.csv``. A trial the recording did not see end (its writer was killed) has no
row. Non-finite numbers were recorded as JSON null and read back as NaN."""

from __future__ import annotations

import math
from pathlib import Path

from otgym.record.mcap_file import read_recording
from otgym.record.replay import events

SESSION_PATTERN = "session*.mcap"
"""The recordings ``otgym play`` and the recorder node write into a folder."""


def trial_rows(path) -> list[dict]:
    """The rows of the finished trials of the recording ``path``, in order. ValueError
    for a file that is not MCAP, or whose trial_end events carry no rows (a simulator
    node's, which knows no participant: record such sessions with ``otgym play``)."""
    rows = []
    for event in events(read_recording(path)):
        if event["event"] != "trial_end":
            continue
        if "participant" not in event:
            raise ValueError(
                f"{path}: its trial_end events carry no trial rows (no participant): a simulator "
                "node's recording cannot be analysed as a study; record sessions with otgym play"
            )
        rows.append({key: math.nan if value is None else value for key, value in event.items() if key != "event"})
    return rows


def folder_recordings(folder: Path) -> list[Path]:
    """``folder``'s session recordings in the order they were written (session.mcap,
    session-2.mcap, ...)."""

    def order(path: Path) -> int:
        suffix = path.stem.removeprefix("session").removeprefix("-")
        return int(suffix) if suffix.isdigit() else 1

    return sorted(Path(folder).glob(SESSION_PATTERN), key=order)
