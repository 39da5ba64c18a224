"""``otgym demo``: the main job, a headless run that writes its results to a folder."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.console import Console
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn


def register(app: typer.Typer) -> None:
    @app.command()
    def demo(
        out: Path = typer.Option(Path("results"), "--out", help="Folder for the results."),
        speed_um_s: float = typer.Option(4.0, help="Constant transport speed along the path, um/s."),
        runs: int = typer.Option(8, help="Environments simulated at once (same start, own noise and obstacles)."),
        seed: int = typer.Option(0, help="Random seed."),
    ) -> None:
        """Two microrobots carry a cell through the default chip along a planned path:
        writes path.csv, trajectory.csv, transport.png and summary.json."""
        from otgym.experiments.transport import TransportDemo, run

        console = Console()
        config = TransportDemo(speed_um_s=speed_um_s, n_runs=runs, seed=seed)
        columns = (TextColumn("{task.description}"), BarColumn(), TextColumn("{task.completed}/{task.total} steps"),
                   TimeElapsedColumn())
        with Progress(*columns, console=console, transient=True) as progress:
            task = progress.add_task("planning and compiling", total=None)

            def report(done: int, total: int) -> None:
                progress.update(task, description="carrying the cell", completed=done, total=total)

            summary = run(config, out, report)
        console.print(f"[bold]otgym demo[/bold]: {summary['reached_goal']} of {summary['runs']} runs carried the "
                      f"cell {summary['path_length_um']} um to the goal at {speed_um_s:g} um/s")
        console.print(f"wrote {out}/path.csv, trajectory.csv, transport.png, summary.json")
        for name in ("mean_completed_fraction", "mean_contact_force_pn", "max_contact_force_pn", "max_trap_distance_um"):
            console.print(f"  {name}: {summary[name]}")
