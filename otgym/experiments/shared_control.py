"""The paper's manual / autonomous / shared experiment (section III-C, Fig. 8 a-b) with
simulated participants: every mode for every participant on the same seeded
scenarios (trial t of every participant and mode meets scenario ``seed * 10000 + t``).
Writes trials.csv (one row per trial), summary.csv, summary.md and stats.json (per
mode, beside the paper's values; repeated-measures ANOVA and Holm-corrected paired
tests, ``otgym.study``), fig8.png and acceptance.json (the paper's ordering, checked)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Callable

import pandas as pd

from otgym.planning.human import sample_population
from otgym.runtime.task import InteractiveConfig, InteractiveTask
from otgym.runtime.trials import TRIAL_COLUMNS, TrialSpec, run_trials
from otgym.shared import MODES
from otgym.study import plot_fig8, write_summary

def parse_modes(text: str) -> list[str]:
    modes = [m.strip() for m in text.split(",") if m.strip()]
    unknown = [m for m in modes if m not in MODES]
    if unknown or not modes:
        raise ValueError(f"unknown mode(s) {', '.join(unknown) or '(none)'}; choose from {', '.join(MODES)}")
    if len(set(modes)) != len(modes):
        raise ValueError(f"--modes lists a mode twice: {text}")
    return modes


def check_arguments(participants: int, trials: int, seed: int) -> None:
    """Refuse bad sizes before any work or any file."""
    if participants < 2:
        raise ValueError(f"--participants must be at least 2 (a repeated-measures analysis), got {participants}")
    if trials < 1:
        raise ValueError(f"--trials must be at least 1, got {trials}")
    if not 0 <= seed < 2**32:
        raise ValueError(f"--seed must lie in [0, 2**32), got {seed}")


def run_experiment(participants: int, trials: int, modes: list[str], seed: int, chip: str = "default",
                   report: Callable[[str], None] = print, time_limit_s: float = 300.0) -> pd.DataFrame:
    """All trials, one batch per mode (a batch runs until its slowest trial is done)."""
    check_arguments(participants, trials, seed)
    from otgym.runtime.task import interactive_scene

    task = InteractiveTask(InteractiveConfig(scene=interactive_scene(chip=chip), time_limit_s=time_limit_s))
    people = dict(enumerate(sample_population(participants, seed)))
    rows = []
    for index, mode in enumerate(modes):
        specs = [TrialSpec(p, mode, t, seed * 10_000 + t) for p in range(participants) for t in range(trials)]
        report(f"[{index + 1}/{len(modes)}] {mode}: {len(specs)} trials")
        last = [-1]

        def progress(fraction, mode=mode, last=last):
            tenth = int(fraction * 10)
            if tenth > last[0]:
                last[0] = tenth
                report(f"      {mode}: {fraction:.0%} of trials done")

        rows += run_trials(task, specs, people, seed=seed + index, progress=progress)
    frame = pd.DataFrame(rows)
    return frame[TRIAL_COLUMNS + [c for c in frame.columns if c not in TRIAL_COLUMNS]]


def acceptance(summary: pd.DataFrame) -> dict:
    """The issue's criteria on the paper's ordering, where the modes are present."""
    by_mode = summary.set_index("mode")
    checks = {}
    if "shared" in by_mode.index:
        shared = by_mode.loc["shared"]
        checks["shared success >= 0.99"] = bool(shared.success_mean >= 0.99)
        if "manual" in by_mode.index:
            manual = by_mode.loc["manual"]
            checks["shared success >= manual's"] = bool(shared.success_mean >= manual.success_mean)
            checks["manual time >= 2x shared time"] = bool(manual.completion_time_mean_s
                                                           >= 2 * shared.completion_time_mean_s)
        if "autonomous" in by_mode.index:
            auto = by_mode.loc["autonomous"]
            checks["autonomous success below shared's by 0.1"] = bool(auto.success_mean <= shared.success_mean - 0.1)
            checks["shared time within 15 % of autonomous"] = bool(
                abs(shared.completion_time_mean_s - auto.completion_time_mean_s) <= 0.15 * auto.completion_time_mean_s)
    return checks


def write_experiment(trials: pd.DataFrame, out: Path) -> dict:
    out.mkdir(parents=True, exist_ok=True)
    trials.to_csv(out / "trials.csv", index=False)
    stats = write_summary(trials, out)
    plot_fig8(trials, out / "fig8.png", stats)
    checks = acceptance(pd.read_csv(out / "summary.csv"))
    (out / "acceptance.json").write_text(json.dumps(checks, indent=2))
    return checks
