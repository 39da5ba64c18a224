"""The shared-control study's summary: a per-mode table (descriptive statistics with the
paper's Fig. 8 values beside ours) and the files an experiment leaves behind
(``summary.csv``, ``summary.md``, ``stats.json``).

Means and SDs are over participants' means (``stats.participant_means``), the unit of
the repeated-measures design; rates' intervals are 95 % Wilson intervals on counts pooled
over all of a mode's trials."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pandas as pd

from otgym.study.paper_fig8 import PAPER_FIG8
from otgym.study.stats import compare_modes, ordered_modes, participant_means, require_columns, stars, wilson_interval

SUMMARY_INPUT_COLUMNS = (
    "participant",
    "mode",
    "obstacles_encountered",
    "obstacles_avoided",
    "reached_goal",
    "completion_time_s",
    "trap_losses",
    "detached",
)
"""The columns of the trials table that ``summarize`` reads; others are ignored."""

SUMMARY_COLUMNS = (
    "mode",
    "trials",
    "participants",
    "success_mean",
    "success_sd",
    "obstacles_encountered",
    "obstacles_avoided",
    "avoided_rate",
    "avoided_rate_ci_low",
    "avoided_rate_ci_high",
    "goals_reached",
    "goal_rate",
    "goal_rate_ci_low",
    "goal_rate_ci_high",
    "completion_time_mean_s",
    "completion_time_sd_s",
    "trap_losses",
    "detachments",
    "paper_success_mean",
    "paper_success_sd",
    "paper_time_mean_s",
    "paper_time_sd_s",
)
"""The columns of ``summarize``'s table, in order."""


def summarize(trials: pd.DataFrame) -> pd.DataFrame:
    """One row per mode (in ``MODE_ORDER``) with the columns ``SUMMARY_COLUMNS``.

    success_mean/sd and completion_time_mean_s/sd_s: mean and SD (ddof 1) over the
    participants' means (participants without a value are left out); avoided_rate and
    goal_rate: pooled over trials, with 95 % Wilson intervals; trap_losses: their sum;
    detachments: trials that ended detached. The paper's values are NaN for modes it
    lacks (MPC). Raises ValueError for missing columns or an empty table."""
    require_columns(trials, SUMMARY_INPUT_COLUMNS)
    success = participant_means(trials, "success")
    time = participant_means(trials, "time")
    rows = []
    for mode in ordered_modes(trials["mode"]):
        in_mode = trials[trials["mode"] == mode]
        mode_success = success.loc[success["mode"] == mode, "value"]
        mode_time = time.loc[time["mode"] == mode, "value"]
        encountered, avoided = int(in_mode["obstacles_encountered"].sum()), int(in_mode["obstacles_avoided"].sum())
        goals = int(in_mode["reached_goal"].astype(bool).sum())
        avoided_ci, goal_ci = wilson_interval(avoided, encountered), wilson_interval(goals, len(in_mode))
        paper = PAPER_FIG8.get(mode, {})
        rows.append(
            {
                "mode": mode,
                "trials": len(in_mode),
                "participants": in_mode["participant"].nunique(),
                "success_mean": mode_success.mean(),
                "success_sd": mode_success.std(ddof=1),
                "obstacles_encountered": encountered,
                "obstacles_avoided": avoided,
                "avoided_rate": avoided / encountered if encountered else math.nan,
                "avoided_rate_ci_low": avoided_ci[0],
                "avoided_rate_ci_high": avoided_ci[1],
                "goals_reached": goals,
                "goal_rate": goals / len(in_mode),
                "goal_rate_ci_low": goal_ci[0],
                "goal_rate_ci_high": goal_ci[1],
                "completion_time_mean_s": mode_time.mean(),
                "completion_time_sd_s": mode_time.std(ddof=1),
                "trap_losses": int(in_mode["trap_losses"].sum()),
                "detachments": int(in_mode["detached"].astype(bool).sum()),
                **{
                    f"paper_{key}": paper.get(key, math.nan)
                    for key in ("success_mean", "success_sd", "time_mean_s", "time_sd_s")
                },
            }
        )
    return pd.DataFrame(rows, columns=list(SUMMARY_COLUMNS))


def _num(value: float, spec: str) -> str:
    return "-" if math.isnan(value) else format(value, spec)


def _p(value: float) -> str:
    return "n/a" if math.isnan(value) else f"{value:.3g}"


def _mean_sd(mean: float, sd: float, scale: float, spec: str) -> str:
    if math.isnan(mean):
        return "-"
    return format(mean * scale, spec) + ("" if math.isnan(sd) else " ± " + format(sd * scale, spec))


def _rate(rate: float, low: float, high: float) -> str:
    return "-" if math.isnan(rate) else f"{100 * rate:.1f} [{100 * low:.1f}, {100 * high:.1f}]"


