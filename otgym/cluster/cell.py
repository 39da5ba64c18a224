"""One cell of a sweep: the command run in this process through its Python entry point
(``otgym.cli.app.main(argv)``, what the ``otgym`` console script calls) into a private
temporary folder, whose files come back with the outcome.

The files travel back in the outcome (Ray's object store on a cluster) rather than
being written by the worker into the sweep's folder, so worker machines need no shared
file system; the driver puts them in place (``otgym.cluster.output``).
"""

from __future__ import annotations

import contextlib
import dataclasses
import io
import shutil
import socket
import tempfile
import time
import traceback
from collections.abc import Callable
from pathlib import Path


@dataclasses.dataclass
class CellOutcome:
    """What running a cell gave.

    ``status``: ``"done"`` or ``"failed"``; ``error``: the failure's one line (the
    command's last ``error:`` line, or the exception), empty when done; ``wall_s``: the
    command's wall time in seconds; ``node``: the IP address of the Ray node that ran it
    (the host name when run without Ray), ``node_id``: Ray's node id (empty without Ray);
    ``files``: the command's output files, path relative to its ``--out`` -> bytes;
    ``log``: what it printed (stdout, then stderr)."""

    name: str
    status: str
    error: str
    wall_s: float
    node: str
    node_id: str
    files: dict
    log: str


def _error_line(code, stderr: str, exception: BaseException | None) -> str:
    lines = [line.strip() for line in stderr.splitlines() if line.strip()]
    errors = [line for line in lines if line.startswith("error:")]
    if errors:
        return errors[-1]
    if exception is not None and not isinstance(exception, SystemExit):
        first = (str(exception).splitlines() or [""])[0]
        return f"{type(exception).__name__}: {first}".rstrip(": ")
    return lines[-1] if lines else f"exit code {code}"


def _collect(folder: Path) -> dict:
    if not folder.is_dir():
        return {}
    return {str(path.relative_to(folder)): path.read_bytes() for path in sorted(folder.rglob("*")) if path.is_file()}


def run_cell(entry_point: Callable, name: str, argv, node: str | None = None, node_id: str = "") -> CellOutcome:
    """Run ``entry_point(list(argv) + ["--out", <temporary folder>])`` here, with its
    output captured; the temporary folder is removed afterwards. A ``SystemExit`` of 0
    (or None) is success; any other exit or exception fails the cell (never raises)."""
    work = Path(tempfile.mkdtemp(prefix=f"otgym-cell-{name}-"))
    out = work / "out"
    stdout, stderr = io.StringIO(), io.StringIO()
    code, exception = 0, None
    start = time.perf_counter()
    try:
        with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
            try:
                entry_point([*argv, "--out", str(out)])
            except SystemExit as stop:
                code, exception = stop.code, stop
            except Exception as error:  # a cell that raises fails alone; the sweep goes on
                code, exception = 1, error
                traceback.print_exc()
        wall_s = time.perf_counter() - start
        failed = code not in (0, None)
        return CellOutcome(
            name=name,
            status="failed" if failed else "done",
            error=_error_line(code, stderr.getvalue(), exception) if failed else "",
            wall_s=wall_s,
            node=node or socket.gethostname(),
            node_id=node_id,
            files={} if failed else _collect(out),
            log=stdout.getvalue() + stderr.getvalue(),
        )
    finally:
        shutil.rmtree(work, ignore_errors=True)


def run_cell_on_ray(entry_point: Callable, name: str, argv) -> CellOutcome:
    """``run_cell`` inside a Ray task, recording the node (its IP address and id)."""
    import ray

    context = ray.get_runtime_context()
    return run_cell(entry_point, name, argv, ray.util.get_node_ip_address(), context.get_node_id())
