"""The demo's line per task beyond the paper's: each task with a report (the registry's
entries with ``report_seed``: assemble, orient, sort-cells) runs its shipped learned
policy and its scripted baseline on the same few paired episodes, with the statistics
and files of the task's full report (``otgym.experiments.task_report.run``), into
``tasks/<name>/``. The demo's seed is a development seed of the seed protocol, so the
files say so; the report-seed results, 256 episodes each, are on docs/tasks.md
(``otgym experiment <name>``)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path


def task_names() -> tuple[str, ...]:
    """The tasks the demo runs, in the registry's order."""
    from otgym.experiments.common import seeds

    return tuple(seeds.TASK_REPORTS)


def run_tasks(
    episodes: int, seed: int, out_dir: Path, progress: Callable[[int, int], None] | None = None
) -> list[dict]:
    """Every task's comparison on ``episodes`` paired episodes from ``seed``, written to
    ``out_dir / name``; one row per task: both success counts and both medians of the
    task's secondary outcome (its time to success on the episodes both completed, or
    its registry's ``report_secondary`` metric on every episode). ``progress(done,
    total)`` after each task."""
    from otgym.experiments.task_report.run import SHIPPED_POLICIES, run

    names = task_names()
    rows = []
    for done, name in enumerate(names, 1):
        result = run(name, out_dir / name, episodes, seed, SHIPPED_POLICIES[name])
        comparison = result["comparison"]
        row = {
            "task": name,
            "preset": result["preset"],
            "episodes": episodes,
            "baseline_successes": comparison["baseline_successes"],
            "learned_successes": comparison["learned_successes"],
            "secondary": comparison.get("secondary", "time to success (s)").replace("_", " "),
        }
        if "secondary" in comparison:  # a per-episode metric, higher is better, on every episode
            row.update(baseline_median=comparison["baseline_median"], learned_median=comparison["learned_median"])
        else:  # seconds, on the episodes both completed
            row.update(
                baseline_median=comparison["baseline_median_time_s"], learned_median=comparison["learned_median_time_s"]
            )
        rows.append(row)
        if progress is not None:
            progress(done, len(names))
    return rows


def task_line(row: dict) -> str:
    """One line of a task's result, for the console and the report."""
    n = row["episodes"]
    medians = (
        ""
        if row["learned_median"] is None
        else f"; median {row['secondary']} {row['learned_median']:.3g} against {row['baseline_median']:.3g}"
    )
    return (
        f"{row['task']} ({row['preset']}): the learned policy succeeded in {row['learned_successes']} of {n} "
        f"episodes, the scripted baseline in {row['baseline_successes']} of {n}{medians} "
        f"(tasks/{row['task']}/summary.md)"
    )


def tasks_section(rows: list[dict], seed: int) -> list[str]:
    """The report's section: one line per task, its sample size and where the full run is."""
    lines = [
        "## The other tasks: learned policy against scripted baseline",
        "",
        f"Each task's shipped learned policy and its scripted baseline on the same {rows[0]['episodes']} "
        f"episodes of seed {seed} (a development seed: a look, not a result). The report-seed comparisons, "
        "256 episodes each with their intervals and paired tests, are in the documentation's Tasks page "
        "(" + ", ".join(f"`otgym experiment {row['task']}`" for row in rows) + ").",
        "",
    ]
    lines += [f"- {task_line(row)}" for row in rows]
    return lines + [""]
