"""``otgym study analyze``: the study's results from one or more session folders, each
holding a ``trials.csv`` (one row per trial, written by ``otgym experiment shared-control``
or ``otgym play``) and, where answers were given, a ``questionnaires.csv``
(``otgym.study.questionnaires``), or from ``StudyTable`` s: trials read elsewhere (the
command line reads them from MCAP recordings, ``otgym.record.trials``).

The folders' tables are concatenated: participant ids must be unique across folders (the
same id in two folders is read as the same person), and a (participant, mode, trial)
given twice is refused. Writes Fig. 8 (``figures.plot_fig8``: a, b always; c, d only
from recorded answers, never invented), ``questionnaire_scores.csv``, ``summary.md``
(with ``summary.csv`` and ``stats.json`` as the experiment writes them) and
``analysis.json`` (inputs, panels drawn, questionnaire tests)."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pandas as pd

from otgym.study.figures import plot_fig8
from otgym.study.mixed import study_models
from otgym.study.questionnaire_stats import TLX_MEASURES, UEQ_MEASURES, compare_measures
from otgym.study.questionnaires import SCORE_COLUMNS, participant_measures, read_answers, score, validate_answers
from otgym.study.report import plot_order_effects, write_report
from otgym.study.stats import ordered_modes
from otgym.study.summary import json_safe, write_summary

TRIALS_COLUMNS = [
    "participant",
    "mode",
    "trial",
    "scenario",
    "completion_time_s",
    "obstacles_encountered",
    "obstacles_avoided",
    "success",
    "reached_goal",
    "trap_losses",
    "detached",
    "peak_contact_force_pn",
]
"""The columns every ``trials.csv`` must have (others are kept and ignored)."""

_COUNTS = ("trial", "scenario", "obstacles_encountered", "obstacles_avoided", "trap_losses")
_FLAGS = ("reached_goal", "detached")


def _check_trials(frame: pd.DataFrame, source: Path) -> pd.DataFrame:
    """ValueError naming ``source`` and the first bad column: missing columns, empty ids,
    counts that are not whole numbers >= 0, avoided > encountered, success outside
    [0, 1], negative or non-finite time or force, flags that are not true/false."""
    missing = [column for column in TRIALS_COLUMNS if column not in frame.columns]
    if missing:
        raise ValueError(f"{source} lacks column(s) {missing}")
    if frame.empty:
        raise ValueError(f"{source} has no trials")
    frame = frame.copy()
    for column in ("participant", "mode"):
        if frame[column].isna().any() or (frame[column].str.strip() == "").any():
            raise ValueError(f"{source}: empty {column} in some row")
        frame[column] = frame[column].str.strip()
    for column in _COUNTS:
        values = pd.to_numeric(frame[column], errors="coerce")
        if values.isna().any() or (values < 0).any() or (values != np.round(values)).any():
            raise ValueError(f"{source}: {column} must be a whole number >= 0 in every row")
        frame[column] = values.astype(int)
    if (frame["obstacles_avoided"] > frame["obstacles_encountered"]).any():
        raise ValueError(f"{source}: obstacles_avoided exceeds obstacles_encountered in some row")
    for column, low, high in (
        ("completion_time_s", 0.0, np.inf),
        ("peak_contact_force_pn", 0.0, np.inf),
        ("success", 0.0, 1.0),
    ):
        values = pd.to_numeric(frame[column], errors="coerce")
        allowed_nan = column == "success"  # a trial that met no obstacle has no success rate
        bad = (values < low) | (values > high) | np.isinf(values) | (values.isna() if not allowed_nan else False)
        if bad.any():
            raise ValueError(
                f"{source}: {column} must lie in [{low:g}, {high:g}]"
                f"{' (or be empty)' if allowed_nan else ''} in every row; got {frame[column][bad].iloc[0]}"
            )
        frame[column] = values
    for column in _FLAGS:
        text = frame[column].astype(str).str.strip().str.lower()
        if not text.isin(["true", "false", "1", "0"]).all():
            raise ValueError(f"{source}: {column} must be true or false in every row")
        frame[column] = text.isin(["true", "1"])
    return frame


@dataclasses.dataclass(frozen=True)
class StudyTable:
    """Trials read elsewhere (e.g. from MCAP recordings, ``otgym.record.trials``): a
    name for messages, the rows (``TRIALS_COLUMNS`` at least) and the path of their
    questionnaire answers, if any."""

    source: str
    trials: pd.DataFrame
    answers: Path | None = None


def _folder_table(folder: Path) -> StudyTable:
    if not folder.is_dir():
        raise FileNotFoundError(f"no study folder {folder}")
    path = folder / "trials.csv"
    if not path.is_file():
        raise FileNotFoundError(f"{folder} has no trials.csv (nor session*.mcap recordings)")
    answers = folder / "questionnaires.csv"
    return StudyTable(
        str(path), pd.read_csv(path, dtype={"participant": str, "mode": str}), answers if answers.is_file() else None
    )


def _name(source) -> str:
    """A source as messages and ``analysis.json`` name it: a folder, or a table's source."""
    return source.source if isinstance(source, StudyTable) else str(source)


