"""Sweep throughput: training seeds run one after another and as Ray tasks, in one run.

1. ``--seeds`` training cells (``otgym train --steps S --envs E --seed k``) through
   ``otgym sweep``'s engine, serially in this process (the reference), then on a Ray
   started here with ``--workers`` workers; both wall times, their ratio, and a check
   that every cell's policy is bitwise the same in both.
2. Ray's overhead per cell: sweeps of ``--noop-cells`` / 4 and ``--noop-cells`` cells
   of a command that returns at once, on the same Ray setup (task submission,
   scheduling, the files' way back, putting the cell in place): the difference of their
   wall times x workers / the difference of cells (Ray's start and stop cancel), against
   the mean training cell.
   The end-to-end figure is printed too: (workers x Ray wall - sum of the cells' own
   wall times) / cells, which also counts Ray's start and each worker's imports.

The load average (1 min) is printed at the start and after each part: the figures are
only as good as the machine was quiet.

Run: python benchmarks/sweep.py [--seeds 8] [--steps 3200] [--envs 16] [--workers 2] [--noop-cells 40]
Goals (issue 31): Ray >= 1.7x serial with 2 workers; overhead <= 5 % of a training cell.
"""

from __future__ import annotations

import argparse
import io
import os
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np
from rich.console import Console

from otgym.cli.app import app, main, register_commands
from otgym.cli.sweep import command_specs
from otgym.cluster.engine import run_sweep
from otgym.cluster.sweep_file import CommandSpec, OptionSpec, load_sweep


def noop_command(argv: list[str]) -> None:
    """A command that writes one small file and returns: what Ray costs a cell beyond its work."""
    out = Path(argv[argv.index("--out") + 1])
    out.mkdir(parents=True, exist_ok=True)
    (out / "done.txt").write_text("done\n")


NOOP = CommandSpec(("noop",), {"index": OptionSpec("index", "--index", "int")})


def load() -> str:
    return f"{os.getloadavg()[0]:.2f}"


def sweep_file(folder: Path, text: str) -> Path:
    path = folder / "sweep.toml"
    path.write_text(text)
    return path


def timed(sweep, out: Path, entry_point, **where) -> tuple[float, list]:
    out.mkdir(parents=True)
    console = Console(file=io.StringIO())
    start = time.perf_counter()
    run = run_sweep(sweep, out, entry_point, console=console, **where)
    wall_s = time.perf_counter() - start
    if run.failed:
        raise SystemExit(f"{len(run.failed)} cells failed: {run.failed[0].error}")
    return wall_s, run.done


def same_policies(first: Path, second: Path, names: list[str]) -> bool:
    for name in names:
        with np.load(first / name / "policy.npz") as a, np.load(second / name / "policy.npz") as b:
            if a.files != b.files or any(a[key].tobytes() != b[key].tobytes() for key in a.files):
                return False
    return True


def main_benchmark() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=8)
    parser.add_argument("--steps", type=int, default=3200)
    parser.add_argument("--envs", type=int, default=16)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--noop-cells", type=int, default=40)
    args = parser.parse_args()
    register_commands()
    print(f"machine: {os.cpu_count()} CPU cores; load average (1 min) at start {load()}")
    with tempfile.TemporaryDirectory(prefix="otgym-sweep-bench-") as folder:
        folder = Path(folder)
        text = (
            f'command = "train"\n[options]\nsteps = {args.steps}\nenvs = {args.envs}\n'
            f"[grid]\nseed = {list(range(args.seeds))}\n"
        )
        sweep = load_sweep(sweep_file(folder, text), command_specs(app))
        names = [cell.name for cell in sweep.cells]
        print(f"{args.seeds} training cells: otgym train --steps {args.steps} --envs {args.envs} --seed 0..")
        serial_s, serial_cells = timed(sweep, folder / "serial", main, serial=True)
        print(f"  serial (one process):        {serial_s:8.1f} s   load {load()}")
        ray_s, ray_cells = timed(sweep, folder / "ray", main, workers=args.workers)
        print(f"  Ray, {args.workers} workers:              {ray_s:8.1f} s   load {load()}")
        print(f"  speed-up serial / Ray: {serial_s / ray_s:.2f}x (goal >= 1.7x with 2 workers)")
        same = same_policies(folder / "serial", folder / "ray", names)
        print(f"  policies bitwise the same serially and on Ray: {same}")
        cell_s = statistics.mean(outcome.wall_s for outcome in ray_cells)
        serial_cell_s = statistics.mean(outcome.wall_s for outcome in serial_cells)
        print(f"  mean training cell: {serial_cell_s:.1f} s serially, {cell_s:.1f} s on Ray (each cell's own clock)")
        end_to_end = (args.workers * ray_s - sum(outcome.wall_s for outcome in ray_cells)) / args.seeds
        print(
            f"  end-to-end Ray overhead per cell (Ray start, worker imports, tasks): {end_to_end:.1f} s "
            f"= {100 * end_to_end / cell_s:.1f} % of a training cell"
        )
        walls = {}
        for count in (max(args.workers, args.noop_cells // 4), args.noop_cells):
            noop_text = f'command = "noop"\n[grid]\nindex = {list(range(count))}\n'
            noop = load_sweep(sweep_file(folder, noop_text), {"noop": NOOP})
            walls[count], _ = timed(noop, folder / f"noop{count}", noop_command, workers=args.workers)
        (few, few_s), (many, many_s) = sorted(walls.items())
        per_cell = (many_s - few_s) * args.workers / (many - few)
        print(
            f"no-op cells on Ray, {args.workers} workers: {few} in {few_s:.1f} s, {many} in {many_s:.1f} s "
            f"(each with Ray's start); the difference gives {per_cell:.2f} s per cell per worker "
            f"= {100 * per_cell / cell_s:.1f} % of a training cell (goal <= 5 %); load {load()}"
        )


if __name__ == "__main__":
    main_benchmark()
