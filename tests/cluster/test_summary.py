"""The sweep's summary puts the finished cells' results side by side: training
summaries as rows of one table with the learning curves in one figure; Table II rows of
every evaluation cell in one table."""

import csv
import json

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from otgym.cluster.summary import write_summary  # noqa: E402
from otgym.cluster.sweep_file import CommandSpec, OptionSpec, load_sweep  # noqa: E402
from tests.cluster.helpers import write_sweep_file  # noqa: E402

SPECS = {
    "train": CommandSpec(("train",), {"seed": OptionSpec("seed", "--seed", "int")}),
    "evaluate": CommandSpec(("evaluate",), {"seed": OptionSpec("seed", "--seed", "int")}),
}


def finished_cell(folder, name, files):
    (folder / name).mkdir(parents=True)
    (folder / name / "cell.json").write_text(json.dumps({"wall_s": 1.0, "node": "n", "node_id": ""}))
    for file_name, text in files.items():
        (folder / name / file_name).write_text(text)


def small_png(path):
    fig, ax = plt.subplots(figsize=(2, 1))
    ax.plot([0, 1], [0, 1])
    fig.savefig(path)
    plt.close(fig)


def rows(path):
    with open(path, newline="") as handle:
        return list(csv.DictReader(handle))


def test_training_cells_side_by_side(tmp_path):
    sweep = load_sweep(write_sweep_file(tmp_path / "s.toml", "train", {}, {"seed": [0, 1, 2]}), SPECS)
    out = tmp_path / "out"
    for seed in (0, 2):  # seed-1 did not finish
        finished_cell(out, f"seed-{seed}", {"training.json": json.dumps({"episodes": 10 + seed, "hidden": [8]})})
        small_png(out / f"seed-{seed}" / "learning_curve.png")
    written = write_summary(sweep, out)
    assert [path.name for path in written] == ["training.csv", "learning_curves.png"]
    table = rows(out / "training.csv")
    assert [(row["cell"], row["seed"], row["episodes"]) for row in table] == [
        ("seed-0", "0", "10"),
        ("seed-2", "2", "12"),
    ]
    assert "hidden" not in table[0] and (out / "learning_curves.png").stat().st_size > 1000


def test_table_ii_rows_of_every_evaluation_cell_in_one_table(tmp_path):
    sweep = load_sweep(write_sweep_file(tmp_path / "s.toml", "evaluate", {}, {"seed": [1, 2]}), SPECS)
    out = tmp_path / "out"
    for seed in (1, 2):
        table = f"policy,ASR\nRL,0.{seed}\nG1,0.5\n"
        finished_cell(out, f"seed-{seed}", {"table.csv": table})
    write_summary(sweep, out)
    table = rows(out / "table.csv")
    assert [(row["cell"], row["policy"], row["ASR"]) for row in table] == [
        ("seed-1", "RL", "0.1"),
        ("seed-1", "G1", "0.5"),
        ("seed-2", "RL", "0.2"),
        ("seed-2", "G1", "0.5"),
    ]
    assert (out / "table.md").read_text().splitlines()[0] == "| cell | seed | policy | ASR |"
