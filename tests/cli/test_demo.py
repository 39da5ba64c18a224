"""The main job: ``otgym demo`` plans on the default chip, evaluates a speed-control
policy against the constant speeds, carries a cell through the chip, runs a small
shared-control study and writes its files and report.md, one progress line per stage;
bad input is one clear line before any work."""

import contextlib
import io
import json
import threading
import time

import numpy as np
import pandas as pd
import pytest

from otgym.cli.app import main
from otgym.experiments.demo import config as demo_config_module
from otgym.experiments.demo import run as demo_module
from otgym.experiments.demo import tasks as demo_tasks
from otgym.rl.policy import PRETRAINED_POLICY, load_policy, save_policy
from otgym.sim.chip import load_chip
from otgym.study import wilson_interval
from otgym.task.task import InteractiveConfig
from otgym.tasks.transport import core as tr
from tests.conftest import FIXED_POLICY_HIDDEN as HIDDEN
from tests.experiments.test_speed_control_eval import EPISODES


@pytest.fixture(scope="module")
def demo_run(tmp_path_factory, fixed_action_q_params):
    """The whole main job from the command line, run once for this module's two demo
    tests, small: 4 episodes with a policy that always drives at the slowest level (its
    Table II row equals G1's exactly in time), one whole-path scenario to its end (the
    route follower and the learned speed), and a study of 2 participants x 1 trial x 3
    modes cut at 30 s, long enough for the assembly to reach the obstacles' crossings
    (the demo's 20 s cut once met none: its Fig. 8 said "avoided 0 of 0"). The study
    runs in a thread beside the other stages, as by default. Returns the output folder
    and what the command printed."""
    folder = tmp_path_factory.mktemp("demo")
    policy = save_policy(folder / "slow.npz", fixed_action_q_params(0), {"preset": "paper", "hidden": list(HIDDEN)})
    out = folder / "out"
    printed = io.StringIO()
    with (
        contextlib.redirect_stdout(printed),
        pytest.raises(SystemExit) as exit_info,
        pytest.MonkeyPatch.context() as mp,
    ):
        # of the other tasks, only sort-cells, at the size of its report's test (its programs compiled once)
        mp.setattr(demo_tasks, "task_names", lambda: ("sort-cells",))
        main(
            [
                "demo",
                "--out",
                str(out),
                "--policy",
                str(policy),
                "--episodes",
                str(EPISODES),
                "--runs",
                "1",
                "--study-participants",
                "2",
                "--study-trials",
                "1",
                "--study-time-limit-s",
                "30",
                "--task-episodes",
                "4",
            ]
        )
    assert exit_info.value.code == 0, printed.getvalue()
    return out, printed.getvalue()


@pytest.mark.slow
@pytest.mark.xdist_group("demo_run")  # one worker runs the module's demo once for both
def test_the_whole_path_reaches_the_goal_past_the_obstacles_with_the_learned_speed(demo_run):
    """The demo's whole path (seed 1: scenario 15000), run by the route follower at
    5 um/s and the learned speed in one batch: the learned speed carries the cell to the
    goal without losing a trap, and the files hold what the summary says. Fails if the
    learned speed's run does not reach the goal."""
    out, _ = demo_run
    folder = out / "whole_path"
    summary = json.loads((folder / "summary.json").read_text())
    follower, learned = summary["modes"]
    assert summary["scenarios"] == [15000] and (follower["mode"], learned["mode"]) == ("autonomous", "rl")
    assert learned["reached_goal"] == 1 and learned["trap_losses"] == 0, summary
    trials = pd.read_csv(folder / "trials.csv")
    assert list(trials["mode"]) == ["autonomous", "rl"] and list(trials["scenario"]) == [15000, 15000]
    assert list(trials["reached_goal"]) == [follower["reached_goal"] == 1, True]
    cells = pd.read_csv(folder / "cells.csv")
    end = cells[cells["mode"] == "rl"].iloc[-1]
    goal = np.array(load_chip("default").site_um(InteractiveConfig().goal_um))
    tolerance = InteractiveConfig().goal_tolerance_um
    assert np.linalg.norm([end["cell_x_um"] - goal[0], end["cell_y_um"] - goal[1]]) < tolerance + 0.5
    assert (folder / "whole_path.png").stat().st_size > 20_000
    assert json.loads((out / "summary.json").read_text())["whole_path"] == summary


