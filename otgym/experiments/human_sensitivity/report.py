"""The files of ``otgym experiment human-sensitivity``
(``otgym.experiments.human_sensitivity``): trials.csv (every trial, with its
``sample``), samples.csv (each sample's parameter values, its modes' time and success,
(b) and (d)), indices.csv (each parameter's Morris or Sobol indices per item),
sensitivity.md (the tables, the run's command and sizes, the seed's status) and
sensitivity.png (which assumptions decide (b) and (d))."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from otgym.experiments.human_sensitivity.config import DUMMY, OUTPUTS
from otgym.experiments.human_sensitivity.run import deciding, problem

ITEMS = {
    "b": "(b) manual / shared completion time",
    "d": "(d) shared - manual success",
}


def write_report(
    method: str,
    labels: list[str],
    samples: np.ndarray,
    trials: pd.DataFrame,
    outputs: pd.DataFrame,
    indices: pd.DataFrame,
    out: Path,
    command: str,
    note: str | None,
) -> None:
    """Write every file into ``out`` (made if missing)."""
    out.mkdir(parents=True, exist_ok=True)
    trials.to_csv(out / "trials.csv", index=False)
    values = pd.DataFrame(samples, columns=problem(labels)["names"])
    pd.concat([outputs[["sample"]], values, outputs.drop(columns="sample")], axis=1).to_csv(
        out / "samples.csv", index=False
    )
    indices.to_csv(out / "indices.csv", index=False)
    (out / "sensitivity.md").write_text(markdown(method, indices, outputs, trials, command, note))
    plot(method, indices, out / "sensitivity.png")


def _number(value: float, digits: int = 3) -> str:
    return "n/a" if not math.isfinite(value) else f"{value:.{digits}f}"


def markdown(
    method: str, indices: pd.DataFrame, outputs: pd.DataFrame, trials: pd.DataFrame, command: str, note: str | None
) -> str:
    """sensitivity.md: per item, every parameter's indices (largest first) with their
    intervals, and the three that decide it."""
    lines = [f"**{note}.**", ""] if note else []
    n_samples, participants = len(outputs), trials.participant.nunique()
    per_mode = len(trials) // max(n_samples, 1) // 2
    lines += [
        f"# Which assumptions decide Fig. 8's (b) and (d): {method.capitalize()}",
        "",
        f"Made by `{command}`: {n_samples} samples, each {participants} participants x "
        f"{per_mode // max(participants, 1)} trials per mode ({len(trials)} trials). "
        + (
            "Morris: mu* is the mean absolute elementary effect of moving a parameter across its range "
            "(in the item's unit per range), sigma its spread (interactions, non-linearity, noise); "
            "the interval is a 95 % bootstrap over trajectories."
            if method == "morris"
            else "Sobol: S1 is the share of the item's variance a parameter explains alone, ST with its "
            "interactions; the interval is a 95 % bootstrap."
        )
        + f" `{DUMMY}` is read by nothing: its index is what noise alone gives.",
        "",
    ]
    for item in OUTPUTS:
        rows = indices[indices["item"] == item]
        y = outputs[item].to_numpy(float)
        finite = y[np.isfinite(y)]
        lines += [
            f"## {ITEMS[item]}",
            "",
            f"Over the samples: mean {_number(float(finite.mean()) if len(finite) else math.nan)}, "
            f"range {_number(float(finite.min()) if len(finite) else math.nan)} to "
            f"{_number(float(finite.max()) if len(finite) else math.nan)}"
            + (f"; {int(rows.imputed.iloc[0])} samples had no value (set to the mean)" if rows.imputed.any() else "")
            + ". Above the dummy, largest first: "
            + (", ".join(f"`{name}`" for name in deciding(indices).get(item, [])) or "none")
            + ".",
            "",
        ]
        if method == "morris":
            lines += ["| rank | parameter | mu* [95 % CI] | mu | sigma |", "|---|---|---|---|---|"]
            for row in rows.itertuples():
                low, high = row.mu_star - row.mu_star_conf, row.mu_star + row.mu_star_conf
                lines.append(
                    f"| {row.rank} | `{row.parameter}` | {_number(row.mu_star)} [{_number(low)}, {_number(high)}] "
                    f"| {_number(row.mu)} | {_number(row.sigma)} |"
                )
        else:
            lines += ["| rank | parameter | S1 [95 % CI] | ST [95 % CI] |", "|---|---|---|---|"]
            for row in rows.itertuples():
                lines.append(
                    f"| {row.rank} | `{row.parameter}` | {_number(row.s1)} [{_number(row.s1 - row.s1_conf)}, "
                    f"{_number(row.s1 + row.s1_conf)}] | {_number(row.st)} [{_number(row.st - row.st_conf)}, "
                    f"{_number(row.st + row.st_conf)}] |"
                )
        lines.append("")
    return "\n".join(lines)


def plot(method: str, indices: pd.DataFrame, path: Path, top: int = 12) -> None:
    """One panel per item: the ``top`` parameters by mu* (Morris; sigma as a dot) or ST
    (Sobol; S1 beside it), with 95 % intervals, and the dummy's as the noise floor."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    key = "mu_star" if method == "morris" else "st"
    fig, axes = plt.subplots(1, len(OUTPUTS), figsize=(11.0, 0.32 * top + 1.8))
    for ax, item in zip(np.atleast_1d(axes), OUTPUTS):
        rows = indices[indices["item"] == item].sort_values(key, ascending=False)
        shown = rows[rows.parameter != DUMMY].head(top)
        y = np.arange(len(shown))
        if method == "morris":
            ax.barh(y, shown.mu_star, xerr=shown.mu_star_conf, color="tab:blue", alpha=0.8, label="mu*")
            ax.plot(shown.sigma, y, "o", color="tab:red", ms=4, label="sigma")
        else:
            ax.barh(y - 0.2, shown.st, 0.4, xerr=shown.st_conf, color="tab:blue", label="ST")
            ax.barh(y + 0.2, shown.s1, 0.4, xerr=shown.s1_conf, color="tab:orange", label="S1")
        floor = rows[rows.parameter == DUMMY][key]
        if len(floor):
            ax.axvline(float(floor.iloc[0]), color="grey", ls="--", lw=1, label=f"{DUMMY} (noise)")
        ax.set_yticks(y, list(shown.parameter), fontsize=8)
        ax.invert_yaxis()
        ax.set_title(ITEMS[item], fontsize=10)
        ax.set_xlabel("mu* (item's unit per range)" if method == "morris" else "Sobol index")
        ax.legend(loc="lower right", fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
