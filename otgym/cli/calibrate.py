"""``otgym experiment calibrate-scenarios``: sweep one scenario parameter and measure
the autonomous mode's obstacles avoided against the paper's 59 %
(``otgym.experiments.calibration.run``)."""

from __future__ import annotations

import shlex
from pathlib import Path

import typer

from otgym.cli import options


def _check_values(value: str) -> str:
    from otgym.experiments.calibration.run import parse_values

    try:
        parse_values(value)
    except ValueError as error:
        raise typer.BadParameter(str(error), param_hint="--values") from None
    return value


def register(experiment: typer.Typer) -> None:
    from otgym.experiments.calibration.config import DEFAULT_SEED, SWEEPABLE  # light: no JAX at registration

    @experiment.command("calibrate-scenarios")
    def calibrate_scenarios(
        values: str = typer.Option(
            "timing_jitter_s=8,15,20",
            "--values",
            metavar="NAME=NUMBERS",
            callback=_check_values,
            help=f"The scenario parameter and its values, NAME=V1,V2,...; NAME one of {', '.join(SWEEPABLE)}.",
        ),
        trials: int = typer.Option(
            64, "--trials", min=1, max=1000, help="Scenarios per value (trial t: scenario SEED * 10000 + t)."
        ),
        seed: int = options.seed(
            DEFAULT_SEED,
            "Study seed of the scenarios and the simulation; calibration is development, so the default is the "
            "development seed of the original calibration,",
        ),
        chip: str = options.chip("default"),
        time_limit_s: float = options.time_limit_s(
            help="A trial not done by then ends unfinished, in s (obstacles beyond are not met)."
        ),
        out: Path = options.out_dir(..., "Folder for calibration.csv, calibration.md, calibration.png."),
    ) -> None:
        """The autonomous mode's share of obstacles avoided for each value of one scenario
        parameter, with 95 % Wilson intervals, against the paper's autonomous success (59 %).

        Example: otgym experiment calibrate-scenarios --values timing_jitter_s=8,15,20 --trials 64 --out results/calibration
        """
        from otgym.experiments.calibration.run import parse_values, run_calibration, seed_note, write_calibration
        from otgym.experiments.common.output_folder import check_out_dir

        name, numbers = parse_values(values)
        check_out_dir(out)
        note = seed_note(seed, trials)
        print(note, flush=True)
        command = "otgym experiment calibrate-scenarios " + shlex.join(
            ["--values", values, "--trials", str(trials), "--seed", str(seed)]
            + (["--chip", chip] if chip != "default" else [])
            + (["--time-limit-s", f"{time_limit_s:g}"] if time_limit_s != 300.0 else [])
            + ["--out", str(out)]
        )
        frame = run_calibration(
            name, numbers, trials, seed, chip, time_limit_s, report=lambda line: print(line, flush=True)
        )
        write_calibration(frame, out, command, note)
        print((out / "calibration.md").read_text())
        print(f"wrote {out}/calibration.csv, calibration_trials.csv, calibration.md, calibration.png")
