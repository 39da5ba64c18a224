"""The session's own process (``otgym.runtime.worker``): the snapshot block never
hands a reader a torn write while another process writes it; a worker whose parent
is killed ends its trial as aborted, closes its recording (a complete MCAP file) and
exits, leaving nothing running. The window's side of a normal session is tested
through ``otgym play`` (tests/ui/test_play.py)."""

from __future__ import annotations

import multiprocessing
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from otgym.runtime.latest_bytes import LatestBytes

ROOT = Path(__file__).resolve().parents[2]
WRITES = 20_000


def payload(k: int) -> bytes:
    """Write k: its length and every byte say k, so a torn read shows."""
    return bytes([k % 251]) * (64 + (k * 37) % 4000)


def _writer(block: LatestBytes) -> None:
    for k in range(1, WRITES + 1):
        block.write(payload(k))


def test_latest_bytes_never_hands_out_a_torn_write():
    block = LatestBytes(8192)
    writer = multiprocessing.get_context("spawn").Process(target=_writer, args=(block,))
    writer.start()
    seen, checked = 0, 0
    while writer.is_alive() or checked == 0:
        latest = block.read()
        if latest is None:
            continue
        sequence, data = latest
        assert data == payload(sequence), f"torn read at write {sequence}"
        assert sequence >= seen  # never older than what was read before
        seen, checked = sequence, checked + 1
    writer.join()
    assert block.read() == (WRITES, payload(WRITES)) and checked > 100


PARENT = """
import functools, sys, time
from otgym.runtime.worker import SessionProcess, WorkerSpec
from otgym.ui.play_worker import play_setup
session = SessionProcess(WorkerSpec(functools.partial(play_setup, "default", "simulated", sys.argv[1]),
                                    "K1", "shared", 0))
session.start()
print("worker", session.process.pid, flush=True)
while True:
    session.poll(0.05)
"""


def allowed_cpus(status: Path) -> int:
    """How many CPUs a process or thread may run on (its /proc status file)."""
    cpus = 0
    for part in status.read_text().split("Cpus_allowed_list:")[1].split()[0].split(","):
        low, _, high = part.partition("-")
        cpus += int(high or low) - int(low) + 1
    return cpus


def gone(pid: int) -> bool:
    """The process has exited (a zombie nobody reaps counts as gone)."""
    try:
        return Path(f"/proc/{pid}/status").read_text().split("State:")[1].split()[0] == "Z"
    except (FileNotFoundError, IndexError):
        return True


def test_a_worker_whose_parent_is_killed_saves_its_trial_as_aborted_and_exits(tmp_path):
    from otgym.record.mcap_file import read_recording
    from otgym.record.replay import summary

    path = tmp_path / "session.mcap"
    parent = subprocess.Popen(
        [sys.executable, "-c", PARENT, str(path)],
        stdout=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
    try:
        line = parent.stdout.readline()
        assert line.startswith("worker"), f"the parent printed {line!r} (exit {parent.poll()})"
        worker = int(line.split()[1])
        time.sleep(2.0)  # about 100 ticks of trial 1
        if len(os.sched_getaffinity(0)) > 1:  # the worker's threads on one core, its servo child on all
            threads = list(Path(f"/proc/{worker}/task").iterdir())
            assert len(threads) > 1 and {allowed_cpus(t / "status") for t in threads} == {1}
            servo = int(Path(f"/proc/{worker}/task/{worker}/children").read_text().split()[0])
            assert allowed_cpus(Path(f"/proc/{servo}/status")) == len(os.sched_getaffinity(0))
    finally:
        os.kill(parent.pid, signal.SIGKILL)
        parent.wait()
    deadline = time.monotonic() + 30.0
    while not gone(worker) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert gone(worker)
    recorded = summary(read_recording(path))
    assert recorded["complete"] and recorded["trials"] == 1 and recorded["ended_by"] == ["aborted"]
    assert recorded["counts"]["/otgym/traps"] >= 50
