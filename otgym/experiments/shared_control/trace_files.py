"""``otgym experiment shared-control --trace P:T``: one trial of one simulated participant
written tick by tick, per mode, as ``trace_p{P}_t{T}_{mode}.csv`` (columns:
``otgym.runtime.trace``)."""

from __future__ import annotations

import re
from pathlib import Path

import pandas as pd


def parse_trace(text: str) -> tuple[int, int]:
    """``"3:5"`` -> (3, 5): participant and trial, both non-negative integers."""
    match = re.fullmatch(r"\s*(\d+)\s*:\s*(\d+)\s*", text)
    if not match:
        raise ValueError(f"--trace must be PARTICIPANT:TRIAL, two non-negative integers such as 3:5, got {text!r}")
    return int(match[1]), int(match[2])


def check_trace(text: str, participants: int, trials: int) -> tuple[int, int]:
    """``parse_trace``, and the participant and trial within the run's ranges."""
    participant, trial = parse_trace(text)
    if participant >= participants or trial >= trials:
        raise ValueError(
            f"participant {participant} must be below --participants {participants} and trial {trial} below "
            f"--trials {trials} (both count from 0)"
        )
    return participant, trial


def trace_path(out: Path, participant: int, trial: int, mode: str) -> Path:
    return Path(out) / f"trace_p{participant}_t{trial}_{mode}.csv"


def write_traces(traces: dict[str, pd.DataFrame], out: Path, participant: int, trial: int) -> list[Path]:
    """Write each mode's trace; return the paths, in the modes' order."""
    paths = []
    for mode, frame in traces.items():
        path = trace_path(out, participant, trial, mode)
        frame.to_csv(path, index=False)
        paths.append(path)
    return paths