def _table_markdown(table: pd.DataFrame) -> list[str]:
    lines = [
        "| mode | trials | participants | success % (mean ± SD) | paper success % | avoided / encountered "
        "| avoided % [95 % CI] | goal % [95 % CI] | time s (mean ± SD) | paper time s | trap losses "
        "| detachments |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for row in table.itertuples():
        lines.append(
            f"| {row.mode} | {row.trials} | {row.participants} "
            f"| {_mean_sd(row.success_mean, row.success_sd, 100, '.1f')} "
            f"| {_mean_sd(row.paper_success_mean, row.paper_success_sd, 100, '.0f')} "
            f"| {row.obstacles_avoided} / {row.obstacles_encountered} "
            f"| {_rate(row.avoided_rate, row.avoided_rate_ci_low, row.avoided_rate_ci_high)} "
            f"| {_rate(row.goal_rate, row.goal_rate_ci_low, row.goal_rate_ci_high)} "
            f"| {_mean_sd(row.completion_time_mean_s, row.completion_time_sd_s, 1, '.1f')} "
            f"| {_mean_sd(row.paper_time_mean_s, row.paper_time_sd_s, 1, '.1f')} "
            f"| {row.trap_losses} | {row.detachments} |"
        )
    return lines


def _stats_markdown(title: str, result: dict) -> list[str]:
    anova = result["anova"]
    if math.isnan(anova["F"]) and (len(result["modes"]) < 2 or result["n_participants"] < 2):
        return [f"## {title}", "", f"No test: {result['note']}", ""]
    corrected = "" if math.isnan(anova["p_gg_corr"]) else f", Greenhouse-Geisser p = {_p(anova['p_gg_corr'])}"
    lines = [
        f"## {title}",
        "",
        f"Repeated-measures ANOVA over modes (n = {result['n_participants']} participants): "
        f"F({_num(anova['ddof1'], '.0f')}, {_num(anova['ddof2'], '.0f')}) = {_num(anova['F'], '.2f')}, "
        f"p = {_p(anova['p_unc'])}{corrected} {stars(anova['p'])}, "
        f"generalised eta² = {_num(anova['ng2'], '.3f')}.",
        "",
        "Paired t-tests, Holm-corrected:",
        "",
    ]
    for pair in result["posthoc"]:
        lines.append(
            f"- {pair['a']} vs {pair['b']}: t({_num(pair['dof'], '.0f')}) = {_num(pair['T'], '.2f')}, "
            f"p = {_p(pair['p_unc'])}, Holm p = {_p(pair['p_holm'])} {pair['stars']}".rstrip()
        )
    if result["note"]:
        lines += ["", f"Note: {result['note']}"]
    return lines + [""]


def summary_markdown(table: pd.DataFrame, stats: dict) -> str:
    """``summary.md``: the per-mode table with the paper's values beside ours, then the
    ANOVA and post-hoc lines for success and completion time."""
    lines = (
        ["# Shared-control study (paper Sec. III-C, Fig. 8)", ""]
        + _table_markdown(table)
        + [
            "",
            "Success: obstacles avoided / encountered, pooled per participant and mode; means and SDs are over "
            "participants' means. Time: mean over trials that reached the goal. CIs: 95 % Wilson intervals on "
            'pooled counts. Paper: Sec. III-C\'s mean ± SD ("-" where the paper has no such mode). '
            "Stars (Fig. 8): * p < 0.05, ** p < 0.01, *** p < 0.001, ns otherwise; on the ANOVA, the "
            "Greenhouse-Geisser p where there is one.",
            "",
        ]
    )
    lines += _stats_markdown("Success rate", stats["success"]) + _stats_markdown("Completion time", stats["time"])
    return "\n".join(lines)


def json_safe(value):
    """NaN as JSON's null, so ``stats.json`` is strict JSON."""
    if isinstance(value, dict):
        return {key: json_safe(item) for key, item in value.items()}
    if isinstance(value, list):
        return [json_safe(item) for item in value]
    if isinstance(value, float) and math.isnan(value):
        return None
    return value


def write_summary(trials: pd.DataFrame, out_dir, more_markdown: str = "") -> dict:
    """Write ``summary.csv`` (``summarize``), ``summary.md`` (with ``more_markdown``
    appended) and ``stats.json`` (``compare_modes`` for success and time; NaN written as
    null) into ``out_dir`` (created if needed); return ``{"success": ..., "time": ...}``
    as compare_modes gives."""
    table = summarize(trials)
    stats = {metric: compare_modes(trials, metric) for metric in ("success", "time")}
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    table.to_csv(out / "summary.csv", index=False)
    (out / "summary.md").write_text(summary_markdown(table, stats) + more_markdown, encoding="utf-8")
    (out / "stats.json").write_text(json.dumps(json_safe(stats), indent=2) + "\n", encoding="utf-8")
    return stats
