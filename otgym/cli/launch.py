"""Local node processes for ``otgym play --distributed``: each an ``otgym node ...``
child of this process, started, waited for (its ``ready:`` line), watched, and
stopped.

Nothing is orphaned: each child gets SIGTERM from the kernel if this process dies
(Linux ``PR_SET_PDEATHSIG``), every node ends cleanly on SIGTERM (devices at zero
force, recordings closed), and ``stop_all`` kills what has not ended within its
grace period. A child that fails is reported by ``failure`` as one line: its role,
exit code and the last line it wrote to stderr."""

from __future__ import annotations

import ctypes
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

PR_SET_PDEATHSIG = 1


def _die_with_parent() -> None:
    """In the child before exec: SIGTERM when the parent dies (Linux; elsewhere nothing)."""
    try:
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGTERM)
    except OSError:
        pass


class NodeProcesses:
    """Children ``otgym node ROLE ...``, by label; their stdout and stderr go to
    ``LABEL.out`` and ``LABEL.err`` in ``log_dir`` (created, and kept), or without one in
    a temporary folder that ``stop_all`` removes."""

    def __init__(self, log_dir: Path | None = None):
        self.children: dict[str, subprocess.Popen] = {}
        self._keep = log_dir is not None
        if log_dir is not None:
            log_dir.mkdir(parents=True, exist_ok=True)
        self._folder = Path(log_dir) if log_dir is not None else Path(tempfile.mkdtemp(prefix="otgym-nodes-"))
        self.finished: set[str] = set()
        """Labels whose exit is expected (stopped by us, or done)."""

    def start(self, label: str, arguments: list[str]) -> None:
        out = open(self._folder / f"{label}.out", "w")
        err = open(self._folder / f"{label}.err", "w")
        self.children[label] = subprocess.Popen(
            [sys.executable, "-m", "otgym", "node", *arguments],
            stdout=out,
            stderr=err,
            stdin=subprocess.DEVNULL,
            preexec_fn=_die_with_parent,
        )
        out.close()
        err.close()

    def _text(self, label: str, stream: str) -> str:
        return (self._folder / f"{label}.{stream}").read_text(errors="replace")

    def failure(self) -> str | None:
        """One line for the first child that failed (ended unasked with a non-zero
        exit code), or None."""
        for label, child in self.children.items():
            if label not in self.finished and child.poll() not in (None, 0):
                lines = [line for line in self._text(label, "err").splitlines() if line.strip()]
                last = lines[-1].removeprefix("error: ") if lines else "no message"
                return f"the {label} node ended (exit code {child.returncode}): {last}"
        return None

    def ended(self, label: str) -> bool:
        return self.children[label].poll() is not None

    def wait_ready(self, timeout_s: float) -> None:
        """Until every child printed its ``ready:`` line; RuntimeError with ``failure``'s
        line if one ends first, or after ``timeout_s``."""
        deadline = time.monotonic() + timeout_s
        waiting = set(self.children)
        while waiting:
            waiting = {label for label in waiting if "ready:" not in self._text(label, "out")}
            failed = self.failure() or next(
                (f"the {label} node ended before it was ready" for label in waiting if self.ended(label)), None
            )
            if failed:
                raise RuntimeError(failed)
            if time.monotonic() > deadline:
                raise RuntimeError(f"node(s) {', '.join(sorted(waiting))} not ready within {timeout_s:.0f} s")
            time.sleep(0.1)

    def wait_output(self, label: str, line: str, timeout_s: float) -> bool:
        """Until ``label`` has written ``line`` to its stdout (True), it has ended or
        ``timeout_s`` has passed (False)."""
        deadline = time.monotonic() + timeout_s
        while line not in self._text(label, "out"):
            if self.ended(label) or time.monotonic() > deadline:
                return line in self._text(label, "out")
            time.sleep(0.05)
        return True

    def wait_exit(self, label: str, timeout_s: float) -> bool:
        child = self.children[label]
        try:
            child.wait(timeout_s)
        except subprocess.TimeoutExpired:
            return False
        self.finished.add(label)
        return True

    def stop(self, label: str, grace_s: float = 10.0) -> None:
        """SIGTERM, then SIGKILL after ``grace_s``."""
        child = self.children[label]
        self.finished.add(label)
        if child.poll() is None:
            child.send_signal(signal.SIGTERM)
            try:
                child.wait(grace_s)
            except subprocess.TimeoutExpired:
                child.kill()
                child.wait()

    def stop_all(self, order: list[str] | None = None, grace_s: float = 10.0) -> None:
        for label in order or list(self.children):
            if label in self.children:
                self.stop(label, grace_s)
        for label in self.children:
            self.stop(label, grace_s)
        if not self._keep:
            shutil.rmtree(self._folder, ignore_errors=True)


def free_loopback_endpoint() -> str:
    """A zenoh endpoint on a loopback port free now."""
    import socket

    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return f"tcp/127.0.0.1:{probe.getsockname()[1]}"
