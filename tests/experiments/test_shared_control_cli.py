"""``otgym experiment shared-control`` end to end from the command line, small: 2
participants x 1 trial x 3 modes, trials cut at 6 s of simulated time."""

import json
import subprocess
import sys

import pandas as pd
import pytest

from otgym.experiments.shared_control import TRIAL_COLUMNS, parse_modes

COMMAND = [sys.executable, "-c", "from otgym.cli.app import main; main()", "experiment", "shared-control"]


def test_small_experiment_writes_every_file(tmp_path):
    """Fails if a file is missing, a trial is lost or a column renamed, if modes do not
    share their scenarios, or if the autonomy does not move off the start in 6 s
    (it grips in under 0.1 s and carries at 5 um/s: a cell near the start at 6 s means
    the navigator or the task's stepping is broken)."""
    out = tmp_path / "fig8"
    run = subprocess.run(COMMAND + ["--participants", "2", "--trials", "1", "--time-limit-s", "6", "--out", str(out)],
                         capture_output=True, text=True, timeout=900)
    assert run.returncode == 0, run.stderr
    for name in ("trials.csv", "summary.csv", "summary.md", "stats.json", "fig8.png", "acceptance.json"):
        assert (out / name).stat().st_size > 0, name
    trials = pd.read_csv(out / "trials.csv")
    assert list(trials.columns[:len(TRIAL_COLUMNS)]) == TRIAL_COLUMNS
    assert len(trials) == 6 and set(trials["mode"]) == {"manual", "autonomous", "shared"}
    assert trials.groupby("mode")["scenario"].apply(tuple).nunique() == 1
    assert (abs(trials["completion_time_s"] - 6.0) < 0.02).all() and not trials["reached_goal"].any()
    assert (trials["grip_time_s"][trials["mode"] == "autonomous"] < 0.5).all()
    json.loads((out / "stats.json").read_text())
    assert "% of trials done" in run.stdout


@pytest.mark.parametrize("args, message", [
    (["--participants", "1"], "at least 2"),
    (["--modes", "manual,bogus"], "bogus"),
    (["--trials", "0"], "at least 1"),
    (["--seed", "-1"], "seed"),
    (["--time-limit-s", "0"], "time-limit"),
])
def test_bad_input_is_one_line_and_writes_nothing(tmp_path, args, message):
    out = tmp_path / "never"
    run = subprocess.run(COMMAND + args + ["--out", str(out)], capture_output=True, text=True, timeout=120)
    assert run.returncode == 2 and message in run.stderr and "Traceback" not in run.stderr
    assert not out.exists()


def test_out_that_is_a_file_is_refused(tmp_path):
    target = tmp_path / "file.txt"
    target.write_text("x")
    run = subprocess.run(COMMAND + ["--out", str(target)], capture_output=True, text=True, timeout=120)
    assert run.returncode == 2 and "is a file" in run.stderr


def test_parse_modes():
    assert parse_modes("shared, manual") == ["shared", "manual"]
    with pytest.raises(ValueError, match="twice"):
        parse_modes("manual,manual")