def load_study(sources) -> tuple[pd.DataFrame, pd.DataFrame | None]:
    """The trials of all ``sources`` (folders holding ``trials.csv`` and maybe
    ``questionnaires.csv``, or ``StudyTable`` s) concatenated (with a ``source``
    column), and their questionnaire answers (None if none has any). Answers must
    belong to a trial of their own source. FileNotFoundError or ValueError, one line."""
    trials, answers = [], []
    for given in sources:
        table = given if isinstance(given, StudyTable) else _folder_table(Path(given))
        checked = _check_trials(table.trials, table.source)
        trials.append(checked.assign(source=_name(given)))
        if table.answers is not None:
            answered = read_answers(table.answers)
            known = set(zip(checked["participant"], checked["mode"], checked["trial"]))
            orphans = [
                key for key in zip(answered["participant"], answered["mode"], answered["trial"]) if key not in known
            ]
            if orphans:
                raise ValueError(
                    f"{table.answers} answers (participant, mode, trial) {orphans[0]} that {table.source} lacks"
                )
            answers.append(answered)
    trials = pd.concat(trials, ignore_index=True)
    twice = trials[trials.duplicated(["participant", "mode", "trial"], keep=False)]
    if len(twice):
        first = twice.iloc[0]
        where = sorted(
            set(
                twice.loc[
                    (twice["participant"] == first["participant"])
                    & (twice["mode"] == first["mode"])
                    & (twice["trial"] == first["trial"]),
                    "source",
                ]
            )
        )
        raise ValueError(
            f"participant {first['participant']}, mode {first['mode']}, trial {first['trial']} appears "
            f"twice (in {', '.join(where)}); participant ids must be unique across folders"
        )
    return trials, (validate_answers(pd.concat(answers, ignore_index=True)) if answers else None)


def _mean_sd(values: pd.Series) -> str:
    if values.empty:
        return "-"
    sd = values.std(ddof=1)
    return f"{values.mean():.2f}" + ("" if np.isnan(sd) else f" ± {sd:.2f}") + f" (n = {len(values)})"


def _p(value: float) -> str:
    return "n/a" if np.isnan(value) else f"{value:.3g}"


def questionnaire_markdown(means: pd.DataFrame | None, tests: dict) -> str:
    """``summary.md``'s questionnaire section: mean ± SD over participants per measure and
    mode, then the paired tests; or a line saying that no answers were recorded."""
    lines = ["## Questionnaires (Fig. 8 c, d)", ""]
    if means is None:
        return "\n".join(
            lines
            + [
                "No questionnaire answers were recorded (no questionnaires.csv in the folders): "
                "Fig. 8 has panels (a, b) only.",
                "",
            ]
        )
    modes = ordered_modes(means["mode"])
    lines += [
        "NASA-TLX ratings 0-100 (lower: less workload; raw = mean of the six, weighted = sum(weight x "
        "rating)/15); UEQ-S scored -3..+3 (higher: better; pragmatic = items 1-4, hedonic = items 5-8). "
        "Mean ± SD over participants, each participant's trials in a mode averaged first.",
        "",
        "| measure | " + " | ".join(modes) + " |",
        "|---|" + "---:|" * len(modes),
    ]
    for measure in TLX_MEASURES + UEQ_MEASURES:
        here = means[means["measure"] == measure]
        if len(here):
            lines.append(
                f"| {measure} | " + " | ".join(_mean_sd(here.loc[here["mode"] == m, "value"]) for m in modes) + " |"
            )
    for key, title in (("tlx", "NASA-TLX"), ("ueq", "UEQ-S")):
        if tests.get(key) is None:
            continue
        lines += ["", f"{title}: paired t-tests, Holm-corrected over the panel's {len(tests[key]['tests'])} tests:", ""]
        for t in tests[key]["tests"]:
            lines.append(
                f"- {t['measure']}: {t['a']} vs {t['b']} (n = {t['n']}): t({_p(t['dof'])}) = {_p(t['T'])}, "
                f"p = {_p(t['p_unc'])}, Holm p = {_p(t['p_holm'])} {t['stars']}".rstrip()
            )
        if tests[key]["note"]:
            lines += ["", f"Note: {tests[key]['note']}"]
    return "\n".join(lines + [""])


def analyze(dirs, out_dir, orders: dict | None = None) -> dict:
    """Read ``dirs`` (folders or ``StudyTable`` s, ``load_study``) and write into
    ``out_dir``: ``fig8.png``,
    ``questionnaire_scores.csv`` (``SCORE_COLUMNS``; header only without answers),
    ``summary.md``, ``summary.csv``, ``stats.json``, ``report.md`` (with the
    mixed-effects models and order effects of ``otgym.study.mixed``, and
    ``order_effects.png`` where the trials carry their block ``position``) and
    ``analysis.json``; return what ``analysis.json`` holds. ``orders``: each
    participant's order of modes, as recorded by ``otgym study run``."""
    trials, answers = load_study(dirs)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    means, tests, scores = None, {}, None
    if answers is not None:
        means = participant_measures(answers)
        for key, measures in (("tlx", TLX_MEASURES), ("ueq", UEQ_MEASURES)):
            if means["measure"].isin(measures).any():
                tests[key] = compare_measures(means, measures)
        scores = score(answers)
        scores.to_csv(out / "questionnaire_scores.csv", index=False)
    else:
        pd.DataFrame(columns=SCORE_COLUMNS).to_csv(out / "questionnaire_scores.csv", index=False)
    questionnaire_md = "\n" + questionnaire_markdown(means, tests)
    stats = write_summary(trials, out, questionnaire_md)
    panels = plot_fig8(trials, out / "fig8.png", stats, {"means": means, **tests} if means is not None else None)
    models = study_models(trials, scores)
    order_figure = plot_order_effects(trials, out / "order_effects.png")
    write_report(out, (out / "summary.md").read_text(encoding="utf-8"), models, orders or {}, order_figure)
    result = {
        "dirs": [_name(d) for d in dirs],
        "trials": len(trials),
        "participants": int(trials["participant"].nunique()),
        "questionnaire_rows": 0 if answers is None else len(answers),
        "panels": panels,
        "questionnaire_tests": tests,
        "orders": orders or {},
        "models": models,
    }
    (out / "analysis.json").write_text(json.dumps(json_safe(result), indent=2) + "\n", encoding="utf-8")
    return result
