"""``otgym demo``: the main job, a headless run that writes its results to a folder."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.console import Console
from rich.progress import Progress


def register(app: typer.Typer) -> None:
    @app.command()
    def demo(
        out: Path = typer.Option(Path("results"), "--out", help="Folder for the results."),
        speed_um_s: float = typer.Option(5.0, help="Trap speed in um/s."),
        seed: int = typer.Option(0, help="Random seed."),
    ) -> None:
        """Simulate a trapped microrobot and write trajectory.csv, trajectory.png, summary.json."""
        from otgym.experiments.trapped_robot import TrappedRobotDemo, run

        console = Console()
        demo_config = TrappedRobotDemo(speed_um_s=speed_um_s, seed=seed)
        with Progress(console=console, transient=True) as progress:
            task = progress.add_task("simulating", total=None)
            summary = run(demo_config, out, lambda done, total: progress.update(task, completed=done, total=total))
        console.print(f"[bold]otgym demo[/bold] wrote {out}/trajectory.csv, trajectory.png, summary.json")
        for name, value in summary.items():
            console.print(f"  {name}: {value}")
