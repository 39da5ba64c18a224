"""The post-trial questionnaires of the shared-control study (paper Sec. III-C, Fig. 8 c, d),
their answer file and their published scoring.

NASA-TLX (Hart & Staveland 1988, "Development of NASA-TLX"; Hart 2006, "NASA-Task Load
Index (NASA-TLX); 20 years later"): six subscales rated 0-100 in steps of 5 (the paper
form's 21 marks; low = little demand, and for ``performance`` low = perfect, high =
failure). Raw TLX = mean of the six ratings. The optional weighting asks for the more
important subscale of each of the 15 pairs; a subscale's weight (0-5) is how often it was
chosen, the weights sum to 15, and weighted TLX = sum(weight * rating) / 15.

UEQ-S (Schrepp, Hinderks & Thomaschewski 2017, "Design and evaluation of a short version
of the User Experience Questionnaire (UEQ-S)", IJIMAI 4(6)): eight 7-point items between
a negative (left, 1) and a positive (right, 7) pole, in the published order. Scored value
= raw - 4 (-3 .. +3); pragmatic quality = mean of items 1-4, hedonic quality = mean of
items 5-8, overall = mean of all eight.

Answers are stored in long form (``QUESTIONNAIRE_COLUMNS``), one row per item answered
after one trial: instrument ``nasa_tlx`` (items ``mental`` .. ``frustration`` and, when
weighted, ``weight_<subscale>``) or ``ueq_s`` (items ``ueq1`` .. ``ueq8``, raw 1-7). A
trial's answers to an instrument are complete or absent: all six ratings (and all six
weights, or none), all eight UEQ-S items."""

from __future__ import annotations

import csv
import itertools
from pathlib import Path

import numpy as np
import pandas as pd

QUESTIONNAIRE_COLUMNS = ["participant", "mode", "trial", "instrument", "item", "value"]
"""Columns of ``questionnaires.csv``, in order (long form: one row per answered item)."""

NASA_TLX, UEQ_S = "nasa_tlx", "ueq_s"

TLX_SUBSCALES = ("mental", "physical", "temporal", "performance", "effort", "frustration")
"""The six NASA-TLX subscales, in the form's order."""

TLX_ITEMS = {
    "mental": ("Mental demand", "How mentally demanding was the task?", "Very low", "Very high"),
    "physical": ("Physical demand", "How physically demanding was the task?", "Very low", "Very high"),
    "temporal": ("Temporal demand", "How hurried or rushed was the pace of the task?", "Very low", "Very high"),
    "performance": (
        "Performance",
        "How successful were you in accomplishing what you were asked to do?",
        "Perfect",
        "Failure",
    ),
    "effort": (
        "Effort",
        "How hard did you have to work to accomplish your level of performance?",
        "Very low",
        "Very high",
    ),
    "frustration": (
        "Frustration",
        "How insecure, discouraged, irritated, stressed, and annoyed were you?",
        "Very low",
        "Very high",
    ),
}
"""Per subscale: title, question, left pole (0), right pole (100), as on the NASA form (Hart 2006)."""

TLX_STEP = 5
"""Ratings lie on 0, 5, ..., 100."""

TLX_WEIGHT_ITEMS = tuple(f"weight_{name}" for name in TLX_SUBSCALES)

TLX_PAIRS = tuple(itertools.combinations(TLX_SUBSCALES, 2))
"""The 15 pairwise comparisons of the TLX weighting, each (first, second) subscale."""

TLX_PAIR_COUNT = len(TLX_PAIRS)  # 15: the weights' sum

UEQ_ITEMS = (
    ("obstructive", "supportive"),
    ("complicated", "easy"),
    ("inefficient", "efficient"),
    ("confusing", "clear"),
    ("boring", "exciting"),
    ("not interesting", "interesting"),
    ("conventional", "inventive"),
    ("usual", "leading edge"),
)
"""UEQ-S items 1-8 (Schrepp et al. 2017), each (negative pole = 1, positive pole = 7)."""

UEQ_ITEM_NAMES = tuple(f"ueq{i}" for i in range(1, len(UEQ_ITEMS) + 1))
UEQ_PRAGMATIC, UEQ_HEDONIC = UEQ_ITEM_NAMES[:4], UEQ_ITEM_NAMES[4:]
UEQ_NEUTRAL = 4
"""The raw middle of the 7-point scale: scored value = raw - 4."""

SCORE_COLUMNS = ["participant", "mode", "raw_tlx", "weighted_tlx", "ueq_pragmatic", "ueq_hedonic", "ueq_overall"]
"""Columns of ``score``'s table."""

