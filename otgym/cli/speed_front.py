"""``otgym experiment speed-front``: Table II as a front. Trains a family of speed
policies across the reward's failure penalty (and time cost), evaluates them, the
shipped policy and the six constant speeds on the same held-out episodes, and writes
front.csv, front_tests.csv, front.md, front.json and front.png."""

from __future__ import annotations

import shlex
from pathlib import Path

import typer

from otgym.cli import options
from otgym.experiments.common.seeds import REPORT_SEEDS


def register(experiment: typer.Typer) -> None:
    @experiment.command("speed-front")
    def speed_front(
        out: Path = options.out_dir(..., "Folder for front.csv, front_tests.csv, front.md, front.json, front.png."),
        penalties: str = options.numbers(
            "100,1000", "--penalties", "Failure penalties of the family's rewards (magnitudes; the paper preset: 100)."
        ),
        time_costs: str = options.numbers(
            "0.05", "--time-costs", "Time costs per control step (magnitudes; the paper preset: 0.05).", allow_zero=True
        ),
        seeds: int = typer.Option(3, "--seeds", min=1, max=100, help="Training seeds per reward."),
        steps: int = typer.Option(204_800, "--steps", min=64, max=10**9, help="Environment steps per training."),
        episodes: int = typer.Option(
            1024, "--episodes", min=1, max=2**20, help="Evaluation episodes, the same for every policy."
        ),
        seed: int = options.seed(
            REPORT_SEEDS["speed-front"],
            "Seed of the run (evaluation batches SEED.., training seeds drawn from it); "
            "the default is the held-out report seed,",
        ),
    ) -> None:
        """Safety against speed: a family of learned speed policies, the shipped policy and
        the constant speeds G1-G6 on the same episodes, with paired tests (McNemar, sign).

        Example: otgym experiment speed-front --penalties 100,1000 --seeds 3 --episodes 1024 --out results/front
        """
        from otgym.cli.options import parse_numbers
        from otgym.experiments.common.output_folder import check_out_dir
        from otgym.experiments.speed_front.config import FrontConfig

        config = FrontConfig(
            penalties=parse_numbers("--penalties", penalties),
            time_costs=parse_numbers("--time-costs", time_costs, allow_zero=True),
            seeds=seeds,
            steps=steps,
            episodes=episodes,
            seed=seed,
        )
        check_out_dir(out)
        command = "otgym experiment speed-front " + shlex.join(
            [
                "--penalties",
                penalties,
                "--time-costs",
                time_costs,
                "--seeds",
                str(seeds),
                "--steps",
                str(steps),
                "--episodes",
                str(episodes),
                "--seed",
                str(seed),
                "--out",
                str(out),
            ]
        )
        run_and_write(config, out, command)


def run_and_write(config, out: Path, command: str) -> None:
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    from otgym.experiments.common.seeds import development_note
    from otgym.experiments.speed_front.config import training_seeds
    from otgym.experiments.speed_front.report import write_front
    from otgym.experiments.speed_front.run import run_front
    from otgym.rl.policy import PRETRAINED_POLICY, load_policy
    from otgym.tasks.transport import core as tr

    console = Console()
    note = development_note("speed-front", config.seed, batches=config.batches)
    if note:
        console.print(note, style="bold yellow", markup=False)
    console.print(
        f"speed-front: {config.trainings} trainings ({len(config.rewards)} rewards x {config.seeds} seeds "
        f"{training_seeds(config.seed, config.seeds)}, {config.steps} steps each), then {config.total_episodes} "
        f"episodes (seeds {config.seed}-{config.seed + config.batches - 1}) for 6 constant speeds, the shipped "
        f"policy and the family"
    )
    q_params, meta = load_policy(PRETRAINED_POLICY, tr.OBS_SIZE, 6)
    columns = (
        TextColumn("{task.description}"),
        BarColumn(),
        TextColumn("{task.completed}/{task.total}"),
        TimeElapsedColumn(),
    )
    with Progress(*columns, console=console) as progress:
        bars = {
            "train": progress.add_task("training the family", total=config.trainings),
            "evaluate": progress.add_task("evaluating (policy runs)", total=None),
        }

        def report(stage: str, done: int, total: int) -> None:
            progress.update(bars[stage], completed=done, total=total)
            if done:
                progress.console.print(f"{stage}: {done}/{total} done")

        result = run_front(config, report, pretrained_q=(q_params, tuple(meta["hidden"])))
    summary = write_front(result, out, command)
    console.print((out / "front.md").read_text())
    if note:
        console.print(note, style="bold yellow", markup=False)
    console.print(
        f"wrote {out}/front.csv, front_episodes.npz, front_tests.csv, front.md, front.json, front.png "
        f"({len(summary.rows)} rows, {result.wall_s / 60:.1f} min)"
    )
