"""The main job: ``otgym demo`` carries a cell through the default chip and writes its
files; bad input is one clear line."""

import csv
import json

import numpy as np
import pytest

from otgym.cli.app import main
from otgym.experiments.transport import TransportDemo, run


def test_transport_demo_carries_the_cell_to_the_goal_and_writes_its_files(tmp_path):
    """A short leg of the top-left branch (45 um at 4 um/s, two runs at once): the cell
    ends within 1 um of the goal in the run shown, carried only by contact."""
    demo = TransportDemo(start_um=(15.0, 40.0), goal_um=(60.0, 40.0), n_runs=2)
    summary = run(demo, tmp_path)
    rows = list(csv.DictReader(open(tmp_path / "trajectory.csv")))
    assert summary["reached_goal"] >= 1
    end = np.array([float(rows[-1]["cell_x_um"]), float(rows[-1]["cell_y_um"])])
    assert np.linalg.norm(end - np.array(demo.goal_um)) < 1.0
    assert all(float(r["contact_force_a_pn"]) > 0 and float(r["contact_force_b_pn"]) > 0 for r in rows)
    path = np.loadtxt(tmp_path / "path.csv", delimiter=",", skiprows=1)
    assert np.linalg.norm(path[0] - demo.start_um) < 1.0 and np.linalg.norm(path[-1] - demo.goal_um) < 1.0
    assert (tmp_path / "transport.png").stat().st_size > 20_000
    assert json.loads((tmp_path / "summary.json").read_text()) == summary


@pytest.mark.parametrize("arguments, name", [(["--speed-um-s", "-1"], "speed_um_s"), (["--runs", "0"], "n_runs")])
def test_cli_rejects_bad_input_with_one_line(tmp_path, capsys, arguments, name):
    with pytest.raises(SystemExit) as exit_info:
        main(["demo", "--out", str(tmp_path), *arguments])
    assert exit_info.value.code == 2
    error = capsys.readouterr().err.strip()
    assert error.startswith("error:") and name in error and "\n" not in error
