"""Tests of otgym.study, with ``make_trials``: a trials table built from chosen values, and
``rows``: one trial's questionnaire answers."""

import numpy as np
import pandas as pd

from otgym.study.questionnaires import TLX_PAIRS, UEQ_ITEM_NAMES


def make_trials(times: dict, avoided: dict | None = None, encountered: int = 10) -> pd.DataFrame:
    """One trial per participant and mode: ``times[mode][p]`` is participant p's completion
    time (goal reached); ``avoided[mode][p]`` of ``encountered`` obstacles avoided (all if
    ``avoided`` is None). Carries the other columns of the trials table, and one extra."""
    rows = []
    for mode, values in times.items():
        for participant, time in enumerate(values):
            n_avoided = encountered if avoided is None else int(avoided[mode][participant])
            rows.append(
                {
                    "participant": participant,
                    "mode": mode,
                    "trial": 0,
                    "scenario": 0,
                    "completion_time_s": float(time),
                    "obstacles_encountered": encountered,
                    "obstacles_avoided": n_avoided,
                    "success": n_avoided / encountered if encountered else np.nan,
                    "reached_goal": True,
                    "trap_losses": 0,
                    "detached": False,
                    "peak_contact_force_pn": 1.0,
                    "operator_seed": 7,
                }
            )
    return pd.DataFrame(rows)


RATINGS = {"mental": 70, "physical": 20, "temporal": 50, "performance": 30, "effort": 60, "frustration": 40}
RANKING = ("mental", "effort", "temporal", "frustration", "performance", "physical")
"""Most to least important: choosing the higher-ranked of each pair gives weights 5, 4, 3, 2, 1, 0."""
UEQ_RAW = (6, 5, 7, 6, 3, 4, 2, 5)
"""Scored (raw - 4): 2, 1, 3, 2 | -1, 0, -2, 1: pragmatic 8/4 = 2, hedonic -2/4 = -0.5, overall 6/8 = 0.75."""


def ranked_choices(ranking=RANKING) -> dict:
    return {pair: min(pair, key=ranking.index) for pair in TLX_PAIRS}


def rows(participant="P1", mode="manual", trial=0, ratings=None, weights=None, ueq=None) -> list[dict]:
    """One trial's answer rows; pass only the instruments wanted."""
    out = []
    key = {"participant": participant, "mode": mode, "trial": trial}
    for item, value in (ratings or {}).items():
        out.append({**key, "instrument": "nasa_tlx", "item": item, "value": value})
    for item, value in (weights or {}).items():
        out.append({**key, "instrument": "nasa_tlx", "item": item, "value": value})
    for item, value in zip(UEQ_ITEM_NAMES, ueq or ()):
        out.append({**key, "instrument": "ueq_s", "item": item, "value": value})
    return out
