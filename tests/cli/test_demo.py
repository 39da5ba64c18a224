"""The main job: ``otgym demo`` writes its files; bad input is one clear line."""

import csv
import json

import pytest

from otgym.cli.app import main
from otgym.experiments.trapped_robot import TrappedRobotDemo, run


def test_demo_run_writes_trajectory_figure_and_summary(tmp_path):
    summary = run(TrappedRobotDemo(side_um=2.0, speed_um_s=10.0), tmp_path)
    rows = list(csv.DictReader(open(tmp_path / "trajectory.csv")))
    assert len(rows) == 40  # 4 sides * 0.2 s at 50 Hz
    last = rows[-1]
    # after one lap the robot is back near the start (within the thermal spread)
    assert abs(float(last["x_um"])) < 0.2 and abs(float(last["y_um"])) < 0.2
    assert (tmp_path / "trajectory.png").stat().st_size > 10_000
    assert json.loads((tmp_path / "summary.json").read_text()) == summary
    assert summary["trap_lost"] is False


def test_cli_rejects_bad_speed_with_one_line(tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["demo", "--out", str(tmp_path), "--speed-um-s", "-1"])
    assert exit_info.value.code == 2
    error = capsys.readouterr().err.strip()
    assert error.startswith("error:") and "speed_um_s" in error and "\n" not in error
