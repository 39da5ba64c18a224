"""``otgym experiment human-sensitivity``: which assumed parameters of the simulated
participants decide Fig. 8's (b) and (d), by Morris screening or Sobol indices
(``otgym.experiments.human_sensitivity``)."""

from __future__ import annotations

import shlex
import time
from pathlib import Path

import typer

from otgym.cli import options

DEVELOPMENT_SEED = 90
"""The default: a development study seed (``otgym.experiments.common.seeds.DEVELOPMENT``);
sensitivity is a development tool, not a report."""


def _check_parameters(value: str) -> str:
    from otgym.experiments.human_sensitivity.config import parse_parameters

    try:
        parse_parameters(value)
    except ValueError as error:
        raise typer.BadParameter(str(error), param_hint="--parameters") from None
    return value


def _check_method(value: str) -> str:
    from otgym.experiments.human_sensitivity.config import METHODS

    if value not in METHODS:
        raise typer.BadParameter(f"must be one of {', '.join(METHODS)}, got {value!r}", param_hint="--method")
    return value


def _check_samples(value: int) -> int:
    if value & (value - 1):
        raise typer.BadParameter(f"must be a power of 2 (Sobol's sequence), got {value}", param_hint="--samples")
    return value


def register(experiment: typer.Typer) -> None:
    @experiment.command("human-sensitivity")
    def human_sensitivity(
        out: Path = options.out_dir(
            ..., "Folder for sensitivity.md, sensitivity.png, indices.csv, samples.csv, trials.csv."
        ),
        method: str = typer.Option(
            "morris",
            "--method",
            metavar="NAME",
            callback=_check_method,
            help="morris (screening every assumption) or sobol (first and total indices of a few).",
        ),
        parameters: str = typer.Option(
            "all",
            "--parameters",
            metavar="NAMES",
            callback=_check_parameters,
            help="all (every assumed parameter of otgym.human.assumptions) or comma-separated labels "
            "(cv_NAME for a population spread); the others stay at the model's values.",
        ),
        trajectories: int = typer.Option(
            2, "--trajectories", min=2, max=1000, help="Morris: trajectories (samples = TRAJECTORIES x (k + 1))."
        ),
        samples: int = typer.Option(
            8,
            "--samples",
            min=2,
            max=65536,
            callback=_check_samples,
            help="Sobol: base sample, a power of 2 (samples = SAMPLES x (k + 2)).",
        ),
        participants: int = typer.Option(
            2, "--participants", min=1, max=100, help="Simulated participants per sample (the same in every sample)."
        ),
        trials: int = typer.Option(1, "--trials", min=1, max=100, help="Trials per participant, mode and sample."),
        seed: int = options.seed(
            DEVELOPMENT_SEED,
            "Study seed (population SEED; participant p's trial t meets scenario SEED * 10000 + p * TRIALS + t; "
            "the design's sampling and bootstrap); the default is a development seed,",
        ),
        time_limit_s: float = options.time_limit_s(),
    ) -> None:
        """Which assumed parameters of the simulated participants decide Fig. 8's (b),
        manual / shared time, and (d), shared - manual success: Morris' mu* and sigma
        over every assumed parameter, or Sobol's S1 and ST over a few, with 95 %
        bootstrap intervals, on common participants and scenarios (SALib).

        Example: otgym experiment human-sensitivity --method morris --parameters carry_speed_um_s,horizon_s --trajectories 2 --participants 1 --time-limit-s 5 --out results/human-sensitivity
        """
        from otgym.experiments.common.output_folder import check_out_dir
        from otgym.experiments.common.seeds import development_note
        from otgym.experiments.human_sensitivity.config import check_arguments, parse_parameters, size_of
        from otgym.experiments.human_sensitivity.report import write_report
        from otgym.experiments.human_sensitivity.run import analyse, design, run_design, sample_outputs

        labels = parse_parameters(parameters)
        size = trajectories if method == "morris" else samples
        check_arguments(method, size, participants, trials, seed)
        check_out_dir(out)
        note = development_note("shared-control", seed, trials=participants * trials)
        if note:
            print(note, flush=True)
        size_option = ["--trajectories", str(trajectories)] if method == "morris" else ["--samples", str(samples)]
        command = "otgym experiment human-sensitivity " + shlex.join(
            ["--method", method, "--parameters", parameters, *size_option]
            + ["--participants", str(participants), "--trials", str(trials), "--seed", str(seed)]
            + ["--time-limit-s", f"{time_limit_s:g}", "--out", str(out)]
        )
        start = time.monotonic()
        print(f"{method}: {len(labels)} parameters and a dummy, {size_of(method, size, len(labels) + 1)} samples")
        points = design(method, labels, size, seed)
        frame = run_design(
            points,
            labels,
            participants,
            trials,
            seed,
            report=lambda line: print(line, flush=True),
            time_limit_s=time_limit_s,
        )
        outputs = sample_outputs(frame, len(points), time_limit_s)
        indices = analyse(method, points, outputs, labels, seed)
        write_report(method, labels, points, frame, outputs, indices, out, command, note)
        print((out / "sensitivity.md").read_text())
        print(
            f"wrote {out}/sensitivity.md, sensitivity.png, indices.csv, samples.csv, trials.csv "
            f"({len(frame)} trials, {(time.monotonic() - start) / 60:.1f} min)"
        )
