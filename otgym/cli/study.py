"""``otgym study analyze``: Fig. 8 and the questionnaire scores from recorded study sessions."""

from __future__ import annotations

from pathlib import Path

import typer


def register(app: typer.Typer) -> None:
    study = typer.Typer(help="Analyse recorded study sessions.", no_args_is_help=True)
    app.add_typer(study, name="study")

    @study.command("analyze")
    def analyze(
        dirs: list[Path] = typer.Argument(..., help="Session folders, each with trials.csv and, where answers "
                                                    "were given, questionnaires.csv; participant ids unique "
                                                    "across folders."),
        out: Path = typer.Option(..., "--out", help="Folder for fig8.png, questionnaire_scores.csv, summary.md, "
                                                    "summary.csv, stats.json, analysis.json."),
    ) -> None:
        """Success and completion time per mode (Fig. 8 a, b) and, where answers were
        recorded, NASA-TLX and UEQ-S per mode (Fig. 8 c, d), with paired tests."""
        from otgym.experiments.output_folder import check_out_dir
        from otgym.study.analyze import analyze as run

        for folder in dirs:  # before touching --out
            if not folder.is_dir():
                raise FileNotFoundError(f"no study folder {folder}")
        check_out_dir(out)
        result = run(dirs, out)
        print((out / "summary.md").read_text())
        print(f"panels: {'; '.join(result['panels'])}")
        print(f"wrote {out}/fig8.png, questionnaire_scores.csv, summary.md, summary.csv, stats.json, analysis.json")
