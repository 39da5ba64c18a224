"""``otgym play --distributed``: the sim, device, recorder and autonomy nodes as local
processes and the window as the ui node, headless. A short session ends by itself and
leaves trials.csv and the recorder's session.mcap; a node killed mid-session stops
them all with one error line. Either way no process it started is left: every one of
them carries a marker in its environment, looked for in /proc afterwards."""

from __future__ import annotations

import csv
import os
import signal
import subprocess
import sys
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


def launch(out: Path, marker: str, *arguments: str) -> subprocess.Popen:
    return subprocess.Popen(
        [
            sys.executable,
            "-m",
            "otgym",
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
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONPATH": str(ROOT), "OTGYM_TEST_MARKER": marker},
    )


def wait_gone(marker: str, timeout_s: float = 20.0) -> list[int]:
    deadline = time.monotonic() + timeout_s
    while marked(marker) and time.monotonic() < deadline:
        time.sleep(0.1)
    return marked(marker)


def test_a_distributed_session_records_its_trial_and_leaves_nothing_running(tmp_path):
    from otgym.record.mcap_file import read_recording
    from otgym.record.replay import summary

    marker = uuid.uuid4().hex
    run = launch(tmp_path, marker, "--duration", "3", "--mode", "shared")
    stdout, stderr = run.communicate(timeout=600)
    assert run.returncode == 0, stderr
    assert wait_gone(marker) == []
    with open(tmp_path / "trials.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert len(rows) == 1 and rows[0]["participant"] == "D1" and rows[0]["ended_by"] == "duration"
    assert float(rows[0]["completion_time_s"]) == pytest.approx(3.0, abs=0.011)
    recorded = summary(read_recording(tmp_path / "session.mcap"))
    assert recorded["complete"] and recorded["trials"] == 1 and recorded["ended_by"] == ["duration"]
    counts = recorded["counts"]
    assert counts["/otgym/traps"] >= 0.9 * 150  # 3 s at 50 Hz (zenoh drops a message now and then under load)
    assert counts["/otgym/device/device0/twist"] > 100 and counts["/otgym/autonomy/increments"] > 100


def test_a_node_that_dies_stops_them_all_with_one_error_line(tmp_path):
    marker = uuid.uuid4().hex
    run = launch(tmp_path, marker, "--duration", "600", "--mode", "manual")
    try:
        for line in run.stdout:  # the nodes are ready, the window opens
            if line.startswith("nodes ready"):
                break
        time.sleep(2.0)  # the session runs
        device = [
            pid for pid in marked(marker) if b"device\0--device\0simulated" in Path(f"/proc/{pid}/cmdline").read_bytes()
        ]
        assert len(device) == 1
        os.kill(device[0], signal.SIGKILL)
        stdout, stderr = run.communicate(timeout=120)
    finally:
        if run.poll() is None:
            run.kill()
            run.wait()
    errors = [line for line in stderr.splitlines() if line.startswith("error:")]
    assert run.returncode == 1 and errors == ["error: the device0 node ended (exit code -9): no message"], stderr
    assert wait_gone(marker) == []
    with open(tmp_path / "trials.csv", newline="") as handle:  # the trial under way was saved
        assert [row["ended_by"] for row in csv.DictReader(handle)] == ["aborted"]
