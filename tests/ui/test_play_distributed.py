"""``otgym play --distributed``: the sim, device, recorder and autonomy nodes as local
processes and the window as the ui node, headless. A node killed mid-session stops
them all with one error line, and no process it started is left: every one of them
carries a marker in its environment, looked for in /proc afterwards. A session that
ends by itself, with its trials.csv and the recorder's session.mcap, is checked with
the ROS 2 bridge beside it (``tests/bus/test_ros2_bridge.py``: one session serves both)."""

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
