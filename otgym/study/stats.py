"""Statistics of the shared-control study (paper Sec. III-C, Fig. 8): per-participant
means, a one-way repeated-measures ANOVA over control modes followed by paired t-tests
with Holm's correction (both from pingouin), significance stars as defined in the Fig. 8
caption, and Wilson score intervals for rates (statsmodels, a pingouin dependency).
Needs pingouin >= 0.6, whose result columns are snake_case (``p_unc``, ``p_GG_corr``).

The unit of analysis is the participant: each participant's trials in one mode are
reduced to one value (``participant_means``) before any test, as a repeated-measures
design requires."""

from __future__ import annotations

import math
import warnings
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import pandas as pd

from otgym import registry

MODE_ORDER = ("manual", "autonomous", "shared", *registry.names("navigators", "trial-mode"))
"""The order of modes in tables and figures: the paper's three, then the navigators' own
modes in the registry's order (MPC, then the learned speed)."""

METRICS = ("success", "time")
_METRIC_COLUMNS = {
    "success": ("obstacles_encountered", "obstacles_avoided"),
    "time": ("completion_time_s", "reached_goal"),
}
_MISSING_REASON = {"success": "no obstacle encountered", "time": "no trial that reached the goal"}


def require_columns(trials: pd.DataFrame, columns) -> None:
    """Raise ValueError naming the columns of ``columns`` that ``trials`` lacks, or if it has no rows."""
    missing = [column for column in columns if column not in trials.columns]
    if missing:
        raise ValueError(f"trials table lacks column(s) {missing}; it has {list(trials.columns)}")
    if trials.empty:
        raise ValueError("trials table has no rows")


def ordered_modes(modes) -> list[str]:
    """The distinct modes in ``modes``, in ``MODE_ORDER``, then any others alphabetically."""
    present = set(modes)
    return [mode for mode in MODE_ORDER if mode in present] + sorted(present - set(MODE_ORDER))


def _sort_by_mode(frame: pd.DataFrame) -> pd.DataFrame:
    rank = {mode: i for i, mode in enumerate(ordered_modes(frame["mode"]))}
    return (
        frame.assign(_rank=frame["mode"].map(rank))
        .sort_values(["_rank", "participant"])
        .drop(columns="_rank")
        .reset_index(drop=True)
    )


def participant_means(trials: pd.DataFrame, metric: str) -> pd.DataFrame:
    """One value per participant and mode (columns ``participant``, ``mode``, ``value``).

    ``success``: the participant's pooled rate in that mode, sum(obstacles_avoided) /
    sum(obstacles_encountered) over their trials (the paper's "proportion of dynamical
    obstacles avoided"; pooling weights trials by their obstacles and avoids the
    undefined 0/0 of a trial that met none). NaN if they met no obstacle at all.

    ``time``: the mean ``completion_time_s`` of their trials that reached the goal; NaN
    if none did (``compare_modes`` then drops that participant, with a note)."""
    if metric not in METRICS:
        raise ValueError(f"metric must be one of {METRICS}, got {metric!r}")
    require_columns(trials, ("participant", "mode") + _METRIC_COLUMNS[metric])
    keys = [trials["participant"], trials["mode"]]
    if metric == "success":
        avoided, encountered = trials["obstacles_avoided"], trials["obstacles_encountered"]
        if ((avoided < 0) | (avoided > encountered)).any():
            raise ValueError("need 0 <= obstacles_avoided <= obstacles_encountered in every trial")
        sums = trials.groupby(keys)[["obstacles_avoided", "obstacles_encountered"]].sum()
        value = sums["obstacles_avoided"] / sums["obstacles_encountered"]  # 0/0 is NaN
    else:
        value = trials["completion_time_s"].where(trials["reached_goal"].astype(bool)).groupby(keys).mean()
    return _sort_by_mode(value.astype(float).rename("value").reset_index())


def stars(p: float | None) -> str:
    """Fig. 8's significance marks: '***' p < 0.001, '**' p < 0.01, '*' p < 0.05, 'ns'
    otherwise; '' when there is no p-value (NaN or None, e.g. from JSON's null)."""
    if p is None or math.isnan(p):
        return ""
    if not 0.0 <= p <= 1.0:
        raise ValueError(f"a p-value lies in [0, 1], got {p}")
    return "***" if p < 0.001 else "**" if p < 0.01 else "*" if p < 0.05 else "ns"


