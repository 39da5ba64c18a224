"""A sweep's summary: the finished cells' results side by side, for the commands that
write a table or a figure worth comparing.

For each command: the files whose rows are stacked, one block per cell with the cell's
name and grid options first (a JSON summary gives one row, a CSV table all its rows),
and the figure put side by side in one image:

- ``train``: ``training.json`` -> ``DIR/training.csv``; ``learning_curve.png`` ->
  ``DIR/learning_curves.png``;
- ``evaluate``: Table II, ``table.csv`` -> ``DIR/table.csv`` and ``DIR/table.md``;
  ``safety.png`` -> ``DIR/safety.png``;
- ``experiment shared-control``: ``summary.csv`` -> ``DIR/summary.csv``; ``fig8.png``;
- ``experiment route-bound``: ``route_bound.csv`` -> ``DIR/route_bound.csv``.
"""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

from otgym.cluster.output import finished_meta
from otgym.cluster.sweep_file import Sweep

TABLES = {
    "train": ("training.json", "learning_curve.png", "learning_curves.png"),
    "evaluate": ("table.csv", "safety.png", "safety.png"),
    "experiment shared-control": ("summary.csv", "fig8.png", "fig8.png"),
    "experiment route-bound": ("route_bound.csv", None, None),
}
"""command -> (table stacked into DIR/<same name, .json as .csv>, figure of each cell, figure side by side)."""


def _rows(path: Path) -> list[dict]:
    if path.suffix == ".json":
        data = json.loads(path.read_text())
        return [{key: value for key, value in data.items() if not isinstance(value, (list, dict))}]
    with open(path, newline="") as handle:
        return list(csv.DictReader(handle))


def _write_table(rows: list[dict], path: Path) -> None:
    columns = list(dict.fromkeys(key for row in rows for key in row))
    with open(path, "w", newline="") as handle:
        writer = csv.DictWriter(handle, columns, lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows)
    if path.name == "table.csv":  # Table II as Markdown too
        lines = ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
        lines += ["| " + " | ".join(str(row.get(column, "")) for column in columns) + " |" for row in rows]
        path.with_suffix(".md").write_text("\n".join(lines) + "\n")


def _side_by_side(images: list[tuple[str, Path]], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.image as mpimg
    import matplotlib.pyplot as plt

    columns = min(len(images), 4)
    rows = math.ceil(len(images) / columns)
    fig, axes = plt.subplots(rows, columns, figsize=(5 * columns, 3.2 * rows), squeeze=False)
    for ax in axes.flat:
        ax.axis("off")
    for ax, (name, image) in zip(axes.flat, images):
        ax.imshow(mpimg.imread(image))
        ax.set_title(name, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write_summary(sweep: Sweep, out_dir: Path) -> list[Path]:
    """Write the command's summary files from the finished cells (none for a command
    without one, or when no cell finished); returns the paths written."""
    out_dir = Path(out_dir)
    if sweep.command.name not in TABLES:
        return []
    table, figure, figure_out = TABLES[sweep.command.name]
    finished = [cell for cell in sweep.cells if finished_meta(out_dir, cell.name) is not None]
    written = []
    rows = []
    for cell in finished:
        source = out_dir / cell.name / table
        if source.is_file():
            rows += [{"cell": cell.name, **cell.grid, **row} for row in _rows(source)]
    if rows:
        path = out_dir / Path(table).with_suffix(".csv").name
        _write_table(rows, path)
        written.append(path)
        if path.name == "table.csv":
            written.append(path.with_suffix(".md"))
    images = [(cell.name, out_dir / cell.name / figure) for cell in finished if figure]
    images = [(name, image) for name, image in images if image.is_file()]
    if images:
        _side_by_side(images, out_dir / figure_out)
        written.append(out_dir / figure_out)
    return written