_RANGES = {
    **{(NASA_TLX, item): (0, 100) for item in TLX_SUBSCALES},
    **{(NASA_TLX, item): (0, TLX_PAIR_COUNT // 3) for item in TLX_WEIGHT_ITEMS},
    **{(UEQ_S, item): (1, 7) for item in UEQ_ITEM_NAMES},
}
"""Allowed (lowest, highest) value per (instrument, item); weights: each subscale meets 5 others."""

_TRIAL = ["participant", "mode", "trial"]


def weights_from_choices(choices: dict) -> dict:
    """TLX weights from the 15 pairwise choices: ``choices[(a, b)]`` is the subscale
    (a or b) judged the more important contributor to workload, for every pair of
    ``TLX_PAIRS``. Returns ``{"weight_<subscale>": times chosen}`` (0-5, sum 15)."""
    if set(choices) != set(TLX_PAIRS):
        missing = [pair for pair in TLX_PAIRS if pair not in choices]
        extra = [pair for pair in choices if pair not in TLX_PAIRS]
        raise ValueError(
            f"need a choice for each of the {TLX_PAIR_COUNT} TLX pairs; missing {missing}, unknown {extra}"
        )
    weights = dict.fromkeys(TLX_WEIGHT_ITEMS, 0)
    for pair, chosen in choices.items():
        if chosen not in pair:
            raise ValueError(f"the choice for pair {pair} must be one of its two subscales, got {chosen!r}")
        weights[f"weight_{chosen}"] += 1
    return weights


def validate_answers(frame: pd.DataFrame) -> pd.DataFrame:
    """The answers as a clean table (``trial`` int, ``value`` float); ValueError with one
    line naming the first problem: columns, unknown instrument or item, a value out of
    range or off the TLX 5-step grid, a duplicate answer, an incomplete instrument, or
    weights that do not sum to 15."""
    if list(frame.columns) != QUESTIONNAIRE_COLUMNS:
        raise ValueError(f"questionnaire answers need the columns {QUESTIONNAIRE_COLUMNS}, got {list(frame.columns)}")
    frame = frame.copy()
    for column in ("participant", "mode", "instrument", "item"):
        text = frame[column].astype(str).str.strip()
        if frame[column].isna().any() or (text == "").any():
            raise ValueError(f"questionnaire answers: empty {column} in some row")
        frame[column] = text
    trial = pd.to_numeric(frame["trial"], errors="coerce")
    if trial.isna().any() or (trial != np.round(trial)).any() or (trial < 0).any():
        raise ValueError("questionnaire answers: trial must be a whole number >= 0 in every row")
    frame["trial"] = trial.astype(int)
    value = pd.to_numeric(frame["value"], errors="coerce").astype(float)
    for row, number in zip(frame.itertuples(index=False), value):
        where = f"participant {row.participant}, mode {row.mode}, trial {row.trial}"
        key = (row.instrument, row.item)
        if row.instrument not in (NASA_TLX, UEQ_S):
            raise ValueError(
                f"questionnaire answers: unknown instrument {row.instrument!r} ({where}); known: {[NASA_TLX, UEQ_S]}"
            )
        if key not in _RANGES:
            known = [item for instrument, item in _RANGES if instrument == row.instrument]
            raise ValueError(
                f"questionnaire answers: unknown item {row.item!r} of {row.instrument} ({where}); known: {known}"
            )
        low, high = _RANGES[key]
        step = TLX_STEP if row.item in TLX_SUBSCALES else 1
        if not (np.isfinite(number) and low <= number <= high and number % step == 0):
            raise ValueError(
                f"questionnaire answers: {row.instrument} {row.item} = {row.value} ({where}) must be "
                f"{'a multiple of ' + str(step) if step > 1 else 'a whole number'} in [{low}, {high}]"
            )
    frame["value"] = value
    duplicated = frame.duplicated(_TRIAL + ["instrument", "item"])
    if duplicated.any():
        row = frame[duplicated].iloc[0]
        raise ValueError(
            f"questionnaire answers: {row['instrument']} {row['item']} answered twice for participant "
            f"{row['participant']}, mode {row['mode']}, trial {row['trial']}"
        )
    for (participant, mode, trial_no), group in frame.groupby(_TRIAL, sort=False):
        items = set(group["item"])
        where = f"participant {participant}, mode {mode}, trial {trial_no}"
        for name, needed in (
            ("NASA-TLX ratings", TLX_SUBSCALES),
            ("TLX weights", TLX_WEIGHT_ITEMS),
            ("UEQ-S items", UEQ_ITEM_NAMES),
        ):
            if items & set(needed) and not items >= set(needed):
                raise ValueError(
                    f"questionnaire answers: incomplete {name} ({where}): missing "
                    f"{[item for item in needed if item not in items]}"
                )
        if items & set(TLX_WEIGHT_ITEMS):
            if not items >= set(TLX_SUBSCALES):
                raise ValueError(f"questionnaire answers: TLX weights without ratings ({where})")
            total = group.loc[group["item"].isin(TLX_WEIGHT_ITEMS), "value"].sum()
            if total != TLX_PAIR_COUNT:
                raise ValueError(f"questionnaire answers: TLX weights sum to {total:g}, not {TLX_PAIR_COUNT} ({where})")
    return frame.reset_index(drop=True)


def read_answers(path) -> pd.DataFrame:
    """``questionnaires.csv`` as a validated table (participant, mode, instrument and item
    as text, trial as int, value as float)."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no questionnaire file {path}")
    return validate_answers(pd.read_csv(path, dtype={"participant": str, "mode": str}))


def append_answers(path, rows: list[dict]) -> None:
    """Append answer rows (dicts with the keys ``QUESTIONNAIRE_COLUMNS``) to the CSV at
    ``path``, writing the header if the file is new. The file's old rows and the new ones
    are validated together (so an answer given twice is refused too); if any row is bad,
    ValueError and nothing is written."""
    if not rows:
        return
    for row in rows:
        if set(row) != set(QUESTIONNAIRE_COLUMNS):
            raise ValueError(f"a questionnaire row needs exactly the keys {QUESTIONNAIRE_COLUMNS}, got {sorted(row)}")
    new = pd.DataFrame(rows, columns=QUESTIONNAIRE_COLUMNS)
    path = Path(path)
    old = pd.read_csv(path, dtype={"participant": str, "mode": str}) if path.is_file() else None
    validate_answers(
        new if old is None else pd.concat([old, new.astype({"participant": str, "mode": str})], ignore_index=True)
    )
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("a", newline="", encoding="utf-8") as file:
        writer = csv.DictWriter(file, fieldnames=QUESTIONNAIRE_COLUMNS)
        if old is None:
            writer.writeheader()
        writer.writerows(rows)


def trial_measures(answers: pd.DataFrame) -> pd.DataFrame:
    """Per trial (participant, mode, trial) and measure, the value: ``tlx_<subscale>``
    ratings, ``raw_tlx``, ``weighted_tlx`` (weighted trials only), UEQ-S items
    ``ueq1`` .. ``ueq8`` scored -3..+3, ``ueq_pragmatic``, ``ueq_hedonic``,
    ``ueq_overall``. Long form: columns participant, mode, trial, measure, value."""
    wide = answers.pivot_table(index=_TRIAL, columns="item", values="value", aggfunc="first")
    wide = wide.reindex(columns=list(TLX_SUBSCALES + TLX_WEIGHT_ITEMS + UEQ_ITEM_NAMES))
    ratings, weights = wide[list(TLX_SUBSCALES)], wide[list(TLX_WEIGHT_ITEMS)]
    ueq = wide[list(UEQ_ITEM_NAMES)] - UEQ_NEUTRAL
    measures = pd.DataFrame(index=wide.index)
    for name in TLX_SUBSCALES:
        measures[f"tlx_{name}"] = ratings[name]
    measures["raw_tlx"] = ratings.mean(axis=1, skipna=False)
    measures["weighted_tlx"] = (
        np.sum(ratings.to_numpy() * weights.to_numpy(), axis=1) / TLX_PAIR_COUNT
    )  # NaN unweighted
    for name in UEQ_ITEM_NAMES:
        measures[name] = ueq[name]
    measures["ueq_pragmatic"] = ueq[list(UEQ_PRAGMATIC)].mean(axis=1, skipna=False)
    measures["ueq_hedonic"] = ueq[list(UEQ_HEDONIC)].mean(axis=1, skipna=False)
    measures["ueq_overall"] = ueq.mean(axis=1, skipna=False)
    return measures.reset_index().melt(id_vars=_TRIAL, var_name="measure", value_name="value").dropna()


def participant_measures(answers: pd.DataFrame) -> pd.DataFrame:
    """Each measure of ``trial_measures`` averaged over a participant's trials in a mode
    (the trials that have it). Columns participant, mode, measure, value."""
    return trial_measures(answers).groupby(["participant", "mode", "measure"], sort=False)["value"].mean().reset_index()


def score(answers: pd.DataFrame) -> pd.DataFrame:
    """One row per participant and mode (columns ``SCORE_COLUMNS``): raw and weighted TLX
    and UEQ-S pragmatic, hedonic and overall, each computed per trial and averaged over
    that participant's trials in that mode that have it; NaN where none has (e.g.
    weighted TLX without weights)."""
    means = participant_measures(answers)
    wide = means.pivot_table(index=["participant", "mode"], columns="measure", values="value", sort=False)
    return wide.reindex(columns=SCORE_COLUMNS[2:]).rename_axis(columns=None).reset_index()[SCORE_COLUMNS]