def wilson_interval(successes: int, n: int, confidence: float = 0.95) -> tuple[float, float]:
    """Wilson score interval for a binomial proportion ``successes / n`` (Wilson 1927;
    statsmodels ``proportion_confint(method='wilson')``). (NaN, NaN) when ``n`` is 0."""
    if not (0 <= successes <= n):
        raise ValueError(f"need 0 <= successes <= n, got successes={successes}, n={n}")
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must lie in (0, 1), got {confidence}")
    if n == 0:
        return (math.nan, math.nan)
    from statsmodels.stats.proportion import proportion_confint  # seconds to import: on first use

    low, high = proportion_confint(successes, n, alpha=1.0 - confidence, method="wilson")
    return (float(low), float(high))


def _float(value) -> float:
    """A finite float, or NaN for anything missing or infinite."""
    value = float(value)
    return value if math.isfinite(value) else math.nan


def _anova(long: pd.DataFrame, notes: list[str]) -> dict:
    """pingouin's one-way repeated-measures ANOVA, with the Greenhouse-Geisser correction
    (computed by pingouin for more than two modes). ``p`` is the corrected p-value where
    there is one (the conservative reading), else the uncorrected one."""
    import pingouin as pg  # seconds to import: on first use

    with warnings.catch_warnings():  # degenerate data (pingouin then omits F and p): NaN below, with a note
        warnings.simplefilter("ignore")
        try:
            row = pg.rm_anova(
                data=long, dv="value", within="mode", subject="participant", correction=True, detailed=False
            ).iloc[0]
        except ZeroDivisionError:  # pingouin's Mauchly test (run even uncorrected) divides by zero on some data
            return _anova_uncorrected(long, notes)
    result = {
        "F": _float(row.get("F", np.nan)),
        "ddof1": int(row["ddof1"]),
        "ddof2": int(row["ddof2"]),
        "p_unc": _float(row.get("p_unc", np.nan)),
        "p_gg_corr": _float(row.get("p_GG_corr", np.nan)),
        "eps": _float(row.get("eps", np.nan)),
        "ng2": _float(row.get("ng2", np.nan)),
    }
    if math.isnan(result["F"]):
        result["p_unc"] = result["p_gg_corr"] = math.nan
        notes.append(
            "ANOVA undefined: the residual (participant x mode) variance is zero, e.g. every "
            "value identical, so F is 0/0 or x/0; reported as NaN, not as significant."
        )
    result["p"] = result["p_gg_corr"] if not math.isnan(result["p_gg_corr"]) else result["p_unc"]
    return result


def _anova_uncorrected(long: pd.DataFrame, notes: list[str]) -> dict:
    """The same one-way repeated-measures ANOVA by statsmodels' ``AnovaRM``, without a
    sphericity correction: used where pingouin's Mauchly test fails (it divides by zero
    for some small or degenerate samples)."""
    from statsmodels.stats.anova import AnovaRM

    table = AnovaRM(long, depvar="value", subject="participant", within=["mode"]).fit().anova_table.iloc[0]
    notes.append(
        "Sphericity test undefined for these data (pingouin's Mauchly test failed); the ANOVA is "
        "statsmodels' AnovaRM and its p is uncorrected."
    )
    p = _float(table["Pr > F"])
    return {
        "F": _float(table["F Value"]),
        "ddof1": int(table["Num DF"]),
        "ddof2": int(table["Den DF"]),
        "p_unc": p,
        "p_gg_corr": math.nan,
        "eps": math.nan,
        "ng2": math.nan,
        "p": p,
    }


def paired_tests(long: pd.DataFrame, modes: list[str]) -> list[dict]:
    """Paired two-sided t-tests between every pair of ``modes`` (pingouin
    ``pairwise_tests``, parametric, unadjusted) on ``long`` (columns participant, mode,
    value; every participant with a value in every mode). Rows ``{a, b, T, dof, p_unc}``,
    T of a minus b; a pair whose paired differences have zero variance gets NaN T and p,
    not p = 0."""
    import pingouin as pg

    with warnings.catch_warnings():  # degenerate pairs (pingouin then omits T and p): NaN below
        warnings.simplefilter("ignore")
        table = pg.pairwise_tests(
            data=long, dv="value", within="mode", subject="participant", parametric=True, padjust="none"
        )
    rows = []
    for i, a in enumerate(modes):
        for b in modes[i + 1 :]:
            match = table[((table["A"] == a) & (table["B"] == b)) | ((table["A"] == b) & (table["B"] == a))].iloc[0]
            t = _float(match.get("T", np.nan)) * (1.0 if match["A"] == a else -1.0)
            rows.append(
                {
                    "a": a,
                    "b": b,
                    "T": t,
                    "dof": _float(match["dof"]),
                    "p_unc": math.nan if math.isnan(t) else _float(match.get("p_unc", np.nan)),
                }
            )
    return rows


