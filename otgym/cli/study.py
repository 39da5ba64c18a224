"""``otgym study analyze``: Fig. 8 and the questionnaire scores from recorded study
sessions: folders with ``trials.csv``, or MCAP recordings (a ``session.mcap`` file, or
a folder of ``session*.mcap`` without ``trials.csv``), whose ``trial_end`` events carry
the trials' rows (``otgym.record.trials``)."""

from __future__ import annotations

from pathlib import Path

import typer

from otgym.cli import options


def register(app: typer.Typer) -> None:
    study = typer.Typer(help="Analyse recorded study sessions.", no_args_is_help=True)
    app.add_typer(study, name="study")

    @study.command("analyze")
    def analyze(
        sources: list[Path] = typer.Argument(
            ...,
            exists=True,
            help="Session folders (trials.csv and, where answers were "
            "given, questionnaires.csv; without trials.csv, its "
            "session*.mcap recordings) or MCAP files; participant "
            "ids unique across them.",
        ),
        out: Path = options.out_dir(
            ..., "Folder for fig8.png, questionnaire_scores.csv, summary.md, summary.csv, stats.json, analysis.json."
        ),
    ) -> None:
        """Success and completion time per mode (Fig. 8 a, b) and, where answers were
        recorded, NASA-TLX and UEQ-S per mode (Fig. 8 c, d), with paired tests.

        Example: otgym study analyze results/session-p1 results/session-p2 --out results/analysis
        """
        from otgym.experiments.output_folder import check_out_dir
        from otgym.study.analyze import analyze as run

        tables = [_source(path) for path in sources]  # before touching --out
        check_out_dir(out)
        result = run(tables, out)
        print((out / "summary.md").read_text())
        print(f"panels: {'; '.join(result['panels'])}")
        print(f"wrote {out}/fig8.png, questionnaire_scores.csv, summary.md, summary.csv, stats.json, analysis.json")


def _source(path: Path):
    """A folder with trials.csv as it is; MCAP recordings as a ``StudyTable`` of their
    trial_end rows (a folder's with its questionnaires.csv)."""
    import pandas as pd

    from otgym.record.trials import SESSION_PATTERN, folder_recordings, trial_rows
    from otgym.study.analyze import StudyTable

    if path.is_file():
        return StudyTable(str(path), pd.DataFrame(trial_rows(path)))
    if not path.is_dir():
        raise FileNotFoundError(f"no study folder or recording {path}")
    recordings = folder_recordings(path)
    if (path / "trials.csv").is_file() or not recordings:
        return path  # study.analyze reads it (and says so if it has no trials.csv)
    answers = path / "questionnaires.csv"
    rows = [row for recording in recordings for row in trial_rows(recording)]
    print(f"{path}: trials from {', '.join(r.name for r in recordings)} (no trials.csv; pattern {SESSION_PATTERN})")
    return StudyTable(str(path), pd.DataFrame(rows), answers if answers.is_file() else None)
