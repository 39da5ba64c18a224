"""Tests of otgym.study, with ``make_trials``: a trials table built from chosen values."""

import numpy as np
import pandas as pd


def make_trials(times: dict, avoided: dict | None = None, encountered: int = 10) -> pd.DataFrame:
    """One trial per participant and mode: ``times[mode][p]`` is participant p's completion
    time (goal reached); ``avoided[mode][p]`` of ``encountered`` obstacles avoided (all if
    ``avoided`` is None). Carries the other columns of the trials table, and one extra."""
    rows = []
    for mode, values in times.items():
        for participant, time in enumerate(values):
            n_avoided = encountered if avoided is None else int(avoided[mode][participant])
            rows.append({"participant": participant, "mode": mode, "trial": 0, "scenario": 0,
                         "completion_time_s": float(time), "obstacles_encountered": encountered,
                         "obstacles_avoided": n_avoided,
                         "success": n_avoided / encountered if encountered else np.nan,
                         "reached_goal": True, "trap_losses": 0, "detached": False,
                         "peak_contact_force_pn": 1.0, "operator_seed": 7})
    return pd.DataFrame(rows)