@pytest.mark.parametrize(
    "arguments, message",
    [
        (["--speed-um-s", "-1"], "--speed-um-s must lie in [0.5, 20.0], not -1"),
        (["--speed-um-s", "nan"], "--speed-um-s must lie in [0.5, 20.0], not nan"),
        (["--runs", "0"], "--runs must lie in [1, 64], not 0"),
        (["--runs", "1000"], "--runs must lie in [1, 64], not 1000"),
        (["--policy", "missing.npz"], "does not exist"),
        (["--episodes", "0"], "--episodes must lie in [1, 4096], not 0"),
        (["--episodes", "1000000"], "--episodes must lie in [1, 4096], not 1000000"),
        (["--seed", "-1"], "--seed must lie in [0, 4294967295], not -1"),
        (["--seed", str(2**32)], f"--seed must lie in [0, 4294967295], not {2**32}"),
        (["--study-participants", "1"], "--study-participants must be an integer in [2, 16], got 1"),
        (["--study-trials", "100"], "--study-trials must lie in [1, 8], not 100"),
        (["--study-time-limit-s", "0"], "--study-time-limit-s must lie in [1.0, 300.0], not 0"),
        (["--task-episodes", "-1"], "--task-episodes must lie in [0, 256], not -1"),
        (["--task-episodes", "257"], "--task-episodes must lie in [0, 256], not 257"),
    ],
)
def test_cli_rejects_bad_input_with_one_line_before_any_work(tmp_path, capsys, arguments, message):
    out = tmp_path / "never"
    with pytest.raises(SystemExit) as exit_info:
        main(["demo", "--out", str(out), *arguments])
    assert exit_info.value.code == 2
    captured = capsys.readouterr()
    error = captured.err.strip()
    assert error.startswith("error:") and message in error and "\n" not in error
    assert "[1/" not in captured.out and not out.exists()


def test_cli_refuses_an_out_that_is_a_file_or_cannot_be_written(tmp_path, capsys):
    target = tmp_path / "file.txt"
    target.write_text("keep")
    for out, message in ((target, "is a file, not a folder"), (target / "sub", "cannot be written")):
        with pytest.raises(SystemExit) as exit_info:
            main(["demo", "--out", str(out)])
        captured = capsys.readouterr()
        assert exit_info.value.code == 2 and captured.err.strip() == captured.err.strip().splitlines()[0]
        assert message in captured.err and "[1/" not in captured.out
    assert target.read_text() == "keep"


def _recomputed_rows(trials: pd.DataFrame) -> dict:
    """The Fig. 8 section's row per mode, recomputed from trials.csv."""
    rows = {}
    for mode, group in trials.groupby("mode"):
        encountered, avoided = int(group["obstacles_encountered"].sum()), int(group["obstacles_avoided"].sum())
        if encountered:
            low, high = wilson_interval(avoided, encountered)
            success = f"{100 * avoided / encountered:.1f} [{100 * low:.1f}, {100 * high:.1f}]"
        else:
            success = "- (no obstacle met)"
        means = group[group["reached_goal"]].groupby("participant")["completion_time_s"].mean()
        time_s = "-" if means.empty else f"{means.mean():.1f}" + ("" if len(means) < 2 else f" ± {means.std():.1f}")
        reached = int(group["reached_goal"].sum())
        low, high = wilson_interval(reached, len(group))
        rows[mode] = (
            f"| {mode} | {len(group)} | {avoided} / {encountered} | {success} |",
            f"| {reached} of {len(group)} ({100 * reached / len(group):.0f} % [{100 * low:.0f}, "
            f"{100 * high:.0f}]) | {time_s} |",
        )
    return rows


