"""``otgym study run``: one participant's session of a study protocol in the window
(``otgym.study.protocol``, ``otgym.study.participants``, ``otgym.ui.study_run``).
``otgym study analyze``: Fig. 8 and the questionnaire scores from recorded study
sessions: folders with ``trials.csv``, or MCAP recordings (a ``session.mcap`` file, or
a folder of ``session*.mcap`` without ``trials.csv``), whose ``trial_end`` events carry
the trials' rows (``otgym.record.trials``)."""

from __future__ import annotations

import os
from pathlib import Path

import typer

from otgym.cli import options


def register(app: typer.Typer) -> None:
    study = typer.Typer(help="Run a study with people, and analyse recorded study sessions.", no_args_is_help=True)
    app.add_typer(study, name="study")

    @study.command("run")
    def run(
        protocol: Path = typer.Argument(
            ...,
            exists=True,
            file_okay=True,
            dir_okay=False,
            help="The study protocol (TOML; docs/study-protocol.toml).",
        ),
        participant: str = typer.Option(
            ...,
            "--participant",
            metavar="ID",
            help="The lab's participant id (letters, digits, _ . -); the data carry a pseudonym instead.",
        ),
        out: Path = options.out_dir(..., "The study's folder: one sub-folder per participant, named by pseudonym."),
        key: Path = typer.Option(
            None,
            "--key",
            file_okay=True,
            dir_okay=False,
            help="The file mapping participant ids to pseudonyms, kept apart from --out (default: DIR.key.csv beside it).",
        ),
        script: Path = typer.Option(
            None,
            "--script",
            exists=True,
            file_okay=True,
            dir_okay=False,
            help="Scripted questionnaire answers (TOML), pressed into the window's form: dry runs and tests.",
        ),
        headless: bool = typer.Option(False, "--headless", help="No window (SDL dummy drivers); for tests and CI."),
    ) -> None:
        """One participant's session: the instructions, the practice, each mode's trials
        in the participant's counterbalanced order (a Williams Latin square over
        participant numbers), the questionnaires after each mode. Run the same command
        again after a crash or a closed window: finished trials are kept, a cut one runs
        again, the next one starts.

        Example: otgym study run study-protocol.toml --participant lab-07 --out results/study
        """
        from otgym.study.participants import check_participant_id, default_key_path

        check_participant_id(participant)
        if out.exists() and not out.is_dir():
            raise ValueError(f"--out {out} is a file, not a folder")
        key = default_key_path(out) if key is None else key
        from otgym.study.participants import check_key

        check_key(out, key)
        from otgym.shared import MODES
        from otgym.study.protocol import load_answer_script, load_protocol

        answers = load_answer_script(script) if script is not None else None
        checked = load_protocol(protocol, MODES)
        if headless:
            os.environ["SDL_VIDEODRIVER"] = "dummy"
            os.environ["SDL_AUDIODRIVER"] = "dummy"
        from otgym.study.participants import start_participant
        from otgym.ui.study_run import run_study

        folder = start_participant(checked, participant, out, key, scripted=answers is not None)
        print(
            f"participant {folder.pseudonym} (number {folder.number}): modes in the order {', '.join(folder.order)}; "
            f"{len(folder.remaining())} of {len(folder.plan)} trial(s) to run",
            flush=True,
        )
        result = run_study(folder, answers)
        left = len(folder.remaining()) + len(folder.unanswered_blocks())
        print(
            f"{result['finished']} trial(s) finished this run; cut and to run again: {result['cut'] or 'none'}; "
            + ("the session is complete" if not left else f"{left} step(s) left: run the same command to resume")
            + f"; data in {folder.path}"
        )

    @study.command("analyze")
    def analyze(
        sources: list[Path] = typer.Argument(
            ...,
            exists=True,
            help="Study folders of otgym study run (one sub-folder per participant), "
            "session folders (trials.csv and, where answers were "
            "given, questionnaires.csv; without trials.csv, its "
            "session*.mcap recordings) or MCAP files; participant "
            "ids unique across them.",
        ),
        out: Path = options.out_dir(
            ...,
            "Folder for report.md, fig8.png, order_effects.png, questionnaire_scores.csv, summary.md, summary.csv, "
            "stats.json, analysis.json.",
        ),
    ) -> None:
        """Success and completion time per mode (Fig. 8 a, b) and, where answers were
        recorded, NASA-TLX and UEQ-S per mode (Fig. 8 c, d), with paired tests; mixed-effects
        models with a participant random effect and, for study folders, order effects
        (mode x block position); all in report.md.

        Example: otgym study analyze results/session-p1 results/session-p2 --out results/analysis
        """
        from otgym.experiments.common.output_folder import check_out_dir
        from otgym.study.analyze import analyze as run
        from otgym.study.participants import study_participants

        tables, orders = [], {}
        for path in sources:  # read before touching --out
            participants = study_participants(path)
            if participants is None:
                tables.append(_source(path))
                continue
            if not participants:
                raise ValueError(f"{path}: no participant of this study has finished a trial yet")
            for folder, order in participants.items():
                tables.append(folder)
                orders[folder.name] = order
        check_out_dir(out)
        result = run(tables, out, orders)
        print((out / "summary.md").read_text())
        print(f"panels: {'; '.join(result['panels'])}")
        print(
            f"wrote {out}/report.md, fig8.png, order_effects.png (study folders), questionnaire_scores.csv, "
            "summary.md, summary.csv, stats.json, analysis.json"
        )


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
