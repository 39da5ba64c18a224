"""The session's own process (``otgym.runtime.worker``): the snapshot block never
hands a reader a torn write while another process writes it; a worker whose parent
is killed ends its trial as aborted, closes its recording (a complete MCAP file) and
exits, leaving nothing running. The window's side of a normal session is tested
through ``otgym play`` (tests/ui/test_play.py)."""

from __future__ import annotations

import multiprocessing
import os
import queue
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from otgym.runtime.latest_bytes import LatestBytes

ROOT = Path(__file__).resolve().parents[2]
READS = 500
"""Distinct writes the reader must see while the writer is writing."""


def payload(k: int) -> bytes:
    """Write k: its length and every byte say k, so a torn read shows."""
    return bytes([k % 251]) * (64 + (k * 37) % 4000)


def _writer(block: LatestBytes, stop, writes) -> None:
    k = 0
    while not stop.is_set():
        k += 1
        block.write(payload(k))
        writes.value = k


@pytest.mark.slow
def test_latest_bytes_never_hands_out_a_torn_write():
    """A writer process writes payloads of changing length and content without pause
    until the reader has seen 500 different writes (120 s at most, a bound against
    hangs): every read is whole (its bytes are the payload of the write it names) and
    never older than the read before; after the writer stops, the block holds its last
    write. The reader stops the writer, so the reads overlap the writes however fast
    either runs."""
    context = multiprocessing.get_context("spawn")
    block, stop, writes = LatestBytes(8192), context.Event(), context.RawValue("q", 0)
    writer = context.Process(target=_writer, args=(block, stop, writes))
    writer.start()
    try:
        seen, distinct, deadline = 0, 0, time.monotonic() + 120.0
        while distinct < READS:
            assert time.monotonic() < deadline and writer.is_alive(), f"{distinct} distinct reads"
            latest = block.read()
            if latest is None:
                continue
            sequence, data = latest
            assert data == payload(sequence), f"torn read at write {sequence}"
            assert sequence >= seen  # never older than what was read before
            distinct += sequence > seen
            seen = sequence
    finally:
        stop.set()
        writer.join(60)
    assert writer.exitcode == 0 and writes.value >= seen
    assert block.read() == (writes.value, payload(writes.value))


PARENT = """
import functools, sys, time
from otgym.runtime.worker import SessionProcess, WorkerSpec
from otgym.ui.play_worker import play_setup
session = SessionProcess(WorkerSpec(functools.partial(play_setup, "default", "simulated", sys.argv[1]),
                                    "K1", "shared", 0))
session.start()
print("worker", session.process.pid, flush=True)
told = False
while True:
    session.poll(0.05)
    snapshot = session.snapshot
    if not told and snapshot is not None and snapshot.observation.time_s[0] >= 1.0:
        told = True
        print("ticked", round(float(snapshot.observation.time_s[0]) / 0.02), flush=True)
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


@pytest.mark.slow
def test_a_worker_whose_parent_is_killed_saves_its_trial_as_aborted_and_exits(tmp_path):
    """A parent starts a session worker and says when the worker's snapshot has reached
    1 s of trial 1 (and how many ticks that is); then it is killed with SIGKILL. The
    worker's threads are pinned to one core, its servo child may use all; the worker
    exits (waited for, 60 s at most) and leaves a complete recording of one trial ended
    as aborted, holding at least every tick the parent had seen. Events, not sleeps: the
    test waits for the parent's lines, 300 s at most each."""
    from otgym.record.mcap_file import read_recording
    from otgym.record.replay import summary

    path = tmp_path / "session.mcap"
    parent = subprocess.Popen(
        [sys.executable, "-c", PARENT, str(path)],
        stdout=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
    lines = queue.Queue()
    threading.Thread(target=lambda: [lines.put(line) for line in parent.stdout], daemon=True).start()

    def next_line() -> str:
        try:
            return lines.get(timeout=300.0)  # bounds a hang only: the worker compiles JAX on a loaded machine
        except queue.Empty:
            raise AssertionError(f"the parent printed nothing more within 300 s (exit {parent.poll()})") from None

    try:
        line = next_line()
        assert line.startswith("worker"), f"the parent printed {line!r} (exit {parent.poll()})"
        worker = int(line.split()[1])
        line = next_line()  # the worker's snapshot has reached 1 s of trial 1
        assert line.startswith("ticked"), f"the parent printed {line!r} (exit {parent.poll()})"
        ticked = int(line.split()[1])
        if len(os.sched_getaffinity(0)) > 1:  # the worker's threads on one core, its servo child on all
            threads = list(Path(f"/proc/{worker}/task").iterdir())
            assert len(threads) > 1 and {allowed_cpus(t / "status") for t in threads} == {1}
            servo = int(Path(f"/proc/{worker}/task/{worker}/children").read_text().split()[0])
            assert allowed_cpus(Path(f"/proc/{servo}/status")) == len(os.sched_getaffinity(0))
    finally:
        os.kill(parent.pid, signal.SIGKILL)
        parent.wait()
    deadline = time.monotonic() + 60.0  # bounds a hang only
    while not gone(worker) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert gone(worker)
    recorded = summary(read_recording(path))
    assert recorded["complete"] and recorded["trials"] == 1 and recorded["ended_by"] == ["aborted"]
    assert ticked >= 50 and recorded["counts"]["/otgym/traps"] >= ticked  # every tick the parent saw is recorded
