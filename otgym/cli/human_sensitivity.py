"""``otgym experiment human-sensitivity``: how much Fig. 8's item (d) moves when each
assumed parameter of the simulated participants moves by -50 % and +50 %
(``otgym.experiments.human_sensitivity``)."""

from __future__ import annotations

import shlex
import time
from pathlib import Path

import typer

from otgym.cli import options

DEVELOPMENT_SEED = 90
"""The default: a development study seed (``otgym.experiments.seeds.DEVELOPMENT``);
sensitivity is a development tool, not a report."""


def _check_parameters(value: str) -> str:
    from otgym.experiments.human_sensitivity import parse_parameters

    try:
        parse_parameters(value)
    except ValueError as error:
        raise typer.BadParameter(str(error), param_hint="--parameters") from None
    return value


def register(experiment: typer.Typer) -> None:
    @experiment.command("human-sensitivity")
    def human_sensitivity(
        out: Path = options.out_dir(..., "Folder for sensitivity.csv, sensitivity.md, sensitivity.png, trials.csv."),
        participants: int = typer.Option(
            3, "--participants", min=2, max=100, help="Simulated participants per variant (the interval is over them)."
        ),
        trials: int = typer.Option(1, "--trials", min=1, max=100, help="Trials per participant, mode and variant."),
        parameters: str = typer.Option(
            "motor",
            "--parameters",
            metavar="NAMES",
            callback=_check_parameters,
            help="motor (the assumed HumanParams and population_cv, the population's spread), task (the "
            "ParticipantTask fields, each scale a group of its own: far slower), all, or comma-separated "
            "names.",
        ),
        seed: int = options.seed(
            DEVELOPMENT_SEED,
            "Study seed (population SEED; participant p's trial t meets scenario SEED * 10000 + p * TRIALS + t); "
            "the default is a development seed,",
        ),
        time_limit_s: float = options.time_limit_s(),
    ) -> None:
        """How much (d), shared control's success mean minus manual control's, moves when
        each assumed participant parameter is scaled by 0.5 and 1.5 (baseline once), on
        the same participants and scenarios, with 95 % t intervals over participants.

        Example: otgym experiment human-sensitivity --participants 3 --trials 1 --out results/human-sensitivity
        """
        from otgym.experiments.human_sensitivity import (
            check_arguments,
            parse_parameters,
            run_sensitivity,
            write_sensitivity,
        )
        from otgym.experiments.output_folder import check_out_dir
        from otgym.experiments.seeds import development_note

        names = parse_parameters(parameters)
        check_arguments(participants, trials, seed)
        check_out_dir(out)
        note = development_note("shared-control", seed, trials=participants * trials)
        if note:
            print(note, flush=True)
        command = "otgym experiment human-sensitivity " + shlex.join(
            [
                "--participants",
                str(participants),
                "--trials",
                str(trials),
                "--parameters",
                parameters,
                "--seed",
                str(seed),
                "--time-limit-s",
                f"{time_limit_s:g}",
                "--out",
                str(out),
            ]
        )
        start = time.monotonic()
        frame = run_sensitivity(
            names, participants, trials, seed, report=lambda line: print(line, flush=True), time_limit_s=time_limit_s
        )
        write_sensitivity(frame, out, command, note)
        print((out / "sensitivity.md").read_text())
        print(
            f"wrote {out}/sensitivity.csv, sensitivity.md, sensitivity.png, trials.csv "
            f"({len(frame)} trials, {(time.monotonic() - start) / 60:.1f} min)"
        )
