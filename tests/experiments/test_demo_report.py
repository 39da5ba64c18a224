"""The demo's report sections and its size checks, on chosen numbers: the Fig. 8 section
quotes pooled success with Wilson intervals (recomputed here from the formula), the
participants' mean completion time and the paper's values, and says what the numbers
say; the Table II section names its sample size; bad sizes are refused with their
range. No simulation runs here."""

import math

import numpy as np
import pandas as pd
import pytest

from otgym.experiments.common.output_folder import check_out_dir
from otgym.experiments.demo.config import DemoConfig, StudyConfig, demo_config, stage_names
from otgym.experiments.demo.report import shared_control_section, speed_control_section
from otgym.experiments.demo.run import read_summary
from otgym.study import summarize
from tests.study import make_trials

Z95 = 1.959963984540054


def wilson(successes: int, n: int) -> tuple[float, float]:
    """The Wilson score interval from its formula (Wilson 1927), independent of statsmodels."""
    p = successes / n
    centre = (p + Z95**2 / (2 * n)) / (1 + Z95**2 / n)
    half = Z95 / (1 + Z95**2 / n) * math.sqrt(p * (1 - p) / n + Z95**2 / (4 * n**2))
    return centre - half, centre + half


def cell(avoided: int, encountered: int) -> str:
    low, high = wilson(avoided, encountered)
    return f"{100 * avoided / encountered:.1f} [{100 * low:.1f}, {100 * high:.1f}]"


def goals(reached: int, trials: int) -> str:
    """The goal column: trials, rate and its Wilson interval in whole percent."""
    low, high = wilson(reached, trials)
    return f"{reached} of {trials} ({100 * reached / trials:.0f} % [{100 * low:.0f}, {100 * high:.0f}])"


def section_for(trials: pd.DataFrame, tmp_path, limit_s: float = 200.0, **design) -> list[str]:
    """The section as the demo makes it: summary.csv written, read back, formatted;
    ``design``: the size's optional entries (scenario_per_participant, one_batch,
    encounter_gap_um)."""
    summarize(trials).to_csv(tmp_path / "summary.csv", index=False)
    size = {
        "participants": int(trials["participant"].nunique()),
        "trials_per_mode": int(trials["trial"].nunique()),
        "time_limit_s": limit_s,
        "scenarios": sorted(trials["scenario"].unique()),
        **design,
    }
    return shared_control_section(read_summary(tmp_path / "summary.csv"), size)


def two_trials(first: dict, second: dict, avoided_first: dict, avoided_second: dict) -> pd.DataFrame:
    """3 participants x 2 trials in the shape of ``tests.study.make_trials`` (4 obstacles each)."""
    return pd.concat(
        [
            make_trials(first, avoided_first, encountered=4).assign(trial=0, scenario=10000),
            make_trials(second, avoided_second, encountered=4).assign(trial=1, scenario=10001),
        ],
        ignore_index=True,
    )


def test_fig8_section_quotes_our_numbers_with_wilson_intervals_beside_the_papers(tmp_path):
    trials = two_trials(
        {"manual": [150, 160, 155], "autonomous": [60, 61, 62], "shared": [55, 54, 58]},
        {"manual": [170, 165, 175], "autonomous": [60, 61, 62], "shared": [57, 90, 59]},
        {"manual": [4, 4, 3], "autonomous": [1, 1, 1], "shared": [4, 4, 4]},
        {"manual": [3, 4, 4], "autonomous": [1, 1, 1], "shared": [4, 4, 4]},
    )
    # participant 1's second shared trial and both of participant 2's did not reach the goal
    not_reached = (trials["mode"] == "shared") & (
        ((trials["participant"] == 1) & (trials["trial"] == 1)) | (trials["participant"] == 2)
    )
    trials.loc[not_reached, "reached_goal"] = False
    trials.loc[(trials["mode"] == "manual") & (trials["participant"] == 0), "trap_losses"] = 1
    text = "\n".join(section_for(trials, tmp_path))

    assert "3 simulated participants x 2 trials = 6 trials per mode" in text
    assert "same 2 seeded scenarios (scenarios 10000-10001)" in text and "small study" in text
    assert "otgym experiment shared-control" in text
    # manual: 22 of 24 avoided, all reached the goal, participants' means 160, 162.5, 165 -> 162.5 +- 2.5
    assert f"| manual | 6 | 22 / 24 | {cell(22, 24)} | 94 ± 4 | {goals(6, 6)} | 162.5 ± 2.5 | 163.5 ± 8.3 | 2 |" in text
    assert f"| autonomous | 6 | 6 / 24 | {cell(6, 24)} | 59 ± 5 | {goals(6, 6)} | 61.0 ± 1.0 | 54.1 ± 0.1 | 0 |" in text
    # shared: participant 0 mean 56, participant 1 only 54, participant 2 none -> 55 +- 1.4
    assert f"| shared | 6 | 24 / 24 | {cell(24, 24)} | 100 ± 0 | {goals(3, 6)} | 55.0 ± 1.4 | 53.9 ± 0.2 | 0 |" in text
    assert "Success ordering here: shared 100 % > manual 92 % > autonomous 25 %" in text
    assert "the paper's: shared 100 % > manual 94 % > autonomous 59 %" in text
    assert "Separated by their 95 % intervals: shared and autonomous, manual and autonomous." in text
    assert "Shared: of 6 trials, 3 reached the goal, 3 were still on the way at the 200 s cut;" in text
    assert "Trials of shared still running at 200 s are left out of the times" in text
    assert "trials took" not in text  # 200 s exceeds every paper mean time
    assert (
        "Completion time against the paper's: manual 162.5 s against 163.5 s (0.99 x), autonomous 61.0 s "
        "against 54.1 s (1.13 x), shared 55.0 s against 53.9 s (1.02 x)."
    ) in text


