"""``otgym play --distributed``: the sim, device, recorder and autonomy nodes as local
processes and the window as the ui node, headless. A short session ends by itself and
leaves trials.csv and the recorder's session.mcap; a node killed mid-session stops
them all with one error line. Either way no process it started is left: every one of
them carries a marker in its environment, looked for in /proc afterwards. The short
session's launcher runs in this process (``tests.otgym_cli``: its nodes are processes
all the same); the other is a process, read line by line while it runs."""

from __future__ import annotations

import csv
import os
import queue
import signal
import subprocess
import sys
import threading
import time
import uuid
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def marked(marker: str) -> list[int]:
    """Live processes whose environment holds ``OTGYM_TEST_MARKER=marker`` (zombies excluded)."""
    found = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            if (
                f"OTGYM_TEST_MARKER={marker}".encode() in (entry / "environ").read_bytes().split(b"\0")
                and (entry / "status").read_text().split("State:")[1].split()[0] != "Z"
            ):
                found.append(int(entry.name))
        except (OSError, IndexError):
            continue
    return found


def play_arguments(out: Path, *arguments: str) -> list[str]:
    """``otgym play --distributed`` headless with the simulated stylus, participant D1."""
    return [
        "play",
        "--headless",
        "--distributed",
        "--device",
        "simulated",
        "--no-questionnaire",
        "--participant",
        "D1",
        *arguments,
        "--out",
        str(out),
    ]


def launch(out: Path, marker: str, *arguments: str) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "otgym", *play_arguments(out, *arguments)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONPATH": str(ROOT), "OTGYM_TEST_MARKER": marker},
    )


def wait_gone(marker: str, timeout_s: float = 60.0) -> list[int]:
    deadline = time.monotonic() + timeout_s
    while marked(marker) and time.monotonic() < deadline:
        time.sleep(0.1)
    return marked(marker)


@pytest.mark.slow
def test_a_distributed_session_records_its_trial_and_leaves_nothing_running(tmp_path, monkeypatch):
    """A 3 s shared-mode session: the window's trials.csv has the one trial's row (D1,
    ended by its duration at 3.0 s of simulated time) and the recorder's session.mcap is
    complete and tells the same trial: its events in order (one trial_start of trial 1,
    D1, shared, the row's scenario; one trial_end whose every field is the row's;
    session_end last, with the 150 ticks of 3 s), and the streams it recorded from the
    bus: every tick's traps at most once (a stream may drop a message under load, never
    duplicate one), in order of their stamps, and the stylus's twists and the autonomy's
    increments present. Nothing it started is left running. Catches a recorder that misses
    or repeats events, rows and events that disagree, or a session cut short."""
    from otgym.bus import messages as msg
    from otgym.record.mcap_file import read_recording
    from otgym.record.replay import events, summary
    from tests.otgym_cli import run_otgym

    marker = uuid.uuid4().hex
    monkeypatch.setenv("OTGYM_TEST_MARKER", marker)  # the nodes this process starts inherit it
    run = run_otgym(play_arguments(tmp_path, "--duration", "3", "--mode", "shared"))
    assert run.returncode == 0, run.stderr
    assert wait_gone(marker) == []
    with open(tmp_path / "trials.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert len(rows) == 1 and rows[0]["participant"] == "D1" and rows[0]["ended_by"] == "duration"
    assert float(rows[0]["completion_time_s"]) == pytest.approx(3.0, abs=0.011)
    recording = read_recording(tmp_path / "session.mcap")
    recorded = summary(recording)
    assert recorded["complete"] and recorded["trials"] == 1 and recorded["ended_by"] == ["duration"]
    trial_events = events(recording)
    names = [event["event"] for event in trial_events]
    assert names[0] == "trial_start" and names[-1] == "session_end" and names.count("trial_end") == 1, names
    start, end = trial_events[0], trial_events[names.index("trial_end")]
    assert (start["trial"], start["participant"], start["mode"]) == (1, "D1", "shared")
    assert start["scenario"] == int(rows[0]["scenario"])
    for column, value in rows[0].items():
        assert column in end, column
        if isinstance(end[column], float):
            assert float(value) == pytest.approx(end[column], rel=1e-9), column
        else:
            assert value == ("" if end[column] is None else str(end[column])), column
    assert trial_events[-1]["ticks"] == 150 and trial_events[-1]["trials"] == 1
    traps = [msg.stamp_s(msg.decode(msg.TRAPS, message.data)) for message in recording.topic(msg.TRAPS)]
    assert 0 < len(traps) <= 150 and all(b > a for a, b in zip(traps, traps[1:]))
    counts = recorded["counts"]
    assert counts["/otgym/device/device0/twist"] > 0 and counts["/otgym/autonomy/increments"] > 0


@pytest.mark.slow
def test_a_node_that_dies_stops_them_all_with_one_error_line(tmp_path):
    """A manual session whose device node is killed (SIGKILL) once the session runs (its
    recording holds a tick's traps: waited for, 300 s at most): the launcher ends with
    exit code 1 and one error line naming the node, nothing it started is left, and the
    trial under way is saved as aborted."""
    from otgym.record.mcap_file import read_recording

    marker = uuid.uuid4().hex
    run = launch(tmp_path, marker, "--duration", "600", "--mode", "manual")
    lines = queue.Queue()
    threading.Thread(target=lambda: [lines.put(line) for line in run.stdout], daemon=True).start()
    try:
        deadline = time.monotonic() + 300.0  # bounds a hang only: four nodes compile on a loaded machine
        while not lines.get(timeout=max(deadline - time.monotonic(), 0.01)).startswith("nodes ready"):
            pass  # the nodes are ready, the window opens
        while not recorded_ticks(tmp_path / "session.mcap", read_recording):  # the session runs
            assert time.monotonic() < deadline and run.poll() is None, "the session did not start"
            time.sleep(0.1)
        device = [
            pid for pid in marked(marker) if b"device\0--device\0simulated" in Path(f"/proc/{pid}/cmdline").read_bytes()
        ]
        assert len(device) == 1
        os.kill(device[0], signal.SIGKILL)
        run.wait(timeout=120)
        stderr = run.stderr.read()
    finally:
        if run.poll() is None:
            run.kill()
            run.wait()
    errors = [line for line in stderr.splitlines() if line.startswith("error:")]
    assert run.returncode == 1 and errors == ["error: the device0 node ended (exit code -9): no message"], stderr
    assert wait_gone(marker) == []
    with open(tmp_path / "trials.csv", newline="") as handle:  # the trial under way was saved
        assert [row["ended_by"] for row in csv.DictReader(handle)] == ["aborted"]


def recorded_ticks(path: Path, read_recording) -> int:
    """Traps messages in the recording so far (its flushed chunks); 0 before the file exists."""
    from otgym.bus import messages as msg

    if not path.exists():
        return 0
    try:
        return len(read_recording(path).topic(msg.TRAPS))
    except ValueError:  # not even its magic written yet
        return 0
