"""What ``otgym experiment speed-front`` writes: ``front.csv`` (one row per constant
speed and policy), ``front_episodes.npz`` (per policy and episode: success, time, so
that every test can be recomputed), ``front_tests.csv`` (every policy against every constant speed),
``front.md`` (the table, the goals met and missed, the run's seeds, sizes and times),
``front.json`` (the same as data) and ``front.png`` (success against ATCT with 95 %
Wilson intervals, the constant speeds' front and the policies')."""

from __future__ import annotations

import csv
import dataclasses
import json
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from otgym.experiments.speed_front.stats import (
    ELIGIBLE_SUCCESS,
    FASTER_BY,
    SIGNIFICANCE_SAFETY,
    SIGNIFICANCE_SPEED,
    Comparison,
    Goals,
    Outcomes,
    compare_all,
    measure_goals,
    pareto_front,
)

if TYPE_CHECKING:
    from otgym.experiments.speed_front.run import FrontResult


@dataclasses.dataclass
class FrontSummary:
    rows: list[dict]
    comparisons: dict[tuple[str, str], Comparison]
    goals: Goals
    constant_front: list[str]
    policy_front: list[str]


def summarize(
    outcomes: list[Outcomes], train_s: dict[str, float] | None = None, extra: dict | None = None
) -> FrontSummary:
    """Rows, paired tests, fronts and goals of a front's outcomes; ``train_s`` (training
    time per member) and ``extra`` (per name: columns such as penalty and seed) join the rows."""
    comparisons = compare_all(outcomes)
    goals = measure_goals(outcomes, comparisons)
    constants = [o for o in outcomes if o.is_constant]
    policies = [o for o in outcomes if not o.is_constant]
    constant_front = pareto_front(constants)
    policy_front = pareto_front(policies)
    rows = []
    for o in outcomes:
        low, high = o.interval()
        rows.append(
            {
                "name": o.name,
                "kind": "constant" if o.is_constant else ("pretrained" if o.group == "pretrained" else "family"),
                "group": o.group,
                "speed_um_s": o.speed_um_s,
                "episodes": o.episodes,
                "successes": o.successes,
                "success_rate": round(o.success_rate, 6),
                "success_ci95_low": round(low, 6),
                "success_ci95_high": round(high, 6),
                "ATCT_s": None if o.atct_s is None else round(o.atct_s, 4),
                "on_constant_front": o.name in constant_front,
                "on_policy_front": o.name in policy_front,
                "train_s": None if not train_s or o.name not in train_s else round(train_s[o.name], 1),
                **((extra or {}).get(o.name, {})),
            }
        )
    return FrontSummary(rows, comparisons, goals, constant_front, policy_front)


def _fmt_p(p: float) -> str:
    return f"{p:.2g}" if p >= 1e-3 else f"{p:.1e}"


def coverage_lines(summary: FrontSummary) -> list[str]:
    """Per eligible constant speed: the fastest covering policy with its tests, or why
    none covers it (the safest 10 %-faster policy and the fastest as-safe one)."""
    atct = {row["name"]: row["ATCT_s"] for row in summary.rows}
    lines = [
        "| constant | success | ATCT (s) | covered by | policy success | ATCT ratio | only policy lost / only "
        "constant lost (McNemar p, less safe) | faster than 0.9 x / not (sign p) |",
        "|---|---:|---:|---|---:|---:|---:|---:|",
    ]
    success = {row["name"]: row["success_rate"] for row in summary.rows}
    fastest = min((row["ATCT_s"] for row in summary.rows if row["kind"] == "constant" and row["ATCT_s"]), default=None)
    for constant in summary.goals.eligible:
        comps = [c for (p, k), c in summary.comparisons.items() if k == constant]
        covering = [c for c in comps if c.covers]
        if covering:
            best, label = min(covering, key=lambda c: atct[c.policy]), None
        else:
            faster = [c for c in comps if c.faster]
            safe = [c for c in comps if c.as_safe]
            best = (
                max(faster, key=lambda c: (success[c.policy], -c.less_safe_p))
                if faster
                else min(safe, key=lambda c: atct[c.policy])
                if safe
                else None
            )
            label = "none" + (f" (closest: {best.policy})" if best else "")
            if fastest is not None and (1 - FASTER_BY) * atct[constant] < fastest:
                label += (
                    f"; unreachable: {1 - FASTER_BY:.1f} x {atct[constant]:.2f} s is below the fastest level's "
                    f"{fastest:.2f} s"
                )
        if best is None:
            lines.append(f"| {constant} | {success[constant]:.3f} | {atct[constant]:.2f} | none | | | | |")
            continue
        lines.append(
            f"| {constant} | {success[constant]:.3f} | {atct[constant]:.2f} | {label or best.policy} | "
            f"{success[best.policy]:.3f} | {best.time_ratio:.3f} | {best.policy_only_lost} / {best.constant_only_lost} "
            f"({_fmt_p(best.less_safe_p)}) | {best.faster_episodes} / {best.not_faster_episodes} "
            f"({_fmt_p(best.faster_p)}) |"
        )
    return lines


