"""``report.md`` of ``otgym study analyze``: the participants and their orders of modes
(with the count of each mode at each block position: the Latin square's balance), Fig.
8 and the summary with its paired tests, the mixed-effects models and the order effects
(``otgym.study.mixed``) with their figure ``order_effects.png``."""

from __future__ import annotations

import math
from pathlib import Path

import pandas as pd
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from otgym.study.mixed import TRIAL_MEASURES, cell_means, trial_values
from otgym.study.stats import ordered_modes

MEASURE_TITLES = {
    "success": "obstacles avoided per trial (proportion)",
    "time": "completion time of trials that reached the goal (s)",
    "raw_tlx": "raw NASA-TLX (0-100)",
    "ueq_overall": "UEQ-S overall (-3..+3)",
}


def _n(value: float, spec: str = ".3g") -> str:
    return "n/a" if value is None or (isinstance(value, float) and math.isnan(value)) else format(value, spec)


def orders_markdown(orders: dict[str, list[str]]) -> list[str]:
    """The participants' orders and how often each mode came at each position."""
    if not orders:
        return ["No participant folder recorded an order of modes (not `otgym study run` folders).", ""]
    lines = ["| participant | order of the modes |", "|---|---|"]
    lines += [f"| {p} | {', '.join(order)} |" for p, order in sorted(orders.items())]
    modes = ordered_modes({mode for order in orders.values() for mode in order})
    positions = max(len(order) for order in orders.values())
    lines += ["", "Times each mode came at each block position:", ""]
    lines += ["| mode | " + " | ".join(str(i) for i in range(1, positions + 1)) + " |", "|---|" + "---:|" * positions]
    for mode in modes:
        counts = [sum(1 for order in orders.values() if len(order) > i and order[i] == mode) for i in range(positions)]
        lines.append(f"| {mode} | " + " | ".join(str(c) for c in counts) + " |")
    return lines + [""]


def models_markdown(models: dict) -> list[str]:
    lines = []
    for measure, found in models.items():
        mixed = found["mixed"]
        lines += [f"### {MEASURE_TITLES.get(measure, measure)}", ""]
        if "note" in mixed:
            lines += [f"Mixed model {mixed['formula']}: not fitted ({mixed['note']}).", ""]
        else:
            lines += [
                f"Mixed model {mixed['formula']} (REML; n = {mixed['n']} from {mixed['participants']} participants; "
                f"reference mode {mixed['reference']}; converged: {mixed['converged']}); participant variance "
                f"{_n(mixed['participant_variance'])}, residual variance {_n(mixed['residual_variance'])}.",
                "",
                "| term | estimate | SE | z | p | 95 % CI |",
                "|---|---:|---:|---:|---:|---|",
            ]
            for c in mixed["coefficients"]:
                lines.append(
                    f"| {c['term']} | {_n(c['estimate'])} | {_n(c['se'])} | {_n(c['z'])} | {_n(c['p'])} | "
                    f"[{_n(c['ci_low'])}, {_n(c['ci_high'])}] |"
                )
            lines.append("")
        order = found.get("order")
        if order is None:
            continue
        if "note" in order:
            lines += [f"Order effects: not tested ({order['note']}).", ""]
            continue
        for name, title in (("position", "block position"), ("mode_x_position", "mode x position")):
            test = order[name]
            if "note" in test:
                lines.append(f"- {title}: not tested ({test['note']})")
            else:
                lines.append(
                    f"- {title}: likelihood ratio {_n(test['lr'])}, df {test['dof']}, p = {_n(test['p'])} "
                    f"(ML fits; converged: {test['converged']})"
                )
        lines.append("")
    return lines


def plot_order_effects(trials: pd.DataFrame, path: Path) -> bool:
    """Mean of each trial measure per block position, a line per mode; False (nothing
    drawn) when the trials carry no position."""
    if "position" not in trials.columns:
        return False
    figure = Figure(figsize=(10, 4), layout="constrained")
    FigureCanvasAgg(figure)
    for index, measure in enumerate(TRIAL_MEASURES):
        ax = figure.add_subplot(1, len(TRIAL_MEASURES), index + 1)
        frame = trial_values(trials, measure)
        if not frame.empty:
            means = cell_means(frame)
            for mode in ordered_modes(means["mode"]):
                here = means[means["mode"] == mode]
                ax.plot(here["position"].astype(int), here["mean"], marker="o", label=mode)
            ax.legend(fontsize=8)
        ax.set_xlabel("block position")
        ax.set_title(MEASURE_TITLES[measure], fontsize=9)
    figure.savefig(path, dpi=100)
    return True


def write_report(out: Path, summary_md: str, models: dict, orders: dict, order_figure: bool) -> Path:
    lines = [
        "# Study report",
        "",
        "## Participants and order of the modes",
        "",
        *orders_markdown(orders),
        "## Fig. 8",
        "",
        "![Fig. 8](fig8.png)",
        "",
        *["#" + line if line.startswith("#") else line for line in summary_md.splitlines()],
        "",
        "## Mixed-effects models (participant as a random effect) and order effects",
        "",
        *models_markdown(models),
    ]
    if order_figure:
        lines += ["![Order effects](order_effects.png)", ""]
    path = Path(out) / "report.md"
    path.write_text("\n".join(lines), encoding="utf-8")
    return path