def test_fig8_section_says_what_a_short_study_cannot_show(tmp_path):
    """Trials cut at 20 s: no goal reached, manual met no obstacle, two modes tie."""
    trials = make_trials(
        {"manual": [20, 20], "autonomous": [20, 20], "shared": [20, 20]},
        {"manual": [0, 0], "autonomous": [1, 1], "shared": [1, 1]},
        encountered=1,
    )
    trials["reached_goal"] = False
    trials.loc[trials["mode"] == "manual", ["obstacles_encountered", "obstacles_avoided"]] = 0
    text = "\n".join(section_for(trials, tmp_path, limit_s=20.0))
    assert "2 simulated participants x 1 trial = 2 trials per mode" in text
    assert "same seeded scenario (scenario 0)," in text
    assert f"| manual | 2 | 0 / 0 | - (no obstacle met) | 94 ± 4 | {goals(0, 2)} | - |" in text
    assert f"| shared | 2 | 2 / 2 | {cell(2, 2)} | 100 ± 0 | {goals(0, 2)} | - |" in text
    assert "autonomous 100 % = shared 100 %" in text
    assert "every pair of modes overlap" in text and "Manual: no obstacle met before the trials ended" in text
    assert "No trial reached the goal within the 20 s limit" in text
    assert "the paper's manual trials took 163.5 s on average" in text


def test_fig8_section_of_the_demos_design_says_how_each_trial_ended(tmp_path):
    """The demo's design (3 participants, each on a scenario of their own, one batch,
    cut at 90 s): manual reached no goal, two of its trials lost a trap and one was cut;
    the others finished, and their times stand beside the paper's."""
    trials = make_trials(
        {"manual": [9, 8, 90], "autonomous": [60.7, 60.7, 60.7], "shared": [71.2, 85.5, 72.5]},
        {"manual": [0, 0, 3], "autonomous": [1, 2, 1], "shared": [4, 4, 3]},
        encountered=4,
    )
    trials["scenario"] = 10000 + trials["participant"]
    manual = trials["mode"] == "manual"
    trials.loc[manual, "reached_goal"] = False
    trials.loc[manual & (trials["participant"] < 2), ["trap_losses", "obstacles_encountered", "obstacles_avoided"]] = (
        1,
        0,
        0,
    )
    trials.loc[trials["mode"] == "autonomous", "obstacles_encountered"] = [3, 4, 4]
    text = "\n".join(
        section_for(
            trials, tmp_path, limit_s=90.0, scenario_per_participant=True, one_batch=True, encounter_gap_um=20.0
        )
    )
    assert (
        "3 simulated participants x 1 trial = 3 trials per mode, each participant on a seeded scenario of their "
        "own (scenarios 10000-10002; every mode on the same"
    ) in text
    assert "all trials simulated together in one batch, each trial cut at 90 s of simulated time" in text
    assert "not chosen by their outcome" in text and "within 20 um of the assembly" in text
    assert f"| manual | 3 | 3 / 4 | {cell(3, 4)} | 94 ± 4 | {goals(0, 3)} | - | 163.5 ± 8.3 | 2 |" in text
    assert f"| autonomous | 3 | 4 / 11 | {cell(4, 11)} | 59 ± 5 | {goals(3, 3)} | 60.7 ± 0.0 |" in text
    assert f"| shared | 3 | 11 / 12 | {cell(11, 12)} | 100 ± 0 | {goals(3, 3)} | 76.4 ± 7.9 |" in text
    assert (
        "Manual: of 3 trials, 2 ended early when a trap lost its robot, 1 was still on the way at the 90 s cut "
        "(the paper's manual trials took 163.5 s on average); its success counts only the obstacles met before "
        "the trials ended."
    ) in text
    assert (
        "Completion time against the paper's: autonomous 60.7 s against 54.1 s (1.12 x), shared 76.4 s against "
        "53.9 s (1.42 x)."
    ) in text
    assert "left out of the times" not in text  # every autonomous and shared trial finished
    assert "Success ordering here: shared 92 % > manual 75 % > autonomous 36 %" in text


