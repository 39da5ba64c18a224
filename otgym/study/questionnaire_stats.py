"""Do the modes differ in the questionnaires (paper Fig. 8 c, d)? Paired two-sided t-tests
between modes on participants' per-mode scores, as the paper's stars; Holm's correction
over every test of one figure panel (one family: the NASA-TLX measures, or the UEQ-S
measures), since the paper reads all of a panel's stars together.

A test needs at least 2 participants with a value in both modes (each pair of modes uses
the participants who have both); otherwise, or when the paired differences have zero
variance, its t and p are NaN, it stays out of the correction and a note says so."""

from __future__ import annotations

import math

import pandas as pd

from otgym.study.questionnaires import TLX_SUBSCALES, UEQ_ITEM_NAMES
from otgym.study.stats import holm, ordered_modes, paired_tests

TLX_MEASURES = tuple(f"tlx_{name}" for name in TLX_SUBSCALES) + ("raw_tlx", "weighted_tlx")
"""Panel (c)'s measures: the six subscale ratings, raw and weighted TLX."""
UEQ_MEASURES = ("ueq_pragmatic", "ueq_hedonic", "ueq_overall") + UEQ_ITEM_NAMES
"""Panel (d)'s measures: the three UEQ-S scales, then the eight items (scored -3..+3)."""


def compare_measures(means: pd.DataFrame, measures) -> dict:
    """Tests for each of ``measures`` present in ``means`` (``participant_measures``'s
    table: participant, mode, measure, value) between every pair of its modes.

    Returns ``{"tests": [{measure, a, b, n, T, dof, p_unc, p_holm, stars}], "note"}``,
    T of a minus b, Holm over the whole list."""
    rows, short, flat = [], [], []
    for measure in measures:
        here = means[means["measure"] == measure]
        wide = here.pivot(index="participant", columns="mode", values="value")
        modes = ordered_modes(here["mode"])
        for i, a in enumerate(modes):
            for b in modes[i + 1 :]:
                both = wide[[a, b]].dropna()
                row = {"measure": measure, "a": a, "b": b, "n": len(both)}
                if len(both) < 2:
                    short.append(f"{measure} {a} vs {b} (n = {len(both)})")
                    row.update(T=math.nan, dof=math.nan, p_unc=math.nan)
                else:
                    long = (
                        both.rename_axis(columns=None)
                        .reset_index()
                        .melt(id_vars="participant", var_name="mode", value_name="value")
                    )
                    test = paired_tests(long, [a, b])[0]
                    row.update(T=test["T"], dof=test["dof"], p_unc=test["p_unc"])
                    if math.isnan(test["T"]):
                        flat.append(f"{measure} {a} vs {b}")
                rows.append(row)
    notes = []
    if short:
        notes.append(f"no test with fewer than 2 participants answering both modes: {', '.join(short)}.")
    if flat:
        notes.append(f"t undefined (paired differences with zero variance): {', '.join(flat)}.")
    return {"tests": holm(rows) if rows else [], "note": " ".join(notes)}
