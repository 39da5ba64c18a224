"""``otgym experiment calibrate-scenarios``: sweep one parameter of the interactive task's
obstacle scenarios (``otgym.tasks.transport.scenario.ScenarioConfig``) and measure, for each value,
the share of obstacles the autonomous mode avoids, against the paper's autonomous
success of 59 % (``otgym.study.PAPER_FIG8``).

This is how ``timing_jitter_s`` (15 s) was chosen (docs/decisions/0049 and 0016: 64
development scenarios, 900000-900063, the route navigator at 5 um/s ignoring obstacles):
the autonomous mode only follows the route, so the spread of the obstacles' crossing
times sets how many it meets. The autonomous mode needs no participant (alpha is 0, so
the person's hands have no weight), so a value costs one batch of autonomous trials.

Every value meets the same scenario numbers (trial t: ``seed * 10000 + t``, as
``otgym experiment shared-control``), each made with that value, so the values differ
only in the swept parameter's effect on the same random draws; all values run in one
batch (simulation seed ``seed``). Rates pool the obstacles of a value's trials, with
95 % Wilson intervals (``otgym.study.stats.wilson_interval``); an obstacle counts as
encountered when it came within the task's ``encounter_gap_um`` (20 um) and as avoided
when it was encountered and never touched (``otgym.task.task``).

Calibration is development by nature: its scenarios tune the task, so its seed is a
development seed (``otgym.experiments.common.seeds``; default 90, the seed of the original
calibration).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd

from otgym.experiments.calibration.config import SWEEPABLE
from otgym.experiments.common.progress import tenths
from otgym.experiments.common.seeds import SCENARIOS_PER_STUDY_SEED, development_uses
from otgym.human.params import HumanParams
from otgym.runtime.trials import TrialSpec, run_trials
from otgym.study import PAPER_FIG8
from otgym.study.stats import wilson_interval
from otgym.task.task import InteractiveConfig, InteractiveTask
from otgym.tasks.transport.interactive import interactive_scene
from otgym.tasks.transport.scenario import ScenarioConfig, make_scenario

TARGET_AVOIDED = PAPER_FIG8["autonomous"]["success_mean"]
"""The paper's autonomous success: 59 % of the obstacles avoided (printed ± 5 %)."""
MAX_VALUES = 20
SUMMARY_COLUMNS = [
    "value",
    "trials",
    "goals_reached",
    "obstacles_encountered",
    "obstacles_avoided",
    "obstacles_collided",
    "avoided_rate",
    "avoided_rate_ci_low",
    "avoided_rate_ci_high",
    "collided_rate",
    "collided_rate_ci_low",
    "collided_rate_ci_high",
    "completion_time_mean_s",
    "target_avoided",
    "target_in_ci",
]


def parse_values(text: str) -> tuple[str, tuple[float, ...]]:
    """``"timing_jitter_s=8,15,20"`` -> (name, values): a sweepable parameter and 1 to
    ``MAX_VALUES`` distinct finite values, each one the scenario configuration accepts."""
    name, equals, rest = text.partition("=")
    name = name.strip()
    if not equals or name not in SWEEPABLE:
        raise ValueError(f"--values must be NAME=V1,V2,... with NAME one of {', '.join(SWEEPABLE)}, got {text!r}")
    try:
        values = tuple(float(v) for v in rest.split(",") if v.strip())
    except ValueError:
        values = ()
    if not values or len(values) > MAX_VALUES or not all(math.isfinite(v) for v in values):
        raise ValueError(f"--values {name}= needs 1 to {MAX_VALUES} comma-separated finite numbers, got {rest!r}")
    if len(set(values)) != len(values):
        raise ValueError(f"--values lists a value twice: {rest}")
    for value in values:
        scenario_config(name, value)
    return name, values


def scenario_config(name: str, value: float) -> ScenarioConfig:
    """The default scenario configuration with ``name`` set to ``value`` (a ValueError
    naming both where the configuration refuses it)."""
    try:
        return dataclasses.replace(ScenarioConfig(), **{name: value})
    except ValueError as error:
        raise ValueError(f"--values {name}={value:g}: {error}") from None


