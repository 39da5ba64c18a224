"""What ``otgym experiment shared-control`` writes and how it is judged: trials.csv (one
row per trial), summary.csv, summary.md and stats.json (per mode, beside the paper's
values; repeated-measures ANOVA and Holm-corrected paired tests, ``otgym.study``),
fig8.png, acceptance.json (the paper's ordering, and the MPC's acceptance where it ran,
checked) and, where the MPC ran, mpc.json (its size and the wall time of its replans)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd

from otgym import registry
from otgym.autonomy.mpc import MPCConfig
from otgym.study import plot_fig8, write_summary
from otgym.study.summary import json_safe

SHARED_OVER_NAVIGATOR_MIN_OBSTACLES = 256
"""Item (e) is judged on at least this many obstacles met by shared control over a
navigator with an acceptance rate."""


def acceptance_rates() -> dict[str, float]:
    """Each registered navigator's acceptance rate (extra ``acceptance_rate``: the share of
    the obstacles it meets that it avoids, and of its trials that reach the goal, alone
    and as shared control's autonomy; the MPC's is 0.99)."""
    return {
        entry.name: float(entry.extras["acceptance_rate"])
        for entry in registry.entries("navigators")
        if "acceptance_rate" in entry.extras
    }


MANUAL_OVER_SHARED_TIME = 1.8
SHARED_OVER_ROUTE_BOUND = 1.15
HOLM_ALPHA = 0.05


def acceptance(
    summary: pd.DataFrame,
    stats: dict | None = None,
    route_bound_s: float | None = None,
    shared_autonomy: str = "route",
) -> dict:
    """The acceptance items, each judged where its modes ran (an item whose modes or
    figures are missing is absent, not passed).

    Fig. 8, the paper's law restated: (a) autonomous avoids fewer obstacles
    than shared (its success mean lower, Holm-corrected paired test p < 0.05 from
    ``stats["success"]``); (b) manual takes at least 1.8x shared's time; (c) shared
    takes at most 1.15x ``route_bound_s``, the route-keeping bound at the autonomy's
    speed on the same scenarios (``otgym.experiments.shared_control.route_bound``); (d) shared avoids
    at least as many as manual (success means). Beyond the paper, with a
    ``shared_autonomy`` that has an acceptance rate (``acceptance_rates``; the MPC's
    0.99): (e) shared control over it avoids at least that share of at least 256
    obstacles met, and takes no longer than autonomous. Such a navigator alone (its
    mode, e.g. ``mpc``): obstacles avoided and goals reached at least its rate
    (pooled), no trap loss, no slower than shared control."""
    by_mode = summary.set_index("mode")
    checks = {}
    rates = acceptance_rates()
    for name in [mode for mode in by_mode.index if mode in rates]:
        alone, rate = by_mode.loc[name], rates[name]
        checks[f"{name} obstacles avoided >= {rate}"] = bool(alone.avoided_rate >= rate)
        checks[f"{name} goal reached >= {rate}"] = bool(alone.goal_rate >= rate)
        checks[f"{name} no trap loss"] = bool(alone.trap_losses == 0)
        if "shared" in by_mode.index:
            checks[f"{name} time <= shared time"] = bool(
                alone.completion_time_mean_s <= by_mode.loc["shared"].completion_time_mean_s
            )
    if "shared" not in by_mode.index:
        return checks
    shared = by_mode.loc["shared"]
    if "autonomous" in by_mode.index and stats is not None:
        auto = by_mode.loc["autonomous"]
        p_holm = _holm_p(stats.get("success", {}), "autonomous", "shared")
        checks["(a) autonomous avoids fewer than shared (Holm p < 0.05)"] = bool(
            auto.success_mean < shared.success_mean and p_holm < HOLM_ALPHA
        )
    if "manual" in by_mode.index:
        manual = by_mode.loc["manual"]
        checks[f"(b) manual time >= {MANUAL_OVER_SHARED_TIME}x shared time"] = bool(
            manual.completion_time_mean_s >= MANUAL_OVER_SHARED_TIME * shared.completion_time_mean_s
        )
    if route_bound_s is not None:
        checks[f"(c) shared time <= {SHARED_OVER_ROUTE_BOUND}x the route bound"] = bool(
            shared.completion_time_mean_s <= SHARED_OVER_ROUTE_BOUND * route_bound_s
        )
    if "manual" in by_mode.index:
        checks["(d) shared avoids at least as many as manual"] = bool(
            shared.success_mean >= by_mode.loc["manual"].success_mean
        )
    if shared_autonomy in rates:
        rate, label = rates[shared_autonomy], registry.entry("navigators", shared_autonomy).extras.get("label")
        minimum = SHARED_OVER_NAVIGATOR_MIN_OBSTACLES
        checks[f"(e) shared over the {label} avoids >= {rate} of >= {minimum} obstacles"] = bool(
            shared.obstacles_encountered >= minimum and shared.avoided_rate >= rate
        )
        if "autonomous" in by_mode.index:
            checks[f"(e) shared over the {label} no slower than autonomous"] = bool(
                shared.completion_time_mean_s <= by_mode.loc["autonomous"].completion_time_mean_s
            )
    return checks


def _holm_p(comparison: dict, a: str, b: str) -> float:
    """The Holm-corrected p of the paired test between modes ``a`` and ``b`` (NaN where
    it was not run)."""
    for row in comparison.get("posthoc", []):
        if {row["a"], row["b"]} == {a, b}:
            return float(row["p_holm"])
    return float("nan")


def mpc_summary(stats: dict, config: MPCConfig, tick_s: float) -> dict | None:
    """mpc.json: the controller's size and its replans' wall time, per batch that used
    the MPC (``stats``: per batch, per navigator, what ``run_experiment`` gathered);
    None where no batch did."""
    stats = {batch: navigators["mpc"] for batch, navigators in stats.items() if "mpc" in navigators}
    if not stats:
        return None
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


def write_experiment(
    trials: pd.DataFrame,
    out: Path,
    mpc: dict | None = None,
    route_bound_s: float | None = None,
    shared_autonomy: str = "route",
) -> dict:
    """Write trials.csv, summary.csv/md, stats.json, fig8.png, acceptance.json (the
    checks of ``acceptance`` on the written summary, the MPC's evidence, the route bound
    it was judged against) and mpc.json where ``mpc`` is given; return the checks."""
    out.mkdir(parents=True, exist_ok=True)
    trials.to_csv(out / "trials.csv", index=False)
    if mpc:
        (out / "mpc.json").write_text(json.dumps(mpc, indent=2))
    stats = write_summary(trials, out)
    plot_fig8(trials, out / "fig8.png", stats)
    summary = pd.read_csv(out / "summary.csv")
    checks = acceptance(summary, stats, route_bound_s, shared_autonomy)
    evidence = mpc_evidence(summary)
    extra = {"mpc": evidence} if evidence else {}
    if route_bound_s is not None:
        extra["route_bound_s"] = route_bound_s
    (out / "acceptance.json").write_text(json.dumps(json_safe({**checks, **extra}), indent=2))
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
