"""The demo's whole-path section: the cell carried from the chip's start to its goal
past the interactive task's four moving obstacles (``otgym.task``), by the autonomy
otgym recommends beside the constant-speed route follower, on the same seeded
scenarios and in one batch (``otgym.runtime.trials.run_trials``).

Run ``i`` meets scenario ``seed * 10000 + SCENARIO_OFFSET + i`` (the study's seed
space, ``otgym.experiments.common.seeds``, away from the trials of the demo's small study) in
both modes:

* ``autonomous``: the route navigator at a constant cruise speed (the paper's
  autonomous mode; 5 um/s by default, the pace the scenarios' crossing times are drawn
  around), which ignores the obstacles;
* ``autonomy``, by default ``RECOMMENDED_AUTONOMY`` (``rl``): the learned speed
  (``otgym.autonomy.rl_navigator``), which slows or waits for the obstacles ahead; or
  ``mpc``, the model-predictive navigator (``otgym.autonomy.mpc``), which predicts the
  obstacles and steps aside or waits.

A trial ends at the goal, at a lost trap or at ``time_limit_s``; an obstacle that
touches the assembly does not end it (the task's rules), so the section counts the
runs that reached the goal and, apart, those that reached it without a touch.

Writes ``trials.csv`` (one row per trial, the study's columns), ``cells.csv`` (every
trial's cell and nearest obstacle every ``SAMPLE_EVERY_TICKS`` ticks),
``whole_path.png`` and ``summary.json``.
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Callable
from pathlib import Path

import numpy as np

from otgym import registry
from otgym.experiments.common.seeds import SCENARIOS_PER_STUDY_SEED

RECOMMENDED_AUTONOMY = "rl"
"""The autonomy the whole-path section shows by default: the learned speed, the route
follower whose speed a DQN chooses, which reaches the goal past the moving obstacles
(docs/decisions/0052-demo-whole-path-learned-speed.md) at a fraction of the MPC's cost:
no replans, one small network every 0.5 s. The MPC (``mpc``) passes more of the
obstacles it meets (128 of 128 goals, 459 of 460 obstacles avoided on held-out seed 13,
docs/mpc.md) and is one option away (``otgym demo --autonomy mpc``)."""

BASELINE_MODE = "autonomous"
"""The constant-speed route follower of the paper's autonomous mode."""

SCENARIO_OFFSET = 5000
"""Run i meets scenario ``seed * 10000 + 5000 + i``: the demo's study uses the first
participants x trials (at most 128) of the seed's 10,000."""

SAMPLE_EVERY_TICKS = 10
"""cells.csv and the figure keep every 10th 20 ms tick (0.2 s)."""

AUTONOMY_MODES = tuple(
    entry.name for entry in registry.entries("navigators", "trial-mode") if "measured" in entry.extras
)
"""The autonomies the section can show beside the route follower: the navigators with a
mode of their own in the trials and a measured full-size result (``otgym list
navigators``)."""


def mode_name(mode: str) -> str:
    """A trial mode's name in the report: the route follower, or the navigator's label."""
    navigator = "route" if mode == BASELINE_MODE else mode
    return registry.entry("navigators", navigator).extras.get("label", mode)


CELL_COLUMNS = ("mode", "run", "scenario", "t_s", "phase", "cell_x_um", "cell_y_um", "nearest_obstacle_gap_um")


