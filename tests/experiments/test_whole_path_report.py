"""The whole-path section's counts and text on chosen trial rows (no simulation): goals
reached with their Wilson interval, goals reached untouched counted apart (an
obstacle's touch does not end a trial), obstacles avoided of those met, the scenarios
and seed named; and the demo's run sizes checked."""

import pytest

from otgym.experiments.demo.report import whole_path_section
from otgym.experiments.demo.whole_path import RECOMMENDED_AUTONOMY, WholePathDemo, summarize
from tests.experiments.test_demo_report import wilson


def trial(mode: str, reached: bool, met: int, avoided: int, time_s: float, trap_losses: int = 0) -> dict:
    return {
        "mode": mode,
        "reached_goal": reached,
        "obstacles_encountered": met,
        "obstacles_avoided": avoided,
        "collisions": met - avoided,
        "trap_losses": trap_losses,
        "detachments": 0,
        "completion_time_s": time_s,
    }


def test_goals_untouched_are_counted_apart_and_the_section_names_its_sample():
    demo = WholePathDemo(runs=3, seed=2, autonomy="mpc")
    rows = [
        trial("autonomous", True, 3, 1, 60.72),  # reached the goal, but touched twice
        trial("autonomous", True, 2, 2, 60.74),
        trial("autonomous", False, 1, 0, 12.0, trap_losses=1),
        trial("mpc", True, 4, 4, 45.04),
        trial("mpc", True, 3, 2, 50.0),
        trial("mpc", False, 2, 2, 150.0),  # cut at the time limit
    ]
    summary = summarize(demo, rows, 307.04)
    follower, mpc = summary["modes"]
    assert (follower["mode"], mpc["mode"]) == ("autonomous", "mpc") and RECOMMENDED_AUTONOMY == "rl"
    assert (follower["reached_goal"], follower["reached_goal_clean"], follower["collisions"]) == (2, 1, 3)
    assert (mpc["reached_goal"], mpc["reached_goal_clean"], mpc["obstacles_avoided"]) == (2, 1, 8)
    assert mpc["completion_times_s"] == [45.04, 50.0] and follower["trap_losses"] == 1
    assert summary["scenarios"] == [25000, 25001, 25002]

    text = "\n".join(whole_path_section(summary))
    low, high = wilson(2, 3)
    assert (
        f"| route follower at 5 um/s | 3 | 2 of 3 [{100 * low:.0f}, {100 * high:.0f} %] | 1 of 3 | 3 / 6 | 3 | 1 |"
        in text
    )
    assert f"| MPC | 3 | 2 of 3 [{100 * low:.0f}, {100 * high:.0f} %] | 1 of 3 | 8 / 9 | 1 | 0 | 45.0, 50.0 |" in text
    assert "scenarios 25000-25002 (seed 2" in text and "307 um of route" in text and "cut at 150 s" in text


def test_a_single_run_names_its_scenario_and_no_goal_shows_a_dash():
    demo = WholePathDemo(runs=1, seed=1, speed_um_s=4.0, autonomy="mpc")
    summary = summarize(demo, [trial("autonomous", False, 1, 0, 150.0), trial("mpc", False, 0, 0, 150.0)], 300.0)
    text = "\n".join(whole_path_section(summary))
    assert "1 seeded scenario 15000 (seed 1" in text and "at a constant 4 um/s" in text
    assert f"| MPC | 1 | 0 of 1 [0, {100 * wilson(0, 1)[1]:.0f} %] | 0 of 1 | 0 / 0 | 0 | 0 | - |" in text


@pytest.mark.parametrize(
    "options, message",
    [
        ({"runs": 0}, "runs must be a positive integer"),
        ({"runs": True}, "runs must be a positive integer"),
        ({"speed_um_s": float("nan")}, "speed_um_s must be a positive number"),
        ({"time_limit_s": 0.0}, "time_limit_s must be a positive number"),
    ],
)
def test_bad_sizes_are_refused(options, message):
    with pytest.raises(ValueError, match=message):
        WholePathDemo(**options)
