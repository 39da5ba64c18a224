"""``otgym experiment learned-speed`` and ``fig8-json``: how two of the files shipped
with otgym are made: the interactive task's learned speed policy (navigator ``rl``,
``otgym.experiments.learned_speed.train``) and the shared-control report runs the
demo's report quotes (``otgym.experiments.demo.shipped_results``)."""

from __future__ import annotations

from pathlib import Path

import typer


def check_runs(values: list[str]) -> list[tuple[str, Path]]:
    """Each value ``LABEL=DIR``: a label and a finished shared-control output folder;
    ValueError naming the first that is not."""
    runs = []
    for value in values:
        label, sep, folder = value.partition("=")
        if not sep or not label or not folder:
            raise ValueError(f"LABEL=DIR: give a label and a run folder, got {value!r}")
        for name in ("summary.csv", "acceptance.json", "stats.json", "command.txt"):
            if not (Path(folder) / name).is_file():
                raise ValueError(f"LABEL=DIR {value}: {Path(folder) / name} is missing (not a finished run)")
        runs.append((label, Path(folder)))
    return runs


def register(experiment: typer.Typer) -> None:
    @experiment.command("learned-speed")
    def learned_speed(
        out: Path = typer.Option(
            None,
            "--out",
            file_okay=True,
            dir_okay=False,
            metavar="FILE",
            help="Where to write the policy (.npz); default: the shipped otgym/data/policies/speed_interactive.npz.",
        ),
    ) -> None:
        """Train the interactive task's learned speed policy (navigator rl): otgym train on
        task interactive-speed with its registered training seed and scenarios, and write it.

        Example: otgym experiment learned-speed --out speed_interactive.npz
        """
        if out is not None and not out.parent.is_dir():
            raise ValueError(f"--out: {out.parent} is not a folder")
        from otgym.autonomy.rl_navigator import SPEED_POLICY
        from otgym.experiments.learned_speed.train import TRAINING_SEED, save_speed_policy, train

        path = SPEED_POLICY if out is None else out
        result = train(TRAINING_SEED, progress=lambda done, total: print(f"chunk {done}/{total}", flush=True))
        save_speed_policy(path, result)
        print(f"{result.episodes} episodes, {result.env_steps} decisions in {result.wall_s:.0f} s; wrote {path}")

    @experiment.command("fig8-json")
    def fig8_json(
        runs: list[str] = typer.Argument(
            ..., metavar="LABEL=DIR", help="A label and a shared-control output folder, each."
        ),
        out: Path = typer.Option(
            ..., "--out", file_okay=True, dir_okay=False, metavar="FILE", help="The JSON file to write (fig8.json)."
        ),
    ) -> None:
        """Collect finished shared-control run folders (their summary.csv, acceptance.json,
        stats.json and command.txt) into one JSON file, as otgym/data/results/fig8.json is made.

        Example: otgym experiment fig8-json --out fig8.json route=results/fig8-route
        """
        import json

        from otgym.experiments.demo.shipped_results import collect_fig8_run

        collected = [collect_fig8_run(label, folder) for label, folder in check_runs(runs)]
        out.write_text(json.dumps({"runs": collected}, indent=2) + "\n")
        print(f"wrote {out}: {len(collected)} run(s)")
