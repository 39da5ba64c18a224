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
        policy: str = typer.Option("pretrained", "--policy", help="Speed-control policy file or 'pretrained'."),
        episodes: int = typer.Option(256, "--episodes", help="Speed-control episodes per policy (RL, G1..G6)."),
        speed_um_s: float = typer.Option(4.0, help="Constant speed of the whole-path transport, um/s."),
        runs: int = typer.Option(8, help="Whole-path transports simulated at once (own noise and obstacles)."),
        seed: int = typer.Option(1, help="Random seed of the episodes and runs."),
    ) -> None:
        """Plan on the default chip (Table I), evaluate the pretrained speed controller
        against constant speeds (Table II, safety violins), carry the cell along the
        whole path, and write report.md beside the paper's numbers."""
        from otgym.experiments.demo import DemoConfig, run_demo
        from otgym.experiments.transport import TransportDemo

        console = Console()
        config = DemoConfig(policy=policy, episodes=episodes, seed=seed,
                            transport=TransportDemo(speed_um_s=speed_um_s, n_runs=runs, seed=seed))
        columns = (TextColumn("{task.description}"), BarColumn(), TextColumn("{task.completed}/{task.total}"),
                   TimeElapsedColumn())
        with Progress(*columns, console=console, transient=True) as progress:
            task = progress.add_task("starting", total=None)

            def stage(text: str) -> None:
                console.print(f"- {text}")
                progress.update(task, description=text, completed=0, total=None)

            def report(done: int, total: int) -> None:
                progress.update(task, completed=done, total=total)

            summary = run_demo(config, out, stage, report)
        console.print((out / "speed_control" / "table.md").read_text(), markup=False, soft_wrap=True)
        safety, limits, transport = summary["safety"]["RL"], summary["limits"], summary["transport"]
        console.print(f"RL safety: contact force < {limits['force_pn']:g} pN in {safety['force_below_limit']:.2%} of "
                      f"steps, handle within {limits['distance_um']:g} um in {safety['distance_within_limit']:.2%}")
        console.print(f"whole path: {transport['reached_goal']} of {transport['runs']} runs carried the cell "
                      f"{transport['path_length_um']} um at {speed_um_s:g} um/s")
        console.print(f"[bold]otgym demo[/bold] wrote {out}/report.md, summary.json, plan/, speed_control/, transport/")