def test_the_default_study_runs_long_enough_to_meet_obstacles_and_finish():
    """The obstacles cross the route 35-65 % of the way along it, which the autonomy's
    5 um/s reaches about 20 s into a trial (a 20 s cut met none); the default cut lets
    the autonomous and shared trials reach the goal (the paper's took about 54 s, ours
    61-86 s) and gives the manual ones time to meet their first obstacles."""
    from otgym.study import PAPER_FIG8
    from otgym.tasks.transport.scenario import ScenarioConfig

    limit = StudyConfig().time_limit_s
    scenario = ScenarioConfig()
    first_crossing_s = scenario.grip_time_s + 0.35 * 300.0 / scenario.cruise_speed_um_s  # a route of about 300 um
    assert limit >= 3 * first_crossing_s >= 3 * 20
    assert limit >= 1.5 * max(PAPER_FIG8[mode]["time_mean_s"] for mode in ("autonomous", "shared"))


def _speed_rows(episodes: int) -> list[dict]:
    speeds = (0.27, 0.318, 0.366, 0.414, 0.462, 0.51)
    times = (55.6, 47.2, 41.0, 36.4, 32.6, 29.6)
    success = (1.0, 1.0, 1.0, 0.9375, 0.9375, 0.6875)

    def interval(rate):
        low, high = wilson(round(rate * episodes), episodes)
        return {"success_ci95_low": low, "success_ci95_high": high}

    rows = [
        {
            "policy": "RL",
            "speed_um_s": None,
            "ASR": 1.0,
            "ATCT_s": 41.88,
            "success_rate": 1.0,
            **interval(1.0),
            "episodes": episodes,
        }
    ]
    return rows + [
        {
            "policy": f"G{i + 1}",
            "speed_um_s": s,
            "ASR": r,
            "ATCT_s": t,
            "success_rate": r,
            **interval(r),
            "episodes": episodes,
        }
        for i, (s, t, r) in enumerate(zip(speeds, times, success))
    ]


def test_table_ii_section_names_its_size_and_reads_the_rows():
    """16 episodes: G3 is quicker than RL and lost none of them; G4-G6 are quicker and lost some."""
    safety = {
        name: {
            "force_below_limit": 1.0,
            "distance_within_limit": 0.03,
            "distance_median_um": 0.33,
            "distance_p99_um": 0.46,
            "samples": 6700,
        }
        for name in ("RL", "untrained")
    }
    checks = {
        "distance_safe": False,
        "reference": "G3",
        "faster_episodes": 0,
        "slower_episodes": 16,
        "speed_p": 1.0,
        "rl_only_lost": 0,
        "reference_only_lost": 0,
        "safety_p": 1.0,
        "beats_reference": False,
    }
    text = "\n".join(speed_control_section(_speed_rows(16), safety, checks, 10.0, 0.2, "paper", full_episodes=256))
    low, high = wilson(16, 16)
    assert f"success 16 of 16 episodes (1.000, 95 % Wilson interval [{low:.3f}, {high:.3f}])" in text
    assert "the same 16 seeded episodes" in text and "`otgym evaluate --policy pretrained --episodes 256`" in text
    assert "The fastest constant speed at least as safe is G3 (success 1.000, ATCT 41.00 s)" in text
    assert "RL finished first in 0 and later in 16 (one-sided sign test p = 1): RL is not significantly faster" in text
    assert "that lost none of these 16: G3 (41.00 s, success 1.000)" in text
    assert "that lost episodes: G4 (36.40 s, success 0.938), G5 (32.60 s, success 0.938), G6" in text
    full = "\n".join(
        speed_control_section(
            _speed_rows(256), safety, dict(checks, reference=None), 10.0, 0.2, "paper", full_episodes=256
        )
    )
    assert "the same 256 seeded episodes." in full and "otgym evaluate" not in full
    assert "No constant speed was as safe as RL" in full
    assert "limit of 0.2 um was kept in 3.0% of RL's steps" in text and "median handle sat 0.330 um" in text
    assert "handle-distance limit" not in "\n".join(
        speed_control_section(_speed_rows(16), safety, dict(checks, distance_safe=True), 10.0, 0.2, "paper")
    )


