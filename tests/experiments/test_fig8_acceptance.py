"""The acceptance checks of the shared-control experiment (``otgym.experiments.
shared_control.acceptance``, written to acceptance.json): the paper's Fig. 8 ordering of
the modes and issue 13's criteria on the MPC, each judged on a trials table built by
hand. A table that satisfies every item passes every item; a table changed to violate
one item fails that item and only that one; an item whose modes did not run is absent,
not passed."""

from __future__ import annotations

import json

import pandas as pd
import pytest

from otgym.experiments.shared_control import MPC_ACCEPTANCE_RATE, acceptance, write_experiment
from otgym.study.summary import summarize

PARTICIPANTS = 2
TRIALS = 2
BASE = {  # mode: (completion time s, obstacles avoided of 10) in every trial
    "manual": (150.0, 8),
    "autonomous": (52.0, 6),
    "shared": (50.0, 10),
    "mpc": (45.0, 10),
}
"""Every item holds with room: shared avoids all (1.0 >= 0.99 and >= manual's 0.8),
manual takes 3x shared's time (>= 2x), autonomous avoids 0.6 (<= 1.0 - 0.1) in 52 s
(shared's 50 s within 15 % of it), the MPC avoids all, reaches every goal, loses no
trap and takes 45 s (<= shared's 50 s)."""

ITEMS = (
    f"mpc obstacles avoided >= {MPC_ACCEPTANCE_RATE}",
    f"mpc goal reached >= {MPC_ACCEPTANCE_RATE}",
    "mpc no trap loss",
    "mpc time <= shared time",
    "shared success >= 0.99",
    "shared success >= manual's",
    "manual time >= 2x shared time",
    "autonomous success below shared's by 0.1",
    "shared time within 15 % of autonomous",
)


def trials_table(modes=tuple(BASE)) -> pd.DataFrame:
    """Every participant's ``TRIALS`` trials in each of ``modes``, at ``BASE``'s values,
    10 obstacles met per trial, every goal reached, no trap lost."""
    rows = []
    for mode in modes:
        time_s, avoided = BASE[mode]
        for participant in range(PARTICIPANTS):
            for trial in range(TRIALS):
                rows.append(
                    {
                        "participant": participant,
                        "mode": mode,
                        "trial": trial,
                        "scenario": trial,
                        "completion_time_s": time_s,
                        "obstacles_encountered": 10,
                        "obstacles_avoided": avoided,
                        "success": avoided / 10,
                        "reached_goal": True,
                        "trap_losses": 0,
                        "detached": False,
                    }
                )
    return pd.DataFrame(rows)


def change(table: pd.DataFrame, mode: str, first_only: bool = False, **values) -> pd.DataFrame:
    """``table`` with ``values`` set in every trial of ``mode`` (or only its first row)."""
    table = table.copy()
    rows = table.index[table["mode"] == mode]
    for column, value in values.items():
        table.loc[rows[:1] if first_only else rows, column] = value
    return table


def checks_of(table: pd.DataFrame) -> dict:
    return acceptance(summarize(table))