def holm(rows: list[dict]) -> list[dict]:
    """Add ``p_holm`` (Holm's step-down correction over the rows' defined ``p_unc``, by
    pingouin's ``multicomp``; NaN stays NaN) and ``stars`` to each row; return the rows."""
    import pingouin as pg

    _, p_holm = pg.multicomp(np.array([row["p_unc"] for row in rows], dtype=float), method="holm")
    for row, p in zip(rows, p_holm):
        row["p_holm"] = _float(p)
        row["stars"] = stars(row["p_holm"])
    return rows


def _posthoc(long: pd.DataFrame, modes: list[str], notes: list[str]) -> list[dict]:
    """``paired_tests`` between every pair of modes, Holm-corrected over the pairs whose t
    is defined."""
    rows = paired_tests(long, modes)
    undefined = [f"{row['a']} vs {row['b']}" for row in rows if math.isnan(row["T"])]
    if undefined:
        notes.append(
            f"t undefined for {', '.join(undefined)}: the paired differences have zero variance "
            "(identical for every participant); reported as NaN and left out of the Holm correction."
        )
    return holm(rows)


def _no_test() -> dict:
    return {key: math.nan for key in ("F", "ddof1", "ddof2", "p_unc", "p_gg_corr", "eps", "ng2", "p")}


def compare_modes(trials: pd.DataFrame, metric: str) -> dict:
    """Do the modes differ in ``metric`` ('success' or 'time')? The paper's analysis of
    Fig. 8: a one-way repeated-measures ANOVA over modes (pingouin ``rm_anova``) on the
    participant means, then paired t-tests between modes with Holm's correction.

    Returns ``{"metric", "modes", "n_participants", "anova": {F, ddof1, ddof2, p_unc,
    p_gg_corr, eps, ng2, p}, "posthoc": [{a, b, T, dof, p_unc, p_holm, stars}], "note"}``;
    T is the t statistic of a minus b. Participants without a value in every mode are
    dropped (listwise, as the design needs every mode) and named in ``note``. Undefined
    tests give NaN and a note, never an invented statistic: no variance, fewer than 2
    complete participants (``n_participants`` < 2: one participant, say), or a single
    mode (nothing to compare; ``posthoc`` empty). Raises ValueError for missing
    columns or no rows."""
    means = participant_means(trials, metric)
    modes = ordered_modes(means["mode"])
    wide = means.pivot(index="participant", columns="mode", values="value").reindex(columns=modes)
    notes = []
    if len(modes) < 2:
        notes.append(f"only one mode ({modes[0]}): nothing to compare, no test.")
        return {
            "metric": metric,
            "modes": modes,
            "n_participants": int(wide.notna().all(axis=1).sum()),
            "anova": _no_test(),
            "posthoc": [],
            "note": " ".join(notes),
        }
    incomplete = wide[wide.isna().any(axis=1)]
    if len(incomplete):
        gaps = "; ".join(f"participant {p}: {', '.join(row.index[row.isna()])}" for p, row in incomplete.iterrows())
        notes.append(f"dropped {len(incomplete)} participant(s) with {_MISSING_REASON[metric]} in some mode ({gaps}).")
    complete = wide.dropna()
    result = {"metric": metric, "modes": modes, "n_participants": len(complete)}
    if len(complete) < 2:
        notes.append(
            f"no test is possible with n < 2 (n = {len(complete)} participant(s) with a value in every "
            "mode); reported as NaN."
        )
        result["anova"] = _no_test()
        result["posthoc"] = [
            {"a": a, "b": b, "T": math.nan, "dof": math.nan, "p_unc": math.nan, "p_holm": math.nan, "stars": ""}
            for i, a in enumerate(modes)
            for b in modes[i + 1 :]
        ]
    else:
        long = (
            complete.rename_axis(columns=None)
            .reset_index()
            .melt(id_vars="participant", var_name="mode", value_name="value")
        )
        result["anova"] = _anova(long, notes)
        result["posthoc"] = _posthoc(long, modes, notes)
    result["note"] = " ".join(notes)
    return result
