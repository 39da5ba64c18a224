"""The sweep's output folder ``DIR``.

``DIR/<cell>/``: a finished cell's files, with ``cell.json`` (its options, command line,
wall time and node) and ``cell.log`` (what the command printed). The folder is filled
under a hidden name (``DIR/.partial-<cell>-*``) and renamed once complete, so it exists
only for a finished cell, and a resumed sweep skips exactly those.
``DIR/<cell>.failed.log``: a failed cell's output (removed once it succeeds).
``DIR/cells.csv``: one row per cell (its options, status, wall time, node, error line),
rewritten after every cell. One driver per ``DIR`` at a time.
"""

from __future__ import annotations

import csv
import io
import json
import os
import shutil
import uuid
from pathlib import Path

from otgym.cluster.cell import CellOutcome
from otgym.cluster.sweep_file import Cell, Sweep

CELL_META = "cell.json"
CELL_LOG = "cell.log"
CELLS_CSV = "cells.csv"
PARTIAL_PREFIX = ".partial-"


def failed_log(out_dir: Path, name: str) -> Path:
    return Path(out_dir) / f"{name}.failed.log"


def finished_meta(out_dir: Path, name: str) -> dict | None:
    """``cell.json`` of the finished cell ``name``, None if it has not finished."""
    path = Path(out_dir) / name / CELL_META
    return json.loads(path.read_text()) if path.is_file() else None


def check_resumable(out_dir: Path, sweep: Sweep) -> list[Cell]:
    """The cells still to run; raises ValueError if a finished cell in ``out_dir`` was
    made with another command line (another sweep file wrote there). Removes the
    partial folders a stopped driver left."""
    out_dir = Path(out_dir)
    for partial in out_dir.glob(PARTIAL_PREFIX + "*"):
        shutil.rmtree(partial, ignore_errors=True)
    todo = []
    for cell in sweep.cells:
        meta = finished_meta(out_dir, cell.name)
        if meta is None:
            todo.append(cell)
        elif meta.get("argv") != list(cell.argv):
            raise ValueError(
                f"{out_dir / cell.name} was made by another sweep ({' '.join(meta.get('argv', []))}); "
                "give another --out or remove it"
            )
    return todo


def commit(out_dir: Path, cell: Cell, outcome: CellOutcome) -> Path:
    """Write a finished cell's files, ``cell.json`` and ``cell.log`` under a partial
    name, then rename the folder to ``DIR/<cell>`` (atomic on one file system)."""
    out_dir = Path(out_dir)
    partial = out_dir / f"{PARTIAL_PREFIX}{cell.name}-{uuid.uuid4().hex[:8]}"
    for relative, data in outcome.files.items():
        path = partial / relative
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(data)
    partial.mkdir(parents=True, exist_ok=True)
    meta = {
        "cell": cell.name,
        "options": cell.options,
        "argv": list(cell.argv),
        "wall_s": round(outcome.wall_s, 3),
        "node": outcome.node,
        "node_id": outcome.node_id,
    }
    (partial / CELL_META).write_text(json.dumps(meta, indent=2))
    (partial / CELL_LOG).write_text(outcome.log)
    final = out_dir / cell.name
    os.rename(partial, final)
    failed_log(out_dir, cell.name).unlink(missing_ok=True)
    return final


def record_failure(out_dir: Path, outcome: CellOutcome) -> Path:
    path = failed_log(out_dir, outcome.name)
    path.write_text(f"{outcome.error}\n\n{outcome.log}")
    return path


def write_cells_csv(out_dir: Path, sweep: Sweep, failures: dict) -> Path:
    """Rewrite ``DIR/cells.csv``: each cell's options, then ``status`` (done, failed or
    pending), ``wall_s``, ``node``, ``node_id`` and ``error`` (``failures``: name ->
    CellOutcome of the cells that failed in this run). Written whole, then renamed."""
    out_dir = Path(out_dir)
    option_names = list(dict.fromkeys(name for cell in sweep.cells for name in cell.options))
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(["cell", *option_names, "status", "wall_s", "node", "node_id", "error"])
    for cell in sweep.cells:
        meta, failure = finished_meta(out_dir, cell.name), failures.get(cell.name)
        options = [cell.options.get(name, "") for name in option_names]
        if meta is not None:
            writer.writerow([cell.name, *options, "done", f"{meta['wall_s']:.1f}", meta["node"], meta["node_id"], ""])
        elif failure is not None:
            row = [cell.name, *options, "failed", f"{failure.wall_s:.1f}", failure.node, failure.node_id]
            writer.writerow([*row, failure.error])
        else:
            writer.writerow([cell.name, *options, "pending", "", "", "", ""])
    path, partial = out_dir / CELLS_CSV, out_dir / f"{PARTIAL_PREFIX}{CELLS_CSV}"
    partial.write_text(buffer.getvalue())
    os.replace(partial, path)
    return path