@dataclasses.dataclass(frozen=True)
class WholePathDemo:
    """``runs`` scenarios, each run by the route follower at ``speed_um_s`` and by the
    recommended autonomy; simulation seed ``seed``; trials cut at ``time_limit_s`` of
    simulated time (the route is about 300 um: 60 s at 5 um/s, plus the grip)."""

    runs: int = 2
    seed: int = 1
    speed_um_s: float = 5.0
    time_limit_s: float = 150.0
    chip: str = "default"
    autonomy: str = RECOMMENDED_AUTONOMY

    def __post_init__(self):
        if self.autonomy not in AUTONOMY_MODES:
            raise ValueError(f"autonomy must be one of {', '.join(AUTONOMY_MODES)}, got {self.autonomy!r}")
        if isinstance(self.runs, bool) or not isinstance(self.runs, int) or self.runs < 1:
            raise ValueError(f"runs must be a positive integer, got {self.runs!r}")
        for name in ("speed_um_s", "time_limit_s"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
                raise ValueError(f"{name} must be a positive number, got {value!r}")

    @property
    def scenarios(self) -> list[int]:
        first = self.seed * SCENARIOS_PER_STUDY_SEED + SCENARIO_OFFSET
        return list(range(first, first + self.runs))

    @property
    def modes(self) -> tuple[str, str]:
        return BASELINE_MODE, self.autonomy


class _CellSampler:
    """``run_trials``' recorder: every ``SAMPLE_EVERY_TICKS`` ticks and at the tick
    each trial ends, each running trial's time, phase, cell position and nearest
    obstacle gap; every ``SAMPLE_EVERY_TICKS`` ticks the obstacles' positions (copies:
    it changes nothing it sees)."""

    def __init__(self, progress: Callable[[float], None] | None):
        self.ticks = 0
        self.rows: list[tuple] = []
        self.obstacles: list[np.ndarray] = []  # (E, K, 2) per sample
        self.progress = progress
        self._done: np.ndarray | None = None

    def __call__(self, view) -> None:
        self.ticks += 1
        obs, done = view.obs, np.array(view.state.metrics.done, bool)
        ended = done & ~(np.zeros_like(done) if self._done is None else self._done)
        self._done = done
        sampled = self.ticks % SAMPLE_EVERY_TICKS == 0
        gaps = obs.nearest_obstacle_gap_um
        for env in np.flatnonzero(ended | (sampled & ~done)):
            self.rows.append(
                (env, float(obs.time_s[env]), int(obs.phase[env]), *map(float, obs.cell_xy_um[env]), float(gaps[env]))
            )
        if sampled:
            self.obstacles.append(np.array(obs.obstacle_xy_um, float))
            if self.progress is not None:
                self.progress(float(np.max(obs.time_s)))


def run(demo: WholePathDemo, out_dir: Path, progress: Callable[[int, int], None] | None = None) -> dict:
    """Run both modes on the demo's scenarios in one batch, write the section's files
    into ``out_dir`` and return the summary (also ``summary.json``). ``progress(done,
    total)`` follows the simulated seconds of the batch (total: the time limit; the
    batch stops once every trial has ended)."""
    import pandas as pd

    from otgym.human.params import sample_population
    from otgym.runtime.trials import TrialSpec, run_trials
    from otgym.task.task import InteractiveConfig, InteractiveTask
    from otgym.tasks.transport.interactive import interactive_scene

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    task = InteractiveTask(InteractiveConfig(scene=interactive_scene(chip=demo.chip), time_limit_s=demo.time_limit_s))
    specs = [TrialSpec(0, mode, run, scenario) for mode in demo.modes for run, scenario in enumerate(demo.scenarios)]
    limit = int(math.ceil(demo.time_limit_s))
    sampler = _CellSampler(None if progress is None else lambda t: progress(min(int(t), limit), limit))
    rows = run_trials(
        task,
        specs,
        dict(enumerate(sample_population(1, demo.seed))),  # nobody acts in these modes
        demo.seed,
        cruise_speed_um_s=demo.speed_um_s,
        recorder=sampler,
    )
    if progress is not None:
        progress(limit, limit)
    trials = pd.DataFrame(rows)
    trials.to_csv(out_dir / "trials.csv", index=False)
    cells = pd.DataFrame(
        [(specs[env].mode, specs[env].trial, specs[env].scenario, *values) for env, *values in sampler.rows],
        columns=CELL_COLUMNS,
    )
    cells.to_csv(out_dir / "cells.csv", index=False, float_format="%.4g")
    summary = summarize(demo, rows, float(task.route_arc_um[-1]))
    (out_dir / "summary.json").write_text(json.dumps(summary, indent=2))
    _figure(task, specs, cells, sampler, summary, out_dir / "whole_path.png")
    return summary


def summarize(demo: WholePathDemo, rows: list[dict], route_length_um: float) -> dict:
    """Per mode: runs, goals reached, goals reached without an obstacle's touch or a
    lost trap ("clean"), obstacles met and avoided, touches, trap losses, detachments and
    the completion times of the runs that reached the goal."""
    modes = []
    for mode in demo.modes:
        mine = [row for row in rows if row["mode"] == mode]
        reached = [row for row in mine if row["reached_goal"]]
        modes.append(
            {
                "mode": mode,
                "name": mode_name(mode) + ("" if mode == demo.autonomy else f" at {demo.speed_um_s:g} um/s"),
                "runs": len(mine),
                "reached_goal": len(reached),
                "reached_goal_clean": sum(row["collisions"] == 0 and row["trap_losses"] == 0 for row in reached),
                "obstacles_encountered": sum(row["obstacles_encountered"] for row in mine),
                "obstacles_avoided": sum(row["obstacles_avoided"] for row in mine),
                "collisions": sum(row["collisions"] for row in mine),
                "trap_losses": sum(row["trap_losses"] for row in mine),
                "detachments": sum(row["detachments"] for row in mine),
                "completion_times_s": [round(row["completion_time_s"], 2) for row in reached],
            }
        )
    return {
        "seed": demo.seed,
        "scenarios": demo.scenarios,
        "runs": demo.runs,
        "speed_um_s": demo.speed_um_s,
        "time_limit_s": demo.time_limit_s,
        "route_length_um": round(route_length_um, 1),
        "recommended": demo.autonomy,
        "autonomy_text": registry.entry("navigators", demo.autonomy).extras["about"],
        "measured_text": registry.entry("navigators", demo.autonomy).extras["measured"],
        "modes": modes,
    }


def _figure(task, specs, cells, sampler: _CellSampler, summary: dict, path: Path) -> None:
    """The chip with each trial's cell path (the route follower dashed orange, the
    autonomy solid blue) and the obstacles' tracks of run 0 (grey)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    chip = task.chip
    height, width = np.asarray(chip.image).shape[:2]
    extent = (0.0, width * chip.pixel_size_um, height * chip.pixel_size_um, 0.0)
    fig, ax = plt.subplots(figsize=(10, 6.4))
    ax.imshow(np.asarray(chip.image), cmap="gray", extent=extent, alpha=0.5)
    ax.plot(task.route_um[:, 0], task.route_um[:, 1], color="0.5", lw=0.6, ls=":", label="planned route")
    if sampler.obstacles:
        obstacles = np.stack(sampler.obstacles)  # (samples, E, K, 2)
        first = [env for env, spec in enumerate(specs) if spec.trial == 0 and spec.mode == summary["recommended"]]
        for k in range(obstacles.shape[2]):
            track = obstacles[:, first[0], k]
            ax.plot(track[:, 0], track[:, 1], color="0.35", lw=1.0, label="obstacles (run 0)" if k == 0 else None)
    by_mode = {row["mode"]: row for row in summary["modes"]}
    for (mode, run), group in cells.groupby(["mode", "run"], sort=False):
        row = by_mode[mode]
        baseline = mode != summary["recommended"]
        label = f"{row['name']}: {row['reached_goal']} of {row['runs']} reached the goal" if run == 0 else None
        ax.plot(
            group["cell_x_um"],
            group["cell_y_um"],
            color="tab:orange" if baseline else "tab:blue",
            lw=1.0 if baseline else 1.8,
            ls="--" if baseline else "-",
            label=label,
        )
    ax.set_xlim(extent[0], extent[1])
    ax.set_ylim(extent[2], extent[3])
    ax.set_xlabel("x (um)")
    ax.set_ylabel("y (um)")
    scenarios = summary["scenarios"]
    named = f"scenario {scenarios[0]}" if len(scenarios) == 1 else f"scenarios {scenarios[0]}-{scenarios[-1]}"
    ax.set_title(f"The cell's path past the moving obstacles, seed {summary['seed']}, {named}")
    ax.legend(loc="lower right", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
