"""trials.csv of ``otgym play``: one row per finished trial, appended as it ends (a
crash loses no finished trial), with the experiment's columns first
(``runtime.trials.TRIAL_COLUMNS``, as ``otgym experiment shared-control`` writes) and
the session's own after them."""

from __future__ import annotations

import csv
from pathlib import Path

from otgym.runtime.session import EXTRA_COLUMNS
from otgym.runtime.trials import TRIAL_COLUMNS

PLAY_COLUMNS = TRIAL_COLUMNS + EXTRA_COLUMNS


def append_trial(path: Path, row: dict) -> None:
    """Append ``row`` to the CSV at ``path``, writing the header first if it is new or empty."""
    path = Path(path)
    new = not path.exists() or path.stat().st_size == 0
    with path.open("a", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=PLAY_COLUMNS, extrasaction="ignore")
        if new:
            writer.writeheader()
        writer.writerow(row)
