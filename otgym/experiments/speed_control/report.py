"""What an evaluation of the speed controller writes (``otgym evaluate``, the demo's
speed-control stage): Table II as table.csv and table.md beside the paper's, the safety
figure (the paper's Fig. 7), safety.json and acceptance.json."""

from __future__ import annotations

import csv
import json
from pathlib import Path

from otgym.experiments.common.paper_tables import table_ii_markdown
from otgym.experiments.speed_control.evaluate import Evaluation, acceptance, passes


def write_table(evaluation: Evaluation, out_dir: Path) -> list[dict]:
    """``table.csv`` and ``table.md`` (rows RL, G1..Gn), with the paper's Table II beside."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    rows = [row for row in evaluation.rows() if row["policy"] != "untrained"]
    with open(out_dir / "table.csv", "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    lines = table_ii_markdown(rows)
    (out_dir / "table.md").write_text("\n".join(lines) + "\n")
    return rows


def write_results(
    evaluation: Evaluation, out_dir: Path, force_limit_pn: float, distance_limit_um: float
) -> tuple[list[dict], dict, dict]:
    """Everything an evaluation writes into ``out_dir``: table.csv and table.md
    (``write_table``), safety.png, safety.json (RL and untrained) and acceptance.json
    (``acceptance`` plus ``passes``). Returns (rows, safety, checks)."""
    out_dir = Path(out_dir)
    rows = write_table(evaluation, out_dir)
    write_safety_figure(evaluation, out_dir / "safety.png", force_limit_pn, distance_limit_um)
    safety = {name: evaluation.safety(name, force_limit_pn, distance_limit_um) for name in ("RL", "untrained")}
    (out_dir / "safety.json").write_text(json.dumps(safety, indent=2))
    checks = acceptance(evaluation, safety["RL"])
    (out_dir / "acceptance.json").write_text(json.dumps({**checks, "passes": passes(checks)}, indent=2))
    return rows, safety, checks


def write_safety_figure(evaluation: Evaluation, path: Path, force_limit_pn: float, distance_limit_um: float) -> None:
    """Violin plots of contact force and handle-to-trap distance, untrained vs trained
    (the paper's Fig. 7)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    before, after = evaluation.names.index("untrained"), evaluation.names.index("RL")
    fig, axes = plt.subplots(1, 2, figsize=(9, 4))
    for ax, samples, limit, label in (
        (axes[0], evaluation.force_pn, force_limit_pn, "robot-cell contact force (pN)"),
        (axes[1], evaluation.distance_um, distance_limit_um, "handle-to-trap distance (um)"),
    ):
        data = [samples[before], samples[after]]
        ax.violinplot(data, showmedians=True)
        ax.boxplot(data, widths=0.12, showfliers=False)
        ax.axhline(limit, color="tab:red", ls="--", lw=1, label=f"limit {limit:g}")
        ax.set_xticks([1, 2], ["before training", "after training"])
        ax.set_ylabel(label)
        ax.legend(loc="upper right")
    fig.suptitle("Safety during speed control (paper Fig. 7)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