def goal_lines(summary: FrontSummary) -> list[str]:
    goals = summary.goals
    met = lambda ok: "**met**" if ok else "**missed**"  # noqa: E731
    lines = [
        f"- Every constant speed with success >= {ELIGIBLE_SUCCESS:.2f} ({', '.join(goals.eligible) or 'none'}) "
        f"covered by some policy of the family: {met(goals.every_eligible_covered)} "
        f"({sum(bool(v) for v in goals.covered_by.values())} of {len(goals.eligible)}"
        + (
            f"; not covered: {', '.join(k for k, v in goals.covered_by.items() if not v)}"
            if not goals.every_eligible_covered
            else ""
        )
        + f"). Exempt (success < {ELIGIBLE_SUCCESS:.2f}): {', '.join(goals.exempt) or 'none'}."
    ]
    if goals.pretrained_covers_reference is not None:
        comp = summary.comparisons[("pretrained", goals.reference)]
        lines.append(
            f"- The shipped `pretrained` policy at least as safe as {goals.reference} and at least "
            f"{FASTER_BY:.0%} faster: {met(goals.pretrained_covers_reference)} (only pretrained lost "
            f"{comp.policy_only_lost}, only {goals.reference} lost {comp.constant_only_lost}, McNemar p = "
            f"{_fmt_p(comp.less_safe_p)}; faster than 0.9 x {goals.reference} in {comp.faster_episodes} of "
            f"{comp.faster_episodes + comp.not_faster_episodes} untied shared completions, sign p = "
            f"{_fmt_p(comp.faster_p)}; ATCT ratio {comp.time_ratio:.3f})."
            if comp.time_ratio is not None
            else f"- The shipped `pretrained` policy against {goals.reference}: {met(False)} (it completed no episode)."
        )
    for group, (covering, total) in goals.seeds_covering_reference.items():
        lines.append(
            f"- Training seeds of the family's reward `{group}` that cover {goals.reference}: {covering} of {total}"
            + (" (goal: at least 4 of 5)" if total == 5 else "")
            + "."
        )
    return lines


def front_markdown(result: FrontResult, summary: FrontSummary, command: str) -> list[str]:
    config = result.config
    lines = ["# Speed-control front (Table II as a front)", ""]
    if result.seed_note:
        lines += [f"**{result.seed_note}.**", ""]
    members = {m.name: m for m in result.members}
    lines += [
        f"Command: `{command}`. Evaluation: {config.total_episodes} episodes ({config.batches} batches of "
        f"{config.batch_size}, seeds {result.evaluation_seeds[0]}-{result.evaluation_seeds[-1]}), the same for "
        f"every policy and constant speed. Family: {len(result.members)} trainings ({len(config.rewards)} rewards "
        f"x {config.seeds} training seeds {sorted({m.training_seed for m in result.members})}, {config.steps} env "
        f"steps each). Wall time {result.wall_s / 60:.1f} min.",
        "",
        "| name | speed (um/s) | success | 95 % CI | ATCT (s) | constants' front | policies' front | training (s) |",
        "|---|---:|---:|---:|---:|:---:|:---:|---:|",
    ]
    for row in summary.rows:
        speed = "learned" if row["speed_um_s"] is None else f"{row['speed_um_s']:.3f}"
        atct = "-" if row["ATCT_s"] is None else f"{row['ATCT_s']:.2f}"
        train = f"{members[row['name']].train_s:.0f}" if row["name"] in members else ""
        lines.append(
            f"| {row['name']} | {speed} | {row['successes']}/{row['episodes']} = {row['success_rate']:.3f} | "
            f"{row['success_ci95_low']:.3f}-{row['success_ci95_high']:.3f} | {atct} | "
            f"{'x' if row['on_constant_front'] else ''} | {'x' if row['on_policy_front'] else ''} | {train} |"
        )
    lines += [
        "",
        "## Goals",
        "",
        *goal_lines(summary),
        "",
        "## Coverage of each eligible constant speed",
        "",
        f"A policy covers a constant speed when McNemar's exact test does not show it less safe (one-sided p >= "
        f"{SIGNIFICANCE_SAFETY:g}), its success rate is not lower, and its completion time is below "
        f"{1 - FASTER_BY:.1f} x the constant's in significantly more than half of the episodes both completed "
        f"(one-sided sign test, p < {SIGNIFICANCE_SPEED:g}). Fastest covering policy, or the closest:",
        "",
        *coverage_lines(summary),
        "",
        "Every test: `front_tests.csv`. Figure: `front.png`.",
        "",
    ]
    return lines


