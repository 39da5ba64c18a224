"""The paper's Fig. 8 from our trials: (a) success rate and (b) task completion time per
control mode, and where questionnaire answers exist (c) NASA-TLX and (d) UEQ-S per mode,
with significance stars between modes as in the paper's figure.

Bars: mean over participants' means with SD error bars; dots: each participant's mean
(jittered); hollow diamonds beside the bars of (a, b): the paper's mean ± SD (Sec.
III-C; the paper prints no numbers for c, d); brackets: pairs whose Holm-corrected
paired t-test is significant (p < 0.05). Drawn on matplotlib's Agg canvas (no display,
no global backend change)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from otgym.study.paper_fig8 import PAPER_FIG8
from otgym.study.questionnaire_stats import TLX_MEASURES, UEQ_MEASURES
from otgym.study.questionnaires import UEQ_ITEMS
from otgym.study.stats import MODE_ORDER, compare_modes, ordered_modes, participant_means

_PANELS = (
    ("success", "(a) Success rate", "Obstacles avoided (%)", 100.0, "success_mean", "success_sd", 100.0),
    ("time", "(b) Task completion time", "Completion time (s)", 1.0, "time_mean_s", "time_sd_s", math.inf),
)
"""Per panel: metric, title, y label, scale to the plotted unit, the paper's mean and SD
keys, and the largest y tick (a rate's axis stops at 100 % below the brackets)."""
_QUESTIONNAIRE_PANELS = {
    "tlx": (
        "(c) NASA-TLX (lower: less workload)",
        "Rating (0-100)",
        (0.0, 100.0),
        TLX_MEASURES,
        ("Mental", "Physical", "Temporal", "Perfor-\nmance", "Effort", "Frustra-\ntion", "Raw\nTLX", "Weighted\nTLX"),
    ),
    "ueq": (
        "(d) UEQ-S (higher: better)",
        "Score (-3 to +3)",
        (-3.0, 3.0),
        UEQ_MEASURES,
        ("Pragmatic", "Hedonic", "Overall") + tuple(positive.replace(" ", "\n") for _, positive in UEQ_ITEMS),
    ),
}
"""Per questionnaire panel: title, y label, scale limits, measures and their x labels
(UEQ-S items by their positive pole)."""
_PALETTE = ("#4C72B0", "#DD8452", "#55A868", "#8172B3", "#C44E52", "#937860", "#DA8BC3", "#8C8C8C")
_COLORS = dict(zip(MODE_ORDER, _PALETTE))
"""Each mode's colour, by its place in ``MODE_ORDER``."""
_PAPER_OFFSET = 0.32


def _brackets(ax, pairs: list[dict], x_of: dict, top: float, span: float) -> float:
    """Draw a bracket with stars for each significant pair, stacked above ``top``; return the new top."""
    step = 0.11 * span
    for pair in sorted(
        (p for p in pairs if p["p_holm"] is not None and not math.isnan(p["p_holm"]) and p["p_holm"] < 0.05),
        key=lambda p: abs(x_of[p["a"]] - x_of[p["b"]]),
    ):
        top += step
        x1, x2 = sorted((x_of[pair["a"]], x_of[pair["b"]]))
        ax.plot([x1, x1, x2, x2], [top - 0.3 * step, top, top, top - 0.3 * step], color="black", lw=1.0)
        ax.text((x1 + x2) / 2, top, pair["stars"], ha="center", va="bottom", fontsize=11)
    return top


def _panel(ax, means: pd.DataFrame, modes: list[str], result: dict, panel: tuple, rng) -> None:
    _, title, ylabel, scale, paper_mean, paper_sd, tick_max = panel
    x_of = {mode: i for i, mode in enumerate(modes)}
    top = 0.0
    for mode in modes:
        values = means.loc[means["mode"] == mode, "value"].dropna().to_numpy() * scale
        x = x_of[mode]
        mean = values.mean() if len(values) else math.nan
        sd = values.std(ddof=1) if len(values) > 1 else 0.0  # one participant: no spread to draw
        ax.bar(
            x,
            mean,
            width=0.5,
            color=_COLORS.get(mode, "#937860"),
            alpha=0.75,
            yerr=sd,
            capsize=5,
            error_kw={"lw": 1.2},
            label="mean ± SD" if x == 0 else None,
        )
        ax.scatter(
            x + rng.uniform(-0.12, 0.12, len(values)),
            values,
            s=14,
            color="black",
            alpha=0.7,
            zorder=3,
            label="participant mean" if x == 0 else None,
        )
        top = max([top, np.nanmax(values, initial=0.0), (mean + sd) if len(values) else 0.0])
        if not len(values):  # say why a bar is missing rather than leave a blank
            ax.text(
                x,
                0.02,
                "no data",
                transform=ax.get_xaxis_transform(),
                ha="center",
                va="bottom",
                fontsize=9,
                color="dimgray",
                rotation=90,
            )
        if mode in PAPER_FIG8:
            paper = PAPER_FIG8[mode]
            ax.errorbar(
                x + _PAPER_OFFSET,
                paper[paper_mean] * scale,
                yerr=paper[paper_sd] * scale,
                fmt="D",
                mfc="white",
                mec="black",
                color="black",
                ms=6,
                capsize=3,
                lw=1.0,
                label="paper (Fig. 8)" if x == 0 else None,
            )
            top = max(top, (paper[paper_mean] + paper[paper_sd]) * scale)
    span = top if top > 0 else 1.0
    top = _brackets(ax, result["posthoc"], x_of, top, span)
    ax.set_ylim(0, top + 0.12 * span)
    ticks = ax.get_yticks()
    ax.set_yticks(ticks[(ticks >= 0) & (ticks <= tick_max)])
    ax.set_xticks(range(len(modes)), modes)
    ax.set_xlim(-0.6, len(modes) - 0.4 + _PAPER_OFFSET)
    ax.set_title(title)
    ax.set_xlabel("Control mode")
    ax.set_ylabel(ylabel)
    ax.grid(axis="y", alpha=0.3)
    ax.set_axisbelow(True)
    p = result["anova"]["p"]
    if p is None or math.isnan(p):  # no brackets then means "no test", not "not significant"
        ax.text(
            0.5,
            0.98,
            "tests undefined (see the stats note)",
            transform=ax.transAxes,
            ha="center",
            va="top",
            fontsize=8,
            color="dimgray",
        )


def _measures_panel(ax, means: pd.DataFrame, result: dict, panel: tuple, rng) -> None:
    """Grouped bars: one group per measure that has answers, one bar per mode in it."""
    title, ylabel, (low, high), measures, labels = panel
    present = [(m, label) for m, label in zip(measures, labels) if (means["measure"] == m).any()]
    modes = ordered_modes(means.loc[means["measure"].isin([m for m, _ in present]), "mode"])
    width = 0.8 / len(modes)
    span = high - low
    top = high
    for g, (measure, _) in enumerate(present):
        x_of = {mode: g + (i - (len(modes) - 1) / 2) * width for i, mode in enumerate(modes)}
        group_top = -math.inf
        for mode in modes:
            values = means.loc[(means["measure"] == measure) & (means["mode"] == mode), "value"].to_numpy()
            if not len(values):
                continue
            mean, sd = values.mean(), (values.std(ddof=1) if len(values) > 1 else 0.0)
            ax.bar(
                x_of[mode],
                mean,
                width=0.92 * width,
                color=_COLORS.get(mode, "#937860"),
                alpha=0.75,
                yerr=sd,
                capsize=3,
                error_kw={"lw": 1.0},
                label=mode if g == 0 else None,
            )
            ax.scatter(
                x_of[mode] + rng.uniform(-0.2, 0.2, len(values)) * width,
                values,
                s=8,
                color="black",
                alpha=0.6,
                zorder=3,
            )
            group_top = max(group_top, values.max(), mean + sd)
        pairs = [p for p in result["tests"] if p["measure"] == measure]
        top = max(top, _brackets(ax, pairs, x_of, group_top, span))
    if measures[0] == "ueq_pragmatic" and len(present) > 3:  # scales | items
        ax.axvline(2.5, color="gray", lw=0.8, ls="--")
    if low < 0:
        ax.axhline(0.0, color="black", lw=0.8)
    ax.set_ylim(low - 0.04 * span, top + 0.2 * span)  # room for the legend above the brackets
    ticks = ax.get_yticks()
    ax.set_yticks(ticks[(ticks >= low) & (ticks <= high)])
    ax.set_xticks(range(len(present)), [label for _, label in present], fontsize=8)
    ax.set_xlim(-0.6, len(present) - 0.4)
    ax.set_title(title)
    ax.set_ylabel(ylabel)
    ax.grid(axis="y", alpha=0.3)
    ax.set_axisbelow(True)
    ax.legend(fontsize=8, loc="upper right", ncols=len(modes), frameon=False)


def fig8_figure(trials: pd.DataFrame, stats: dict | None = None, questionnaires: dict | None = None) -> Figure:
    """Fig. 8 as a matplotlib ``Figure`` (on its own Agg canvas, not saved): (a) success
    rate and (b) completion time per mode, and from ``questionnaires`` (``{"means":
    participant_measures table, "tlx": ..., "ueq": ...}``, the last two as
    ``compare_measures`` gives; a key left out or None: no such answers) (c) NASA-TLX and
    (d) UEQ-S. ``stats`` is ``{"success": ..., "time": ...}`` as ``compare_modes`` (or
    ``write_summary``, or its ``stats.json``) gives; computed here when None. Modes in
    ``MODE_ORDER`` (manual, autonomous, shared, then mpc and rl). Its axes are the panels, in
    order; each panel's bars are ``ax.patches`` and its participants' dots a collection."""
    if stats is None:
        stats = {metric: compare_modes(trials, metric) for metric in ("success", "time")}
    extra = [key for key in ("tlx", "ueq") if (questionnaires or {}).get(key) is not None]
    layout = [["a"] * 5 + ["b"] * 5]  # ten columns: (d)'s 11 groups get 6 of them beside (c)'s 8
    layout += [["c"] * 4 + ["d"] * 6] if len(extra) == 2 else [["c"] * 10] if extra else []
    fig = Figure(figsize=(11 if len(layout) == 1 else 14, 4.6 * len(layout)), dpi=150, layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplot_mosaic(layout)
    rng = np.random.default_rng(0)  # jitter only: the same figure for the same trials
    for ax, panel in zip((axes["a"], axes["b"]), _PANELS):
        means = participant_means(trials, panel[0])
        _panel(ax, means, ordered_modes(means["mode"]), stats[panel[0]], panel, rng)
    for name, key in zip("cd", extra):
        _measures_panel(axes[name], questionnaires["means"], questionnaires[key], _QUESTIONNAIRE_PANELS[key], rng)
    fig.legend(*axes["a"].get_legend_handles_labels(), loc="outside lower center", ncols=3, fontsize=8, frameon=False)
    fig.suptitle(
        f"Shared-control study: success and completion time{' and questionnaires' if extra else ''} "
        "per mode (stars: Holm-corrected paired t-tests)",
        fontsize=11,
    )
    return fig


def plot_fig8(trials: pd.DataFrame, path, stats: dict | None = None, questionnaires: dict | None = None) -> list[str]:
    """Write Fig. 8 (``fig8_figure``, same arguments) to ``path`` (PNG, 150 dpi; its
    folder created). Returns the titles of the panels drawn."""
    fig = fig8_figure(trials, stats, questionnaires)
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=150)
    return [ax.get_title() for ax in fig.axes]
