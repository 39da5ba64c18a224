"""How fast a controller that keeps the assembly on the planned route could carry the
cell past the shared-control experiment's obstacles: the earliest passage
(``otgym.autonomy.route_timing``) on the experiment's own scenarios (trial t of seed s
meets scenario ``s * 10000 + t``, as in ``otgym experiment shared-control``), from the
route's start at time 0 (no time to grip) to the goal tolerance, with perfect
foresight of the tracks and no margin beyond contact. Its mean over the scenarios
is a lower bound on the completion time of manual and shared control as built here
(they follow the route) and tells whether the issue's "shared time within 15 % of
autonomous" is reachable at all on those scenarios."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import pandas as pd

from otgym.autonomy.route_timing import earliest_passage, task_assembly_shape
from otgym.experiments.shared_control.config import check_arguments
from otgym.runtime.trials import CRUISE_SPEED_UM_S
from otgym.task.task import InteractiveConfig, InteractiveTask
from otgym.tasks.transport.interactive import interactive_scene

ROUTE_SPEED_UM_S = CRUISE_SPEED_UM_S
"""The route navigator's cruise speed in trials: the autonomous mode's pace, and
shared control's when nothing is in the way."""
COLUMNS = ["scenario", "max_speed_um_s", "free_s", "earliest_s", "lost_s"]
SHARED_TIME_TOLERANCE = 0.15
"""The issue's acceptance: shared control's mean time within 15 % of the autonomous mode's."""


def run_route_bound(
    trials: int, seed: int, speeds_um_s: list[float], chip: str = "default", report: Callable[[str], None] = print
) -> pd.DataFrame:
    """One row per scenario and speed limit (``COLUMNS``); the free time is the
    unobstructed route follower's at that speed, which for the autonomy's cruise speed
    is the autonomous mode's completion time when it meets nothing."""
    check_arguments(2, trials, seed)
    if not speeds_um_s or not all(0 < v <= 20 for v in speeds_um_s):
        raise ValueError(
            f"--speeds-um-s must be speeds in (0, 20] um/s (the task's trap-speed clamp), got {speeds_um_s}"
        )
    task = InteractiveTask(InteractiveConfig(scene=interactive_scene(chip=chip)))
    shape = task_assembly_shape(task)
    goal_arc = float(task.route_arc_um[-1] - task.config.goal_tolerance_um)
    rows = []
    for trial in range(trials):
        scenario_seed = seed * 10_000 + trial
        scenario = task.scenario(scenario_seed)
        for speed in speeds_um_s:
            passage = earliest_passage(
                scenario,
                task.route_um,
                task.route_arc_um,
                shape,
                task.config.scene.obstacle_radius_um,
                0.0,
                0.0,
                speed,
                goal_arc_um=goal_arc,
                time_limit_s=task.config.time_limit_s,
            )
            rows.append(
                {
                    "scenario": scenario_seed,
                    "max_speed_um_s": speed,
                    "free_s": passage.free_s,
                    "earliest_s": passage.arrival_s,
                    "lost_s": passage.lost_s,
                }
            )
        report(
            f"      scenario {scenario_seed}: earliest "
            + ", ".join(f"{r['earliest_s']:.1f} s at {r['max_speed_um_s']:g} um/s" for r in rows[-len(speeds_um_s) :])
            + f" ({trial + 1}/{trials})"
        )
    return pd.DataFrame(rows, columns=COLUMNS)


def summarise(frame: pd.DataFrame) -> dict:
    """Per speed limit: mean and SD of the earliest arrival and of the time lost, the
    free time, and whether the mean earliest arrival lies within 15 % of the free
    time (the best any route-keeping control could do against the issue's check)."""
    summary = {}
    for speed, group in frame.groupby("max_speed_um_s"):
        earliest = group.earliest_s.to_numpy(float)
        free = float(group.free_s.iloc[0])
        summary[f"{speed:g}"] = {
            "scenarios": int(len(group)),
            "free_s": free,
            "earliest_mean_s": float(earliest.mean()),
            "earliest_sd_s": float(earliest.std(ddof=1)) if len(group) > 1 else float("nan"),
            "lost_mean_s": float(group.lost_s.mean()),
            "scenarios_with_loss": int((group.lost_s > 0.5).sum()),
            "earliest_over_free": float(earliest.mean() / free),
            f"within {SHARED_TIME_TOLERANCE:.0%} of free": bool(earliest.mean() <= (1 + SHARED_TIME_TOLERANCE) * free),
        }
    return summary


def write_route_bound(frame: pd.DataFrame, out: Path) -> dict:
    """route_bound.csv (the rows), route_bound.json and route_bound.md (the summary)."""
    out.mkdir(parents=True, exist_ok=True)
    frame.to_csv(out / "route_bound.csv", index=False)
    summary = summarise(frame)
    (out / "route_bound.json").write_text(json.dumps(summary, indent=2))
    lines = [
        "# Earliest passage along the route (a bound on route-keeping control)",
        "",
        "Perfect foresight of the obstacles' tracks, no margin beyond contact, no time to grip; "
        "from the route's start to the goal tolerance.",
        "",
        "| max speed (um/s) | scenarios | free (s) | earliest, mean +- SD (s) | lost, mean (s) | "
        "scenarios with loss | earliest / free |",
        "|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for speed, row in summary.items():
        lines.append(
            f"| {speed} | {row['scenarios']} | {row['free_s']:.1f} | {row['earliest_mean_s']:.1f} +- "
            f"{row['earliest_sd_s']:.1f} | {row['lost_mean_s']:.1f} | {row['scenarios_with_loss']} | "
            f"{row['earliest_over_free']:.3f} |"
        )
    (out / "route_bound.md").write_text("\n".join(lines) + "\n")
    return summary