VIOLATIONS = {
    # one MPC trial avoids 9 of its 10: 39 / 40 = 0.975 pooled
    f"mpc obstacles avoided >= {MPC_ACCEPTANCE_RATE}": lambda t: change(t, "mpc", True, obstacles_avoided=9),
    # one MPC trial misses the goal: 3 / 4 (its time leaves the mean, still 45 s)
    f"mpc goal reached >= {MPC_ACCEPTANCE_RATE}": lambda t: change(t, "mpc", True, reached_goal=False),
    # one MPC trial loses a trap (and still reaches the goal: only this item may fail)
    "mpc no trap loss": lambda t: change(t, "mpc", True, trap_losses=1),
    # the MPC slower than shared control (55 s against 50 s)
    "mpc time <= shared time": lambda t: change(t, "mpc", completion_time_s=55.0),
    # one shared trial avoids 9 of 10: participant 0 at 0.95, the mean 0.975 (still above manual's 0.8)
    "shared success >= 0.99": lambda t: change(t, "shared", True, obstacles_avoided=9),
    # one shared trial meets 100 and avoids 99: participant 0 at 109 / 110, the mean 0.995 (>= 0.99)
    # but below manual's, here all avoided
    "shared success >= manual's": lambda t: change(
        change(t, "shared", True, obstacles_encountered=100, obstacles_avoided=99), "manual", obstacles_avoided=10
    ),
    # manual 90 s, under 2 x 50 s
    "manual time >= 2x shared time": lambda t: change(t, "manual", completion_time_s=90.0),
    # autonomous avoids all, as shared control does: not 0.1 below it
    "autonomous success below shared's by 0.1": lambda t: change(t, "autonomous", obstacles_avoided=10),
    # autonomous 70 s: shared's 50 s is 29 % faster
    "shared time within 15 % of autonomous": lambda t: change(t, "autonomous", completion_time_s=70.0),
}


def test_a_table_that_satisfies_every_item_passes_every_item():
    checks = checks_of(trials_table())
    assert set(checks) == set(ITEMS)
    assert all(checks.values()), checks


@pytest.mark.parametrize("item", list(VIOLATIONS))
def test_a_table_that_violates_one_item_fails_that_item_and_only_that_one(item):
    """Catches a check that reads the wrong mode or column, compares the wrong way, uses
    another threshold, or is missing (each violation also leaves every other item held)."""
    checks = checks_of(VIOLATIONS[item](trials_table()))
    assert set(checks) == set(ITEMS)
    assert [name for name, passed in checks.items() if not passed] == [item], checks


def test_shared_time_must_lie_within_15_percent_of_the_autonomys_on_both_sides():
    """Shared control's 50 s against the autonomy's: 40 s (shared 25 % slower) fails as
    70 s does; 47.6 s and 52.5 s (5 % off either way) pass. The 15 % are of the autonomy's
    time: 58 s (8 s off, within 8.7 s) passes and 43 s (7 s off, beyond 6.45 s) fails,
    where 15 % of shared's 50 s (7.5 s) would judge both the other way."""
    for autonomous_s, passes in ((40.0, False), (47.6, True), (52.5, True), (58.0, True), (43.0, False)):
        checks = checks_of(change(trials_table(), "autonomous", completion_time_s=autonomous_s))
        assert checks["shared time within 15 % of autonomous"] is passes, autonomous_s
        assert all(passed for name, passed in checks.items() if name != "shared time within 15 % of autonomous")


@pytest.mark.parametrize(
    "modes, items",
    [
        (("manual", "autonomous", "shared"), ITEMS[4:]),
        (("manual", "shared"), ITEMS[4:7]),
        (("autonomous", "shared"), (ITEMS[4],) + ITEMS[7:]),
        (("shared", "mpc"), ITEMS[:5]),
        (("mpc",), ITEMS[:3]),
        (("manual", "autonomous"), ()),
    ],
)
def test_only_the_items_of_the_modes_that_ran_are_checked(modes, items):
    """An item whose modes did not run is left out (absent, not passed)."""
    checks = checks_of(trials_table(modes))
    assert set(checks) == set(items) and all(checks.values())


def test_acceptance_json_holds_the_checks_of_the_written_summary(tmp_path):
    """``write_experiment`` judges the summary.csv it wrote (read back from the file) and
    writes the same verdicts to acceptance.json, beside the MPC's evidence."""
    table = VIOLATIONS["manual time >= 2x shared time"](trials_table())
    checks = write_experiment(table, tmp_path)
    written = json.loads((tmp_path / "acceptance.json").read_text())
    assert checks == checks_of(table)
    assert {name: written[name] for name in ITEMS} == checks and set(written) == set(ITEMS) | {"mpc"}
    assert written["mpc"]["trials"] == PARTICIPANTS * TRIALS and written["mpc"]["goals_reached"] == 4