def write_front(result: FrontResult, out_dir: Path, command: str) -> FrontSummary:
    """Write front.csv, front_tests.csv, front.md, front.json and front.png into ``out_dir``."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    extra = {
        m.name: {"penalty": m.penalty, "time_cost": m.time_cost, "training_seed": m.training_seed}
        for m in result.members
    }
    summary = summarize(result.outcomes, {m.name: m.train_s for m in result.members}, extra)
    fields = list(dict.fromkeys(key for row in summary.rows for key in row))
    with open(out_dir / "front.csv", "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=fields)
        writer.writeheader()
        writer.writerows(summary.rows)
    tests = [
        {**dataclasses.asdict(c), "as_safe": c.as_safe, "faster": c.faster, "covers": c.covers}
        for c in summary.comparisons.values()
    ]
    with open(out_dir / "front_tests.csv", "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(tests[0]))
        writer.writeheader()
        writer.writerows(tests)
    (out_dir / "front.md").write_text("\n".join(front_markdown(result, summary, command)))
    from otgym.rl.policy import save_policy

    for m in result.members:
        meta = {"preset": "paper", "hidden": list(m.hidden), "seed": m.training_seed, "env_steps": result.config.steps}
        save_policy(out_dir / "policies" / f"{m.file_stem}.npz", m.q_params, {**meta, **extra[m.name]})
    np.savez_compressed(
        out_dir / "front_episodes.npz",
        names=np.array([o.name for o in result.outcomes]),
        success=np.stack([o.success for o in result.outcomes]),
        time_s=np.stack([o.time_s for o in result.outcomes]),
    )
    goals = summary.goals
    report = {
        "command": command,
        "seed": result.config.seed,
        "seed_status": "development seed" if result.seed_note else "held out",
        "development_note": result.seed_note,
        "evaluation_seeds": result.evaluation_seeds,
        "episodes": result.config.total_episodes,
        "training_seeds": sorted({m.training_seed for m in result.members}),
        "steps": result.config.steps,
        "wall_s": round(result.wall_s, 1),
        "train_s": {m.name: round(m.train_s, 1) for m in result.members},
        "rows": summary.rows,
        "pretrained_tests": [
            {**dataclasses.asdict(c), "as_safe": c.as_safe, "faster": c.faster, "covers": c.covers}
            for (policy, _), c in summary.comparisons.items()
            if policy == "pretrained"
        ],
        "constant_front": summary.constant_front,
        "policy_front": summary.policy_front,
        "goals": {
            "eligible": goals.eligible,
            "exempt": goals.exempt,
            "covered_by": goals.covered_by,
            "every_eligible_covered": goals.every_eligible_covered,
            "reference": goals.reference,
            "pretrained_covers_reference": goals.pretrained_covers_reference,
            "seeds_covering_reference": {k: list(v) for k, v in goals.seeds_covering_reference.items()},
        },
    }
    (out_dir / "front.json").write_text(json.dumps(report, indent=2))
    write_front_figure(summary, out_dir / "front.png", result.seed_note is None, result.config.seed)
    return summary


def write_front_figure(summary: FrontSummary, path: Path, held_out: bool, seed: int) -> None:
    """Success rate (95 % Wilson intervals) against ATCT: constant speeds and their front,
    the family by reward, the shipped policy, and the policies' front."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = [r for r in summary.rows if r["ATCT_s"] is not None]
    by_name = {r["name"]: r for r in rows}
    fig, ax = plt.subplots(figsize=(8, 5.5))

    def points(group_rows, **style):
        xs = [r["ATCT_s"] for r in group_rows]
        ys = [r["success_rate"] for r in group_rows]
        low = [r["success_rate"] - r["success_ci95_low"] for r in group_rows]
        high = [r["success_ci95_high"] - r["success_rate"] for r in group_rows]
        ax.errorbar(xs, ys, yerr=[low, high], ls="none", capsize=2, **style)

    constants = [r for r in rows if r["kind"] == "constant"]
    points(constants, marker="s", color="tab:gray", label="constant speeds G1-G6")
    for r in constants:
        ax.annotate(r["name"], (r["ATCT_s"], r["success_rate"]), textcoords="offset points", xytext=(5, -10))
    groups = list(dict.fromkeys(r["group"] for r in rows if r["kind"] == "family"))
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for index, group in enumerate(groups):
        points([r for r in rows if r["group"] == group], marker="o", color=colours[index % len(colours)], label=group)
    shipped = [r for r in rows if r["kind"] == "pretrained"]
    if shipped:
        points(shipped, marker="*", markersize=14, color="black", label="pretrained (shipped)")

    def front_line(names, **style):
        line = sorted((by_name[n] for n in names if n in by_name), key=lambda r: r["ATCT_s"])
        if line:
            ax.step([r["ATCT_s"] for r in line], [r["success_rate"] for r in line], where="post", **style)

    front_line(summary.constant_front, color="tab:gray", ls="--", lw=1, label="constant speeds' front")
    front_line(summary.policy_front, color="tab:red", ls="-", lw=1, label="policies' front")
    n = rows[0]["episodes"] if rows else 0
    ax.set_xlabel("ATCT: mean completion time of completed episodes (s)")
    ax.set_ylabel("success rate (95 % Wilson interval)")
    ax.set_title(
        f"Speed control: safety against speed, {n} episodes, seed {seed}" + ("" if held_out else " (development)")
    )
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
