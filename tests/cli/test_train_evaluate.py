"""``otgym train`` and ``otgym evaluate`` from the command line: the files they write,
and bad input as one clear line."""

import json

import numpy as np
import pytest

from otgym.rl.policy import load_policy, save_policy
from otgym.tasks.transport import core as tr
from otgym.tasks.transport.presets import preset
from tests.conftest import FIXED_POLICY_HIDDEN
from tests.experiments.test_speed_control_eval import EPISODES
from tests.otgym_cli import run_cli
from tests.rl.canonical import TRAIN_ARGS, TRAIN_STEPS


@pytest.mark.slow
def test_train_writes_a_loadable_policy_curve_and_summary(tmp_path, capsys):
    """The tests' canonical training (``tests.rl.canonical``: 64 environments x 200
    iterations, 12800 steps, compiled once for all tests that train): short, but episodes
    end (a random speed finishes a 15 um segment in at most 278 steps) and the learning
    curve has them."""
    assert run_cli(["train", "--out", str(tmp_path), *TRAIN_ARGS, "--seed", "3"]) == 0
    summary = json.loads((tmp_path / "training.json").read_text())
    assert summary["env_steps"] == TRAIN_STEPS and summary["episodes"] > 0 and summary["preset"] == "paper"
    q_params, meta = load_policy(tmp_path / "policy.npz", tr.OBS_SIZE, 6)
    assert meta["seed"] == 3 and all(np.all(np.isfinite(np.asarray(v))) for v in q_params["params"]["Dense_0"].values())
    # the task's own policy_meta: evaluating the file needs the speed levels it was trained on
    assert meta["speed_levels_um_s"] == list(preset("paper").speed_levels_um_s) and meta["preset"] == "paper"
    assert (tmp_path / "learning_curve.png").stat().st_size > 10_000
    assert f"{TRAIN_STEPS} steps" in capsys.readouterr().out


@pytest.mark.slow
def test_evaluate_writes_table_ii_and_safety(tmp_path, fixed_action_q_params, capsys):
    policy = save_policy(
        tmp_path / "slow.npz", fixed_action_q_params(0), {"preset": "paper", "hidden": list(FIXED_POLICY_HIDDEN)}
    )
    assert (
        run_cli(
            [
                "evaluate",
                "--policy",
                str(policy),
                "--episodes",
                str(EPISODES),
                "--seed",
                "3",
                "--out",
                str(tmp_path / "eval"),
            ]
        )
        == 0
    )
    # seed 3 is a development seed (the evaluation's tests): said in the output and the report files
    assert "development seed" in capsys.readouterr().out
    assert (tmp_path / "eval" / "table.md").read_text().startswith("**development seed")
    lines = (tmp_path / "eval" / "table.csv").read_text().splitlines()
    assert len(lines) == 8
    rl, g1 = lines[1].split(","), lines[2].split(",")
    assert rl[0] == "RL" and g1[0] == "G1" and rl[3] == g1[3]  # same ATCT: the policy always drives at G1
    safety = json.loads((tmp_path / "eval" / "safety.json").read_text())
    # contact forces in the paper preset stay below 0.5 pN (docs/images/speed_control_safety.png)
    assert set(safety) == {"RL", "untrained"} and safety["RL"]["force_below_limit"] == 1.0
    assert (tmp_path / "eval" / "safety.png").is_file()
    # a policy that always drives at the slowest speed is never first against an as-safe constant speed
    checks = json.loads((tmp_path / "eval" / "acceptance.json").read_text())
    assert checks["reference"] in {"G1", "G2", "G3", "G4", "G5", "G6"} and checks["faster_episodes"] == 0
    assert not checks["beats_reference"] and not checks["passes"]
    assert checks["seed_status"] == "development seed" and "seed 3" in checks["development_note"]


@pytest.mark.parametrize(
    "arguments, message",
    [
        (["evaluate", "--policy", "nowhere.npz"], "does not exist"),
        (["evaluate", "--policy", "."], ". is a folder; give a policy file"),
        (["evaluate", "--policy", "pretrained", "--episodes", "0"], "--episodes"),
        (["evaluate", "--policy", "pretrained", "--repeats", "0"], "--repeats"),
        (["train", "--preset", "fast"], "--preset must be one of paper, realistic, not 'fast'"),
        (["train", "--task", "juggle"], "--task"),
        (["train", "--task", "cell-transport", "--steps", "64"], "DQN needs a discrete action space"),
        (["train", "--steps", "0"], "--steps must lie in [1, "),
    ],
)
def test_bad_input_is_one_line(tmp_path, capsys, arguments, message):
    assert run_cli([*arguments, "--out", str(tmp_path)]) == 2
    error = capsys.readouterr().err.strip()
    assert error.startswith("error:") and message in error and "\n" not in error


@pytest.mark.parametrize("command", [["train"], ["evaluate", "--policy", "pretrained"]])
def test_an_out_that_is_a_file_is_refused_before_any_work(tmp_path, capsys, command):
    target = tmp_path / "taken"
    target.write_text("not a folder")
    assert run_cli([*command, "--out", str(target)]) == 2
    error = capsys.readouterr().err.strip()
    assert error == f"error: --out {target} is a file, not a folder"
    assert target.read_text() == "not a folder"