def seed_note(seed: int, trials: int) -> str:
    """One line saying the seed is development: what development used it for, or that
    calibrating on it makes it a development seed (the same seed spaces as
    ``otgym experiment route-bound``: study seed, scenarios ``seed * 10000 + t``)."""
    uses = development_uses("route-bound", seed, trials=trials)
    if uses:
        named = "; ".join(f"{use.space} {_span(use.first, use.last)}: {use.used_for}" for use in uses)
        return (
            f"development seed: seed {seed} was used in development ({named}); calibration is development by "
            "nature: its figures tune the scenarios and are never held out"
        )
    first = seed * SCENARIOS_PER_STUDY_SEED
    return (
        f"development seed: calibrating on seed {seed} (scenarios {first}-{first + trials - 1}) makes it a "
        "development seed; add it to DEVELOPMENT in otgym/experiments/common/seeds.py and never report on it"
    )


def _span(first: int, last: int) -> str:
    return str(first) if first == last else f"{first}-{last}"


def run_calibration(
    name: str,
    values: tuple[float, ...],
    trials: int,
    seed: int,
    chip: str = "default",
    time_limit_s: float = 300.0,
    report: Callable[[str], None] = print,
) -> pd.DataFrame:
    """One row per value and trial: the autonomous mode's trial row (``TRIAL_COLUMNS``
    and the task's extra columns) with ``parameter`` and ``value``."""
    if trials < 1 or not 0 <= seed < 2**32:
        raise ValueError(f"need trials >= 1 and a seed in [0, 2**32), got {trials}, {seed}")
    configs = [scenario_config(name, value) for value in values]
    task = InteractiveTask(InteractiveConfig(scene=interactive_scene(chip=chip), time_limit_s=time_limit_s))
    numbers = [seed * SCENARIOS_PER_STUDY_SEED + t for t in range(trials)]
    scenarios = []
    for value, config in zip(values, configs):
        for number in numbers:
            try:
                scenarios.append(
                    make_scenario(
                        number,
                        task.route_um,
                        task.route_arc_um,
                        task.wall_distance_um,
                        task.config.scene.obstacle_radius_um,
                        config,
                    )
                )
            except ValueError as error:
                raise ValueError(f"--values {name}={value:g}, scenario {number}: {error}") from None
    specs = [TrialSpec(0, "autonomous", t, number) for _ in values for t, number in enumerate(numbers)]
    report(f"{name}: {len(values)} values x {trials} scenarios ({numbers[0]}-{numbers[-1]}), autonomous mode")
    # the autonomous mode gives the person no weight: any participant serves
    rows = run_trials(task, specs, {0: HumanParams()}, seed=seed, progress=tenths(report), scenarios=scenarios)
    frame = pd.DataFrame(rows).drop(columns=["participant"])
    frame.insert(0, "value", np.repeat(values, trials))
    frame.insert(0, "parameter", name)
    return frame


def summarise(frame: pd.DataFrame) -> pd.DataFrame:
    """Per value (``SUMMARY_COLUMNS``): obstacles encountered, avoided and collided,
    pooled over the trials, with 95 % Wilson intervals, and whether the paper's 59 %
    lies in the avoided rate's interval."""
    rows = []
    for value, group in frame.groupby("value", sort=True):
        met = int(group.obstacles_encountered.sum())
        avoided = int(group.obstacles_avoided.sum())
        low, high = wilson_interval(avoided, met)
        c_low, c_high = wilson_interval(met - avoided, met)
        rows.append(
            {
                "value": float(value),
                "trials": len(group),
                "goals_reached": int(group.reached_goal.sum()),
                "obstacles_encountered": met,
                "obstacles_avoided": avoided,
                "obstacles_collided": met - avoided,
                "avoided_rate": avoided / met if met else math.nan,
                "avoided_rate_ci_low": low,
                "avoided_rate_ci_high": high,
                "collided_rate": (met - avoided) / met if met else math.nan,
                "collided_rate_ci_low": c_low,
                "collided_rate_ci_high": c_high,
                "completion_time_mean_s": float(group.completion_time_s.mean()),
                "target_avoided": TARGET_AVOIDED,
                "target_in_ci": bool(met and low <= TARGET_AVOIDED <= high),
            }
        )
    return pd.DataFrame(rows, columns=SUMMARY_COLUMNS)


