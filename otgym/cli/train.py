"""``otgym train``: DQN speed control on a preset; writes policy.npz,
learning_curve.png and training.json."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.console import Console
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

from otgym.cli import options


def _check_preset(ctx: typer.Context, value: str | None) -> str | None:
    """A preset of the task given by ``--task`` (parsed before it)."""
    if value is not None:
        from otgym import tasks

        presets = tasks.load(ctx.params.get("task_name") or "speed-control").presets()
        if value not in presets:
            raise typer.BadParameter(f"{value!r} is not one of {', '.join(presets)}")
    return value


def register(app: typer.Typer) -> None:
    @app.command()
    def train(
        task_name: str = options.registered(
            "speed-control", "--task", "tasks", None, "Task to train (discrete actions)."
        ),
        preset: str = typer.Option(
            None, "--preset", metavar="NAME", callback=_check_preset, help="The task's preset (default: its first)."
        ),
        out: Path = options.out_dir(Path("results/train"), "Folder for the results."),
        steps: int = typer.Option(
            None, "--steps", min=1, max=10**9, help="Environment steps in all (default: the task's, else 200000)."
        ),
        envs: int = typer.Option(
            None, "--envs", min=1, max=2**20, help="Environments simulated at once (default: the task's, else 64)."
        ),
        seed: int = options.seed(0, "Random seed,"),
    ) -> None:
        """Train a DQN policy on a task with discrete actions; by default the paper's speed
        controller (planned path, learned speed).

        Example: otgym train --task speed-control --preset paper --steps 204800 --out results/train
        """
        from otgym import tasks
        from otgym.experiments.common.output_folder import check_out_dir
        from otgym.experiments.speed_control.train import train_task, write_training
        from otgym.rl.dqn import DQNConfig

        task = tasks.load(task_name)
        task_config = task.config(preset)
        config = DQNConfig(
            **{
                **task.dqn_config(task_config),
                **{name: value for name, value in (("n_envs", envs), ("total_env_steps", steps)) if value is not None},
            }
        )
        check_out_dir(out)
        console = Console()
        columns = (
            TextColumn("{task.description}"),
            BarColumn(),
            TextColumn("{task.completed}/{task.total} chunks"),
            TimeElapsedColumn(),
        )
        with Progress(*columns, console=console, transient=True) as progress:
            bar = progress.add_task("planning and compiling", total=config.n_chunks)

            def report(done: int, total: int) -> None:
                progress.update(bar, description="training", completed=done)

            params = task.make_params(task_config)
            try:
                result = train_task(task, params, config, seed, report, preset=preset)
            except ValueError as error:
                raise typer.BadParameter(str(error), param_hint="--task") from None
        summary = write_training(result, out)
        console.print(
            f"[bold]otgym train[/bold] ({task_name}, {result.meta['preset']}): {summary['episodes']} episodes, "
            f"{summary['env_steps']} steps in {summary['wall_s']} s; final mean return "
            f"{summary['final_mean_return']}"
        )
        console.print(f"wrote {out}/policy.npz, learning_curve.png, training.json")