@pytest.mark.slow
@pytest.mark.xdist_group("demo_run")  # one worker runs the module's demo once for both
def test_demo_writes_tables_figures_and_a_report_beside_the_paper(demo_run):
    """The demo's run (``demo_run``): one line per stage on a stdout that is not a
    terminal; the report's numbers are the written files' (Fig. 8: recomputed from
    trials.csv)."""
    out, printed = demo_run
    stages = [line for line in printed.splitlines() if line.startswith("[")]
    assert [line[:5] for line in stages] == ["[1/5]", "[2/5]", "[3/5]", "[4/5]", "[5/5]"]
    assert "the other tasks (sort-cells)" in stages[4] and "4 paired episodes each" in stages[4]
    assert "planning" in stages[0] and "2 simulated participants" in stages[1] and "in the background" in stages[1]
    assert "3 modes in one batch, trials cut at 30 s" in stages[1]
    assert (
        f"{EPISODES} episodes each" in stages[2]
        and "1 scenario, the learned speed beside the route follower at 5 um/s" in stages[3]
    )
    for name in (
        "report.md",
        "summary.json",
        "plan/metrics.md",
        "plan/paths.png",
        "speed_control/table.csv",
        "speed_control/safety.png",
        "speed_control/safety.json",
        "whole_path/whole_path.png",
        "whole_path/trials.csv",
        "whole_path/cells.csv",
        "shared_control/trials.csv",
        "shared_control/summary.csv",
        "shared_control/summary.md",
        "shared_control/stats.json",
        "shared_control/fig8.png",
        "shared_control/acceptance.json",
        "tasks/sort-cells/results.json",
        "tasks/sort-cells/summary.md",
    ):
        assert (out / name).is_file(), name
    summary = json.loads((out / "summary.json").read_text())
    rows = {row["policy"]: row for row in summary["table_ii"]}
    assert rows["RL"]["success_rate"] == rows["G1"]["success_rate"] == 1.0
    assert rows["RL"]["ATCT_s"] == pytest.approx(rows["G1"]["ATCT_s"], abs=1e-4)
    report = (out / "report.md").read_text()
    assert f"| RL | learned | {rows['RL']['ASR']:.3f} | {rows['RL']['ATCT_s']:.2f} |" in report
    assert "| 1.000 | 38.92 |" in report  # the paper's RL row beside ours
    # the policy drives at G1, so it is never first against any constant speed as safe as it
    assert "The fastest constant speed at least as safe is G" in report and "RL is not significantly faster" in report
    assert f"the same {EPISODES} seeded episodes" in report and "--episodes 256" in report
    follower, learned = summary["whole_path"]["modes"]
    assert learned["reached_goal"] == 1
    goals = f"{follower['reached_goal']} of 1 ["
    assert "| learned speed | 1 | 1 of 1 [" in report and f"| route follower at 5 um/s | 1 | {goals}" in report
    assert "seeded scenario 10000" not in report and "scenario 15000 (seed 1" in report
    assert "whole path past the moving obstacles" in printed
    assert "learned speed reached the goal in 1 of 1 runs" in printed
    assert summary["rl_asr"] == rows["RL"]["ASR"]
    (task,) = summary["tasks"]
    written = json.loads((out / "tasks" / "sort-cells" / "results.json").read_text())["comparison"]
    assert (task["learned_successes"], task["baseline_successes"]) == (
        written["learned_successes"],
        written["baseline_successes"],
    )
    line = f"sort-cells (robots): the learned policy succeeded in {task['learned_successes']} of 4 episodes"
    assert line in printed and line in report and "The other tasks" in report

    trials = pd.read_csv(out / "shared_control" / "trials.csv")
    assert len(trials) == 6 and set(trials["mode"]) == {"manual", "autonomous", "shared"}
    # each participant on a scenario of their own (seed 1: 10000 and 10001), every mode on the same ones
    assert trials.groupby("participant")["scenario"].unique().map(list).to_dict() == {0: [10000], 1: [10001]}
    met = trials.groupby("mode")["obstacles_encountered"].sum()
    # the route follower reaches the crossings about 20 s in: both autonomous trials meet obstacles by 30 s, and
    # so does shared control, which follows the route at the same pace until an obstacle comes near
    assert (trials.loc[trials["mode"] != "manual", "obstacles_encountered"] > 0).all(), trials
    section = report[report.index("## Shared control") :]
    assert "2 simulated participants x 1 trial = 2 trials per mode" in section and "cut at 30 s" in section
    assert "scenarios 10000-10001" in section and "one batch" in section
    assert "Success ordering here:" in section
    for mode in ("autonomous", "shared"):
        line = next(line for line in printed.splitlines() if line.startswith(f"  {mode}: obstacles avoided"))
        assert f"of {met[mode]} (" in line and "(paper: " in line, line
    assert "small study" in section and "otgym experiment shared-control" in section
    for mode, (start, goal) in _recomputed_rows(trials).items():
        line = next(line for line in section.splitlines() if line.startswith(f"| {mode} |"))
        assert line.startswith(start) and goal in line, (line, start, goal)
    assert summary["shared_control"]["size"]["participants"] == 2
    assert [row["mode"] for row in summary["shared_control"]["modes"]] == ["manual", "autonomous", "shared"]


