"""``otgym experiment route-bound`` from the command line: two scenarios of the
shared-control study, two speed limits; bad input ends in one line and exit 2."""

import json

import pandas as pd
import pytest

from tests.otgym_cli import run_otgym

COMMAND = ["experiment", "route-bound"]
GRID_S = 2 * 0.25 / 5.0  # two arc steps of 0.25 um at the slower limit


@pytest.mark.slow
def test_route_bound_writes_its_files_and_a_faster_limit_never_arrives_later(tmp_path):
    """Fails if a file or row is missing, if the unobstructed time is not the route's
    length to the goal tolerance over the speed (the autonomous mode's 60.7 s at
    5 um/s), if an arrival beats it, or if allowing 8 um/s makes any arrival later
    (every 5 um/s passage is also an 8 um/s one)."""
    out = tmp_path / "bound"
    run = run_otgym(COMMAND + ["--seed", "10", "--trials", "2", "--speeds-um-s", "5,8", "--out", str(out)])
    assert run.returncode == 0, run.stderr
    rows = pd.read_csv(out / "route_bound.csv")
    assert sorted(rows.scenario.unique()) == [100000, 100001] and len(rows) == 4
    slow, fast = (rows[rows.max_speed_um_s == v].set_index("scenario") for v in (5.0, 8.0))
    assert slow.free_s.iloc[0] == pytest.approx(60.7, abs=0.1)
    assert fast.free_s.iloc[0] == pytest.approx(slow.free_s.iloc[0] * 5 / 8)
    assert (rows.earliest_s >= rows.free_s - 1e-6).all()
    assert (fast.earliest_s <= slow.earliest_s + GRID_S).all()
    summary = json.loads((out / "route_bound.json").read_text())
    assert summary["5"]["scenarios"] == 2
    assert "scenario 100001" in run.stdout and "earliest" in (out / "route_bound.md").read_text()
    assert "development seed: seed 10" in run.stdout  # seed 10 is Fig. 8's: not held out


def test_bad_speeds_are_one_line_and_exit_2(tmp_path):
    run = run_otgym(COMMAND + ["--speeds-um-s", "5,fast", "--out", str(tmp_path / "x")])
    assert run.returncode == 2 and "(0, 20]" in run.stderr and "Traceback" not in run.stderr
    assert not (tmp_path / "x").exists()
