"""``otgym experiment shared-control``: the paper's Fig. 8 (a, b) with simulated participants."""

from __future__ import annotations

from pathlib import Path

import typer


def register(app: typer.Typer) -> None:
    experiment = typer.Typer(help="The paper's experiments with simulated participants.", no_args_is_help=True)
    app.add_typer(experiment, name="experiment")

    @experiment.command("shared-control")
    def shared_control(
        participants: int = typer.Option(8, "--participants", help="Simulated participants (at least 2)."),
        trials: int = typer.Option(8, "--trials", help="Trials per participant and mode."),
        modes: str = typer.Option("manual,autonomous,shared", "--modes", help="Comma-separated modes."),
        seed: int = typer.Option(0, "--seed", help="Seed of the participants and scenarios."),
        chip: str = typer.Option("default", "--chip", help="Chip name or PNG."),
        time_limit_s: float = typer.Option(300.0, "--time-limit-s", help="A trial not done by then ends unfinished."),
        out: Path = typer.Option(..., "--out", help="Folder for trials.csv, summary.*, stats.json, fig8.png."),
    ) -> None:
        """Manual, autonomous and shared control on the same seeded scenarios: success
        (obstacles avoided / encountered) and completion time per mode (Fig. 8 a, b)."""
        from otgym.experiments.output_folder import check_out_dir
        from otgym.experiments.shared_control import check_arguments, parse_modes, run_experiment, write_experiment

        chosen = parse_modes(modes)
        check_arguments(participants, trials, seed)
        if not 0 < time_limit_s <= 3600:
            raise ValueError(f"--time-limit-s must lie in (0, 3600], got {time_limit_s}")
        check_out_dir(out)
        frame = run_experiment(participants, trials, chosen, seed, chip, report=lambda line: print(line, flush=True),
                               time_limit_s=time_limit_s)
        checks = write_experiment(frame, out)
        print((out / "summary.md").read_text())
        for name, passed in checks.items():
            print(f"{'PASS' if passed else 'FAIL'}  {name}")
        print(f"wrote {out}/trials.csv, summary.csv, summary.md, stats.json, fig8.png, acceptance.json")