def write_calibration(frame: pd.DataFrame, out: Path, command: str, note: str) -> pd.DataFrame:
    """calibration_trials.csv (one row per trial), calibration.csv (``summarise``),
    calibration.md and calibration.png; returns the summary."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    name = str(frame.parameter.iloc[0])
    summary = summarise(frame)
    frame.to_csv(out / "calibration_trials.csv", index=False)
    summary.to_csv(out / "calibration.csv", index=False)
    default = getattr(ScenarioConfig(), name)
    lines = [
        f"**{note}.**",
        "",
        f"# Scenario calibration: {name}",
        "",
        f"`{command}`",
        "",
        f"The autonomous mode (the route navigator at 5 um/s, ignoring obstacles) on the same "
        f"{int(summary.trials.iloc[0])} scenarios per value; obstacles pooled over trials, 95 % Wilson intervals. "
        f"Target: the paper's autonomous success, {TARGET_AVOIDED:.0%} avoided. Default {name} = {default:g}.",
        "",
        f"| {name} | trials | goal | encountered | avoided | avoided rate [95 % CI] | collided rate [95 % CI] "
        "| time (s) | 59 % in CI |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for row in summary.itertuples():
        lines.append(
            f"| {row.value:g} | {row.trials} | {row.goals_reached} | {row.obstacles_encountered} | "
            f"{row.obstacles_avoided} | {_rate(row.avoided_rate, row.avoided_rate_ci_low, row.avoided_rate_ci_high)}"
            f" | {_rate(row.collided_rate, row.collided_rate_ci_low, row.collided_rate_ci_high)} | "
            f"{row.completion_time_mean_s:.1f} | {'yes' if row.target_in_ci else 'no'} |"
        )
    unfinished = int(summary.trials.sum() - summary.goals_reached.sum())
    if unfinished:
        lines += ["", f"{unfinished} trial(s) ended before the goal: obstacles beyond where they ended were not met."]
    (out / "calibration.md").write_text("\n".join(lines) + "\n")
    _plot(summary, name, out / "calibration.png", command, int(frame.scenario.min()) // SCENARIOS_PER_STUDY_SEED)
    return summary


def _rate(rate: float, low: float, high: float) -> str:
    if math.isnan(rate):
        return "n/a (none met)"
    return f"{rate:.0%} [{low:.0%}, {high:.0%}]"


def _plot(summary: pd.DataFrame, name: str, path: Path, command: str, seed: int) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4))
    rate = summary.avoided_rate.to_numpy(float)
    below = np.nan_to_num(rate - summary.avoided_rate_ci_low.to_numpy(float))
    above = np.nan_to_num(summary.avoided_rate_ci_high.to_numpy(float) - rate)
    ax.errorbar(summary.value, rate, yerr=[below, above], fmt="o-", capsize=4, label="autonomous mode (95 % Wilson)")
    ax.axhline(
        TARGET_AVOIDED, color="tab:red", linestyle="--", label=f"paper's autonomous success {TARGET_AVOIDED:.0%}"
    )
    for row in summary.itertuples():
        ax.annotate(
            f"{row.obstacles_encountered} met",
            (row.value, row.avoided_rate),
            textcoords="offset points",
            xytext=(4, -12),
            fontsize=7,
        )
    ax.set_xlabel(name)
    ax.set_ylabel("obstacles avoided / encountered")
    ax.set_ylim(0, 1.05)
    ax.legend(loc="lower right", fontsize=8)
    trials = int(summary.trials.iloc[0])
    ax.set_title(f"Scenario calibration: development seed {seed}, {trials} scenarios per value", fontsize=10)
    fig.text(0.01, 0.01, command, fontsize=6)
    fig.tight_layout(rect=(0, 0.03, 1, 1))
    fig.savefig(path, dpi=120)
    plt.close(fig)