@pytest.mark.parametrize(
    "options, message",
    [
        ({"episodes": 0}, "--episodes must be an integer in [1, 4096], got 0"),
        ({"episodes": 5000}, "--episodes must be an integer in [1, 4096]"),
        ({"runs": 65}, "--runs must be an integer in [1, 64], got 65"),
        ({"speed_um_s": 0.0}, "--speed-um-s must lie in [0.5, 20] um/s"),
        ({"speed_um_s": float("inf")}, "--speed-um-s must lie in [0.5, 20] um/s"),
        ({"seed": -1}, "--seed must be an integer in [0, 4294967295]"),
        ({"seed": 2**32}, "--seed must be an integer in [0, 4294967295]"),
        ({"study_participants": 1}, "--study-participants must be an integer in [2, 16], got 1"),
        ({"study_trials": 0}, "--study-trials must be an integer in [1, 8]"),
        ({"study_time_limit_s": 301.0}, "--study-time-limit-s must lie in [1, 300] s"),
        ({"study_time_limit_s": float("nan")}, "--study-time-limit-s must lie in [1, 300] s"),
    ],
)
def test_sizes_outside_their_range_are_refused_with_it(options, message):
    with pytest.raises(ValueError) as error:
        demo_config(**options)
    assert message in str(error.value)


def test_edges_of_the_ranges_are_accepted_and_zero_participants_leaves_the_study_out():
    config = demo_config(
        episodes=4096,
        runs=64,
        speed_um_s=20.0,
        seed=2**32 - 1,
        study_participants=16,
        study_trials=8,
        study_time_limit_s=300.0,
    )
    assert (config.episodes, config.whole_path.runs, config.seed, config.whole_path.seed) == (
        4096,
        64,
        2**32 - 1,
        2**32 - 1,
    )
    assert config.study == StudyConfig(16, 8, time_limit_s=300.0)
    assert demo_config(study_participants=0).study is None and len(stage_names(demo_config(study_participants=0))) == 4
    assert len(stage_names(demo_config(study_participants=0, task_episodes=0))) == 3  # nor the other tasks
    assert demo_config(task_episodes=256).task_episodes == 256 and demo_config(task_episodes=0).task_episodes == 0
    with pytest.raises(ValueError, match="distinct"):
        StudyConfig(modes=("manual", "manual"))
    with pytest.raises(ValueError, match="--episodes"):
        DemoConfig(episodes=0)


def test_out_folder_checks(tmp_path):
    target = tmp_path / "file.txt"
    target.write_text("x")
    with pytest.raises(ValueError, match="is a file, not a folder"):
        check_out_dir(target)
    with pytest.raises(ValueError, match="cannot be written"):
        check_out_dir(target / "sub")
    assert target.read_text() == "x"
    made = check_out_dir(tmp_path / "a" / "b")
    assert made.is_dir() and list(made.iterdir()) == []  # the probe file is gone


def test_the_shipped_policy_on_the_front_names_its_run_and_what_it_covers():
    """The front paragraph quotes the run (command, seed, n), the shipped policy's rate
    with its interval, and the constant speeds it covers; fails if a covered constant is
    missing, an uncovered one is listed, or a development seed passes as held out."""
    from otgym.experiments.demo.shipped_results import front_lines
    from otgym.experiments.speed_front.report import summarize
    from otgym.experiments.speed_front.stats import Outcomes

    n = 200
    lost = lambda k: np.arange(n) < k  # noqa: E731 - success array: the first k completed
    outcomes = [
        Outcomes("G1", lost(n), np.full(n, 55.6), 0.27),
        Outcomes("G3", lost(n - 3), np.full(n, 41.0), 0.366),
        Outcomes("pretrained", lost(n - 2), np.full(n, 33.0), None, "pretrained"),
    ]
    summary = summarize(outcomes)
    front = {
        "command": "otgym experiment speed-front --seed 123",
        "seed": 123,
        "seed_status": "held out",
        "episodes": n,
        "rows": summary.rows,
        "pretrained_tests": [
            vars(c) | {"as_safe": c.as_safe, "faster": c.faster, "covers": c.covers}
            for c in summary.comparisons.values()
        ],
        "goals": {"exempt": summary.goals.exempt, "every_eligible_covered": summary.goals.every_eligible_covered},
    }
    text = "\n".join(front_lines(front))
    assert "held-out seed 123, 200 episodes" in text and "198 of 200" in text
    low, high = wilson(198, n)
    assert f"[{low:.3f}, {high:.3f}]" in text
    assert "It covers (at least as safe and at least 10 % faster): G3." in text  # not G1: 2 lost against 0
    front["seed_status"] = "development seed"
    assert "development seed 123" in "\n".join(front_lines(front))
    assert front_lines(None) == []
