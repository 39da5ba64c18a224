"""The reward-term table: which fraction of steps each term binds in, and its share."""

import numpy as np
import pytest

from otgym.experiments.speed_control.reward_terms import markdown, summarize
from tests.otgym_cli import run_cli


def test_summary_counts_binding_steps_and_shares():
    samples = {
        "RL": {"time": np.full(4, -0.05), "failure": np.array([0.0, 0.0, 0.0, -100.0])},
        "random": {"time": np.full(2, -0.05), "failure": np.zeros(2)},
    }
    rows = {(row["policy"], row["term"]): row for row in summarize(samples)}
    assert rows["RL", "failure"]["binds"] == 0.25 and rows["RL", "time"]["binds"] == 1.0
    assert rows["random", "failure"]["binds"] == 0.0 and rows["random", "failure"]["max"] == 0.0
    assert rows["RL", "failure"]["share_of_abs_reward"] == pytest.approx(100 / 100.2)
    assert rows["RL", "time"]["mean"] == pytest.approx(-0.05) and rows["RL", "time"]["steps"] == 4
    assert "| RL | failure | 4 | 0.2500 |" in "\n".join(markdown(list(rows.values())))


@pytest.mark.parametrize(
    "arguments, message",
    [
        (["--episodes", "0"], "--episodes must lie in [1, 4096], not 0"),
        (["--seed", "-1"], "--seed must lie in [0, 4294967295], not -1"),
        (["--policy", "nowhere.npz"], "nowhere.npz does not exist"),
    ],
)
def test_bad_input_is_one_line_before_any_work(tmp_path, capsys, arguments, message):
    assert run_cli(["experiment", "reward-terms", *arguments, "--out", str(tmp_path / "out")]) == 2
    error = capsys.readouterr().err.strip()
    assert error.startswith("error:") and message in error and "\n" not in error
    assert not (tmp_path / "out").exists()


def test_an_out_that_is_a_file_is_refused(tmp_path, capsys):
    target = tmp_path / "taken"
    target.write_text("x")
    assert run_cli(["experiment", "reward-terms", "--out", str(target)]) == 2
    assert "is a file, not a folder" in capsys.readouterr().err
