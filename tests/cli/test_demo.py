"""The main job: ``otgym demo`` plans on the default chip, evaluates a speed-control
policy against the constant speeds, carries a cell through the chip and writes its
files and report.md; bad input is one clear line."""

import csv
import json

import numpy as np
import pytest

from otgym.cli.app import main
from otgym.envs import transport as tr
from otgym.experiments.demo import DemoConfig, run_demo
from otgym.experiments.transport import TransportDemo, run
from otgym.rl.policy import PRETRAINED_POLICY, load_policy, save_policy
from tests.conftest import FIXED_POLICY_HIDDEN as HIDDEN
from tests.experiments.test_speed_control_eval import EPISODES

SHORT_LEG = TransportDemo(start_um=(15.0, 40.0), goal_um=(60.0, 40.0), n_runs=2)


def test_transport_demo_carries_the_cell_to_the_goal_and_writes_its_files(tmp_path):
    """A short leg of the top-left branch (45 um at 4 um/s, two runs at once): the cell
    ends within 1 um of the goal in the run shown, carried only by contact."""
    demo = SHORT_LEG
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


@pytest.mark.parametrize("arguments, name", [
    (["--speed-um-s", "-1"], "speed_um_s"),
    (["--runs", "0"], "n_runs"),
    (["--policy", "missing.npz"], "does not exist"),
    (["--episodes", "0"], "episodes"),
])
def test_cli_rejects_bad_input_with_one_line(tmp_path, capsys, arguments, name):
    with pytest.raises(SystemExit) as exit_info:
        main(["demo", "--out", str(tmp_path), *arguments])
    assert exit_info.value.code == 2
    error = capsys.readouterr().err.strip()
    assert error.startswith("error:") and name in error and "\n" not in error


def test_demo_writes_tables_figures_and_a_report_beside_the_paper(tmp_path, fixed_action_q_params):
    """The whole main job on a short leg with a policy that always drives at the slowest
    level: its Table II row equals G1's exactly in time, and the report quotes both."""
    policy = save_policy(tmp_path / "slow.npz", fixed_action_q_params(0), {"preset": "paper", "hidden": list(HIDDEN)})
    stages = []
    summary = run_demo(DemoConfig(policy=str(policy), episodes=EPISODES, transport=SHORT_LEG), tmp_path / "out",
                       stages.append)
    out = tmp_path / "out"
    for name in ("report.md", "summary.json", "plan/metrics.md", "plan/paths.png", "speed_control/table.csv",
                 "speed_control/safety.png", "speed_control/safety.json", "transport/transport.png"):
        assert (out / name).is_file(), name
    assert len(stages) == 3
    rows = {row["policy"]: row for row in summary["table_ii"]}
    assert rows["RL"]["success_rate"] == rows["G1"]["success_rate"] == 1.0
    assert rows["RL"]["ATCT_s"] == pytest.approx(rows["G1"]["ATCT_s"], abs=1e-4)
    report = (out / "report.md").read_text()
    assert f"| RL | learned | {rows['RL']['ASR']:.3f} | {rows['RL']['ATCT_s']:.2f} |" in report
    assert "| 1.000 | 38.92 |" in report  # the paper's RL row beside ours
    assert f"{summary['transport']['reached_goal']} of 2 runs" in report
    assert json.loads((out / "summary.json").read_text())["rl_asr"] == rows["RL"]["ASR"]


def test_pretrained_policy_ships_and_fits_the_paper_preset():
    q_params, meta = load_policy(PRETRAINED_POLICY, tr.OBS_SIZE, 6)
    assert meta["preset"] == "paper" and meta["env_steps"] > 0


def test_demo_rejects_a_policy_of_the_wrong_shape(tmp_path, capsys, fixed_action_q_params):
    policy = save_policy(tmp_path / "wide.npz", fixed_action_q_params(0, n_actions=10),
                         {"preset": "paper", "hidden": list(HIDDEN)})
    with pytest.raises(SystemExit):
        main(["demo", "--out", str(tmp_path / "out"), "--policy", str(policy)])
    assert "does not fit" in capsys.readouterr().err
