"""The paper's manual / autonomous / shared experiment (section III-C, Fig. 8 a-b) with
simulated participants: every mode for every participant on the same seeded
scenarios (trial t of every participant and mode meets scenario ``seed * 10000 + t``).
A fourth mode, ``mpc``, runs the model-predictive navigator alone (no participant acts;
``otgym.autonomy.mpc``); ``shared_autonomy="mpc"`` makes it shared control's dP_r too.
Writes trials.csv (one row per trial), summary.csv, summary.md and stats.json (per
mode, beside the paper's values; repeated-measures ANOVA and Holm-corrected paired
tests, ``otgym.study``), fig8.png, acceptance.json (the paper's ordering, and the MPC's
acceptance where it ran, checked) and, where the MPC ran, mpc.json (its size and the
wall time of its replans)."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd

from otgym.autonomy.mpc import MPCConfig
from otgym.human.params import sample_population
from otgym.runtime.trials import AUTONOMIES, TRIAL_COLUMNS, TRIAL_MODES, TrialSpec, run_trials
from otgym.study import plot_fig8, write_summary
from otgym.study.summary import json_safe
from otgym.task.task import InteractiveConfig, InteractiveTask

MPC_ACCEPTANCE_RATE = 0.99
"""The MPC's acceptance: it avoids at least this share of the obstacles it meets and reaches
the goal in at least this share of its trials."""


def parse_modes(text: str) -> list[str]:
    modes = [m.strip() for m in text.split(",") if m.strip()]
    unknown = [m for m in modes if m not in TRIAL_MODES]
    if unknown or not modes:
        raise ValueError(f"unknown mode(s) {', '.join(unknown) or '(none)'}; choose from {', '.join(TRIAL_MODES)}")
    if len(set(modes)) != len(modes):
        raise ValueError(f"--modes lists a mode twice: {text}")
    return modes


def check_arguments(participants: int, trials: int, seed: int) -> None:
    """Refuse bad sizes before any work or any file."""
    if participants < 1:
        raise ValueError(
            f"--participants must be at least 1 (2 or more for the repeated-measures tests), got {participants}"
        )
    if trials < 1:
        raise ValueError(f"--trials must be at least 1, got {trials}")
    if not 0 <= seed < 2**32:
        raise ValueError(f"--seed must lie in [0, 2**32), got {seed}")


def run_experiment(
    participants: int,
    trials: int,
    modes: list[str],
    seed: int,
    chip: str = "default",
    report: Callable[[str], None] = print,
    time_limit_s: float = 300.0,
    shared_autonomy: str = "route",
    mpc_config: MPCConfig = MPCConfig(),
    mpc_stats: dict | None = None,
    one_batch: bool = False,
    scenario_per_participant: bool = False,
) -> pd.DataFrame:
    """All trials, one batch per mode (a batch runs until its slowest trial is done,
    mode ``i``'s with random seed ``seed + i``), or with ``one_batch`` every mode's
    trials in a single batch (seed ``seed``). A batch's cost per 20 ms tick grows
    little with its size (measured on 2 cores: about 7.4 ms for 3 trials, 10-11 ms for
    9, 14 ms for 18), so one batch of every mode costs about what the longest mode's
    alone does; the trials differ from per-mode batches only in their random streams.
    Trial t of every participant meets scenario ``seed * 10000 + t``, or with
    ``scenario_per_participant`` participant p's trial t meets ``seed * 10000 + p *
    trials + t``: every mode still meets the same scenarios, and a small study sees as
    many scenarios as it has trials per mode. ``mpc_stats`` (a dict) receives, per batch
    that used the MPC (keyed by its modes, joined by ``+``), its replan statistics."""
    check_arguments(participants, trials, seed)
    if shared_autonomy not in AUTONOMIES:
        raise ValueError(f"--shared-autonomy must be one of {', '.join(AUTONOMIES)}, got {shared_autonomy!r}")
    from otgym.task.task import interactive_scene

    task = InteractiveTask(InteractiveConfig(scene=interactive_scene(chip=chip), time_limit_s=time_limit_s))
    people = dict(enumerate(sample_population(participants, seed)))
    rows = []
    batches = [list(modes)] if one_batch else [[mode] for mode in modes]
    for index, batch in enumerate(batches):
        name = "+".join(batch)
        specs = [
            TrialSpec(p, mode, t, seed * 10_000 + p * trials * scenario_per_participant + t)
            for mode in batch
            for p in range(participants)
            for t in range(trials)
        ]
        report(f"[{index + 1}/{len(batches)}] {', '.join(batch)}: {len(specs)} trials")
        last = [-1]

        def progress(fraction, name=name, last=last):
            tenth = int(fraction * 10)
            if tenth > last[0]:
                last[0] = tenth
                report(f"      {name}: {fraction:.0%} of trials done")

        stats = {}
        rows += run_trials(
            task,
            specs,
            people,
            seed=seed + index,
            progress=progress,
            shared_autonomy=shared_autonomy,
            mpc_config=mpc_config,
            mpc_stats=stats,
        )
        if stats and mpc_stats is not None:
            mpc_stats[name] = stats
    frame = pd.DataFrame(rows)
    return frame[TRIAL_COLUMNS + [c for c in frame.columns if c not in TRIAL_COLUMNS]]


def acceptance(summary: pd.DataFrame) -> dict:
    """The acceptance criteria on the paper's ordering, where the modes are present, and
    the MPC's: obstacles avoided and goals reached (pooled over trials)
    at least ``MPC_ACCEPTANCE_RATE``, no trap loss, and its mean completion time no
    longer than shared control's (where shared control ran)."""
    by_mode = summary.set_index("mode")
    checks = {}
    if "mpc" in by_mode.index:
        mpc = by_mode.loc["mpc"]
        checks[f"mpc obstacles avoided >= {MPC_ACCEPTANCE_RATE}"] = bool(mpc.avoided_rate >= MPC_ACCEPTANCE_RATE)
        checks[f"mpc goal reached >= {MPC_ACCEPTANCE_RATE}"] = bool(mpc.goal_rate >= MPC_ACCEPTANCE_RATE)
        checks["mpc no trap loss"] = bool(mpc.trap_losses == 0)
        if "shared" in by_mode.index:
            checks["mpc time <= shared time"] = bool(
                mpc.completion_time_mean_s <= by_mode.loc["shared"].completion_time_mean_s
            )
    if "shared" in by_mode.index:
        shared = by_mode.loc["shared"]
        checks["shared success >= 0.99"] = bool(shared.success_mean >= 0.99)
        if "manual" in by_mode.index:
            manual = by_mode.loc["manual"]
            checks["shared success >= manual's"] = bool(shared.success_mean >= manual.success_mean)
            checks["manual time >= 2x shared time"] = bool(
                manual.completion_time_mean_s >= 2 * shared.completion_time_mean_s
            )
        if "autonomous" in by_mode.index:
            auto = by_mode.loc["autonomous"]
            checks["autonomous success below shared's by 0.1"] = bool(auto.success_mean <= shared.success_mean - 0.1)
            checks["shared time within 15 % of autonomous"] = bool(
                abs(shared.completion_time_mean_s - auto.completion_time_mean_s) <= 0.15 * auto.completion_time_mean_s
            )
    return checks


def mpc_summary(stats: dict, config: MPCConfig, tick_s: float) -> dict:
    """mpc.json: the controller's size and its replans' wall time (per mode that used it)."""
    summary = {
        "rollouts": config.n_rollouts,
        "horizon_s": config.horizon_s,
        "replan_period_s": config.step_s,
        "model_dt_s": config.model_dt_s,
        "tick_s": tick_s,
        "physics_steps_per_environment_replan": config.substeps_per_replan,
        "modes": {},
    }
    for mode, mode_stats in stats.items():
        seconds = np.asarray(mode_stats["replan_seconds"], float)
        sizes = np.asarray(mode_stats["environments_planned"], float)
        per_env = seconds / np.maximum(sizes, 1)
        summary["modes"][mode] = {
            "replans": int(mode_stats["replans"]),
            "environments_planned_mean": float(sizes.mean()) if sizes.size else 0,
            "replan_wall_s_mean": float(seconds.mean()) if seconds.size else None,
            "replan_wall_s_per_environment_mean": float(per_env.mean()) if per_env.size else None,
            "note": "batched trials replan many environments per call; benchmarks/mpc.py times one environment",
        }
    return summary


def write_experiment(trials: pd.DataFrame, out: Path, mpc: dict | None = None) -> dict:
    out.mkdir(parents=True, exist_ok=True)
    trials.to_csv(out / "trials.csv", index=False)
    if mpc:
        (out / "mpc.json").write_text(json.dumps(mpc, indent=2))
    stats = write_summary(trials, out)
    plot_fig8(trials, out / "fig8.png", stats)
    summary = pd.read_csv(out / "summary.csv")
    checks = acceptance(summary)
    evidence = mpc_evidence(summary)
    (out / "acceptance.json").write_text(
        json.dumps(json_safe({**checks, **({"mpc": evidence} if evidence else {})}), indent=2)
    )
    return checks


def mpc_evidence(summary: pd.DataFrame) -> dict | None:
    """The figures behind the MPC's checks, for acceptance.json: counts, rates with their
    95 % Wilson intervals (as summary.csv has them), mean completion time beside shared
    control's (same scenarios), trap losses. None where the MPC did not run."""
    by_mode = summary.set_index("mode")
    if "mpc" not in by_mode.index:
        return None
    row = by_mode.loc["mpc"]
    shared_time = float(by_mode.loc["shared"].completion_time_mean_s) if "shared" in by_mode.index else None
    return {
        "trials": int(row.trials),
        "obstacles_encountered": int(row.obstacles_encountered),
        "obstacles_avoided": int(row.obstacles_avoided),
        "avoided_rate": float(row.avoided_rate),
        "avoided_rate_ci95": [float(row.avoided_rate_ci_low), float(row.avoided_rate_ci_high)],
        "goals_reached": int(row.goals_reached),
        "goal_rate": float(row.goal_rate),
        "goal_rate_ci95": [float(row.goal_rate_ci_low), float(row.goal_rate_ci_high)],
        "completion_time_mean_s": float(row.completion_time_mean_s),
        "shared_completion_time_mean_s": shared_time,
        "trap_losses": int(row.trap_losses),
        "detachments": int(row.detachments),
    }
