"""``otgym experiment speed-front`` end to end at a tiny size: two penalties x one
training seed of the tests' canonical training length (``tests.rl.canonical``: two chunks
of 64 environments; the member at penalty 100 is that very training, compiled once for
all tests that train), four episodes; and its bad input."""

from __future__ import annotations

import csv
import json

import pytest

from tests.otgym_cli import run_otgym
from tests.rl.canonical import TRAIN_STEPS

COMMAND = ["experiment", "speed-front"]


@pytest.mark.slow
def test_tiny_front_writes_its_files_and_flags_a_development_seed(tmp_path):
    """Fails if a file or row is missing, if the family is not 2 rewards x 1 seed, if the
    constant speeds do not keep their order of completion times, if a rate lies outside
    its interval, or if the development seed goes unflagged."""
    out = tmp_path / "front"
    run = run_otgym(
        COMMAND
        + ["--penalties", "100,1000", "--seeds", "1", "--steps", str(TRAIN_STEPS), "--episodes", "4", "--seed", "5001"]
        + ["--out", str(out)]
    )
    assert run.returncode == 0, run.stderr[-3000:]
    for name in ("front.csv", "front_tests.csv", "front.md", "front.json", "front.png"):
        assert (out / name).stat().st_size > 0, name
    rows = list(csv.DictReader(open(out / "front.csv")))
    names = [row["name"] for row in rows]
    assert names[:7] == ["G1", "G2", "G3", "G4", "G5", "G6", "pretrained"]
    assert sorted(names[7:]) == sorted(["penalty 1000, time 0.05 #1", "penalty 100, time 0.05 #1"])
    assert all(row["episodes"] == "4" for row in rows)
    for row in rows:
        rate, low, high = (float(row[k]) for k in ("success_rate", "success_ci95_low", "success_ci95_high"))
        assert low <= rate <= high
    times = [float(row["ATCT_s"]) for row in rows[:6] if row["ATCT_s"]]
    assert times == sorted(times, reverse=True)  # faster constant speeds finish sooner
    tests = list(csv.DictReader(open(out / "front_tests.csv")))
    assert len(tests) == 3 * 6  # pretrained and 2 members against 6 constant speeds
    report = json.loads((out / "front.json").read_text())
    assert report["seed_status"] == "development seed" and report["evaluation_seeds"] == [5001]
    assert len(report["training_seeds"]) == 1 and report["episodes"] == 4
    assert (out / "front.md").read_text().startswith("# Speed-control front")
    assert "development seed" in (out / "front.md").read_text() and "development seed" in run.stdout
    assert "train: 2/2 done" in run.stdout


@pytest.mark.parametrize(
    "args, message",
    [
        (["--penalties", "100,100"], "--penalties"),
        (["--time-costs", "0.05,-1"], "--time-costs"),
        (["--seed", str(2**32 - 2), "--episodes", "1024"], "--seed"),
    ],
)
def test_bad_input_is_one_line_and_writes_nothing(tmp_path, args, message):
    """What a single option's range cannot say: a repeated penalty, a negative time cost
    in a list, a seed whose evaluation batches would pass 2**32 - 1."""
    out = tmp_path / "never"
    run = run_otgym(COMMAND + args + ["--out", str(out)])
    assert run.returncode == 2 and message in run.stderr and "Traceback" not in run.stderr, run.stderr
    assert len(run.stderr.strip().splitlines()) == 1 and not out.exists()