@pytest.mark.slow
def test_a_failing_stage_stops_the_background_study_and_is_the_error_reported(tmp_path, monkeypatch):
    """The study thread (here a stand-in that reports until told to stop) is stopped at
    its next report when the speed-control stage fails, and the demo raises that
    stage's error, not the study's."""
    import otgym.experiments.speed_control.evaluate as evaluation

    ended, reporting = [], threading.Event()

    def endless_study(study, seed, out_dir, detail):
        try:
            while True:
                detail("working")
                reporting.set()
                time.sleep(0.01)  # a stand-in's pace, not a wait for anything
        except BaseException as error:
            ended.append(type(error).__name__)
            raise

    def broken_evaluation(*args, **kwargs):
        assert reporting.wait(120.0), "the study never reported"  # the study is running
        raise RuntimeError("broken evaluation")

    monkeypatch.setattr(demo_module, "run_study", endless_study)
    monkeypatch.setattr(evaluation, "evaluate", broken_evaluation)
    config = demo_config_module.demo_config(episodes=EPISODES, study_participants=2)
    with pytest.raises(RuntimeError, match="broken evaluation"):
        demo_module.run_demo(config, tmp_path / "out")
    assert ended == ["_Cancelled"]


def test_pretrained_policy_ships_and_fits_the_paper_preset():
    q_params, meta = load_policy(PRETRAINED_POLICY, tr.OBS_SIZE, 6)
    assert meta["preset"] == "paper" and meta["env_steps"] > 0


def test_demo_rejects_a_policy_of_the_wrong_shape(tmp_path, capsys, fixed_action_q_params):
    policy = save_policy(
        tmp_path / "wide.npz", fixed_action_q_params(0, n_actions=10), {"preset": "paper", "hidden": list(HIDDEN)}
    )
    with pytest.raises(SystemExit):
        main(["demo", "--out", str(tmp_path / "out"), "--policy", str(policy)])
    assert "does not fit" in capsys.readouterr().err and not (tmp_path / "out").exists()


def test_demo_names_a_folder_given_as_policy(tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["demo", "--out", str(tmp_path / "out"), "--policy", str(tmp_path)])
    assert exit_info.value.code == 2 and "is a folder" in capsys.readouterr().err
