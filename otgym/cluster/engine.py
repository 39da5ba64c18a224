"""Running a sweep's cells: one after another in this process (``serial``), or as Ray
tasks, on a Ray instance started here (``address=None``) or on a running cluster
(``address="auto"`` or ``"HOST:PORT"``).

A Ray started here is always a new one of its own (Ray's ``address="local"``): neither
``RAY_ADDRESS`` nor the cluster Ray records in its temporary folder (which ``ray stop``
leaves behind) can send the cells elsewhere or stop the sweep; joining a cluster is
only ever asked for with an address.

On Ray each cell is one task (``ray.remote`` with ``num_cpus``/``num_gpus`` per
cell); Ray places the tasks on the cluster's nodes as resources free up, reruns a task
whose worker or node died (``max_retries``) on another node, and ``ray.wait`` hands
back cells as they finish. A cell that fails (its command exits non-zero or raises)
returns a failed outcome and is not retried; the others go on. We keep no queue,
scheduler or retry loop of our own.
"""

from __future__ import annotations

import dataclasses
import logging
import sys
from collections.abc import Callable
from pathlib import Path

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from otgym.cluster import output
from otgym.cluster.cell import CellOutcome, run_cell, run_cell_on_ray
from otgym.cluster.sweep_file import Cell, Sweep

LOCAL_NODE_IP = "127.0.0.4"
"""The node address of a Ray started by the sweep itself on Linux (where all of
127.0.0.0/8 is loopback): Ray replaces 127.0.0.1 and localhost with the machine's
outward address, which would let its processes talk over the outward interface."""

NODE_LOSS_RETRIES = 3
"""Reruns of a cell whose worker process or node died (Ray's ``max_retries``)."""


@dataclasses.dataclass
class SweepRun:
    """``skipped``: cells finished by an earlier run; ``done``/``failed``: outcomes of this run."""

    skipped: list[str]
    done: list[CellOutcome]
    failed: list[CellOutcome]


def ray_available() -> bool:
    import importlib.util

    return importlib.util.find_spec("ray") is not None


def _run_serially(cells: list[Cell], entry_point: Callable):
    for cell in cells:
        yield cell, run_cell(entry_point, cell.name, cell.argv)


def _run_on_ray(
    cells: list[Cell], entry_point: Callable, address: str | None, workers: int | None, cpus: float, gpus: float
):
    import ray

    if address is None:  # a Ray of our own, on a loopback address on Linux
        ray.init(
            address="local",
            num_cpus=workers,
            include_dashboard=False,
            logging_level=logging.WARNING,
            log_to_driver=False,
            _node_ip_address=LOCAL_NODE_IP if sys.platform == "linux" else None,
        )
    else:
        ray.init(address=address, logging_level=logging.WARNING, log_to_driver=False)
    try:
        # a cell with GPUs gets a fresh worker process: JAX keeps the devices it saw first
        task = ray.remote(max_calls=1 if gpus else 0)(run_cell_on_ray).options(
            num_cpus=cpus, num_gpus=gpus, max_retries=NODE_LOSS_RETRIES, retry_exceptions=False
        )
        pending = {task.remote(entry_point, cell.name, cell.argv): cell for cell in cells}
        while pending:
            finished, _ = ray.wait(list(pending), num_returns=1)
            for reference in finished:
                cell = pending.pop(reference)
                try:
                    outcome = ray.get(reference)
                except ray.exceptions.RayError as error:  # retries spent, or the task could not run at all
                    first = (str(error).strip().splitlines() or [type(error).__name__])[0]
                    outcome = CellOutcome(cell.name, "failed", f"{type(error).__name__}: {first}", 0.0, "", "", {}, "")
                yield cell, outcome
    finally:
        ray.shutdown()


def run_sweep(
    sweep: Sweep,
    out_dir: Path,
    entry_point: Callable,
    serial: bool = False,
    address: str | None = None,
    workers: int | None = None,
    cpus_per_cell: float = 1.0,
    gpus_per_cell: float = 0.0,
    console: Console | None = None,
) -> SweepRun:
    """Run the cells of ``sweep`` not yet finished in ``out_dir`` (which must exist),
    each through ``entry_point(argv)``; put each finished cell in place as it comes
    and keep ``cells.csv`` current. A progress bar counts finished cells. ``workers``:
    CPUs of a Ray instance started here (default: all). Raises ValueError if
    ``out_dir`` holds cells of another sweep."""
    console = console or Console()
    todo = output.check_resumable(out_dir, sweep)
    todo_names = {cell.name for cell in todo}
    run = SweepRun([cell.name for cell in sweep.cells if cell.name not in todo_names], [], [])
    failures: dict[str, CellOutcome] = {}
    output.write_cells_csv(out_dir, sweep, failures)
    if run.skipped:
        console.print(f"{len(run.skipped)} of {len(sweep.cells)} cells finished earlier in {out_dir}: skipped")
    if not todo:
        return run
    outcomes = (
        _run_serially(todo, entry_point)
        if serial
        else _run_on_ray(todo, entry_point, address, workers, cpus_per_cell, gpus_per_cell)
    )
    columns = (TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn())
    with Progress(*columns, console=console) as progress:
        where = "serially" if serial else "on Ray"
        bar = progress.add_task(f"{sweep.command.name}: cells finished ({where})", total=len(sweep.cells))
        progress.update(bar, completed=len(run.skipped))
        for cell, outcome in outcomes:
            if outcome.status == "done":
                output.commit(out_dir, cell, outcome)
                run.done.append(outcome)
                progress.console.print(f"{cell.name}: done in {outcome.wall_s:.1f} s on {outcome.node}")
            else:
                output.record_failure(out_dir, outcome)
                failures[cell.name] = outcome
                run.failed.append(outcome)
                progress.console.print(f"{cell.name}: failed on {outcome.node or '?'}: {outcome.error}")
            output.write_cells_csv(out_dir, sweep, failures)
            progress.advance(bar)
    return run
