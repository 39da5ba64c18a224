"""``report.md`` of the demo: our planning, speed-control, transport and shared-control
figures beside the paper's (its Tables I and II, the safety claims of its Fig. 7 and
its Fig. 8), each with its sample size.

Pure text formatting of results computed elsewhere; the paper's numbers are quoted
from the paper (``paper_tables``, ``otgym.study.paper_fig8``).
"""

from __future__ import annotations

from pathlib import Path

from otgym.experiments.common.paper_tables import PAPER_SAFETY, PAPER_TABLE_I, number, table_ii_markdown
from otgym.experiments.demo.shipped_results import fig8_lines, front_lines
from otgym.planning.metrics import PathMetrics
from otgym.study import PAPER_FIG8, wilson_interval


def planning_section(metrics: dict[str, PathMetrics]) -> list[str]:
    """Table I, ours (um) beside the paper's (scene units), with lengths also relative to
    the B-spline path so that the rows compare across units."""
    ours_reference = metrics["B-spline"].length_um
    paper_reference = PAPER_TABLE_I["B-spline"][0]
    lines = [
        "## Path planning (paper Table I)",
        "",
        "| path | length (um) | length / B-spline | mean curvature (1/um) | angular deviation (deg) | "
        "paper: length / B-spline | paper: mean curvature | paper: angular deviation (deg) |",
        "|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for name, row in metrics.items():
        paper = PAPER_TABLE_I.get(name, (None, None, None))
        paper_ratio = None if paper[0] is None else paper[0] / paper_reference
        lines.append(
            f"| {name} | {row.length_um:.1f} | {row.length_um / ours_reference:.3f} | "
            f"{row.mean_curvature_per_um:.4g} | {row.angular_deviation_deg:.4g} | "
            f"{number(paper_ratio, '.3f')} | {number(paper[1], '.5g')} | {number(paper[2], '.5g')} |"
        )
    lines += [
        "",
        "Curvatures depend on the sampling step (ours 0.25 um, the paper's unpublished), so compare "
        "the order of the rows, not the values. Figures: `plan/paths.png`, `plan/spectrum.png`.",
        "",
    ]
    return lines


def reference_verdict(checks: dict, rows: list[dict]) -> str:
    """One paragraph: RL against the fastest constant speed as safe as it, with the
    paired tests of ``speed_control_eval.acceptance``."""
    if checks["reference"] is None:
        return "No constant speed was as safe as RL on these episodes (every one lost more of them)."
    reference = next(row for row in rows if row["policy"] == checks["reference"])
    name = checks["reference"]
    outcome = "faster" if checks["beats_reference"] else "not significantly faster"
    atct = "none completed" if reference["ATCT_s"] is None else f"{reference['ATCT_s']:.2f} s"
    return (
        f"The fastest constant speed at least as safe is {name} (success {reference['success_rate']:.3f}, "
        f"ATCT {atct}). On the episodes both completed RL finished first in "
        f"{checks['faster_episodes']} and later in {checks['slower_episodes']} (one-sided sign test "
        f"p = {checks['speed_p']:.2g}): RL is {outcome}. Episodes only RL lost: {checks['rl_only_lost']}, only "
        f"{name} lost: {checks['reference_only_lost']} (McNemar's exact test, p = {checks['safety_p']:.2g} that "
        f"RL loses more often)."
    )


def speed_control_section(
    rows: list[dict],
    safety: dict,
    checks: dict,
    force_limit_pn: float,
    distance_limit_um: float,
    preset: str,
    full_episodes: int | None = None,
    front: dict | None = None,
) -> list[str]:
    """Table II (ours beside the paper's), the comparison with the fastest constant speed
    as safe as RL (``checks``: ``speed_control_eval.acceptance``), the shipped policy on
    the measured front (``front``: see ``shipped_results.front_lines``) and the safety figures of the
    trained policy; ``full_episodes``: the size of the full evaluation (``otgym
    evaluate``), named when this one is smaller."""
    rl = next(row for row in rows if row["policy"] == "RL")
    episodes = rl["episodes"]
    size = f"every policy runs the same {episodes} seeded episodes"
    if full_episodes is not None and episodes < full_episodes:
        size += (
            f", a small sample that fits the demo's time (the full evaluation: `otgym evaluate --policy "
            f"pretrained --episodes {full_episodes}`)"
        )
    lines = [
        "## Learned speed control (paper Table II)",
        "",
        f"Preset `{preset}`; {size}.",
        "",
        *table_ii_markdown(rows),
    ]
    quicker = [
        row
        for row in rows
        if row["policy"] != "RL"
        and row["ATCT_s"] is not None
        and rl["ATCT_s"] is not None
        and row["ATCT_s"] < rl["ATCT_s"]
    ]
    won = round(rl["success_rate"] * episodes)
    low, high = wilson_interval(won, episodes)
    verdict = (
        f"RL: ASR {rl['ASR']:.3f}, success {won} of {episodes} episodes ({rl['success_rate']:.3f}, 95 % "
        f"Wilson interval [{low:.3f}, {high:.3f}]). " + reference_verdict(checks, rows)
    )

    def describe(group: list[dict]) -> str:
        return ", ".join(f"{row['policy']} ({row['ATCT_s']:.2f} s, success {row['success_rate']:.3f})" for row in group)

    lost = [row for row in quicker if row["success_rate"] < 1.0]
    kept = [row for row in quicker if row["success_rate"] == 1.0]
    if lost:
        verdict += f" Constant speeds with a shorter ATCT that lost episodes: {describe(lost)}."
    if kept:
        verdict += f" Constant speeds with a shorter ATCT that lost none of these {episodes}: {describe(kept)}."
    after, before = safety["RL"], safety["untrained"]
    lines += [
        "",
        verdict,
        "",
        *front_lines(front),
        "### Safety (paper Fig. 7)",
        "",
        "| policy | force < " + f"{force_limit_pn:g} pN | handle within {distance_limit_um:g} um | "
        "median handle distance (um) | 99th percentile (um) | samples |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for name, values in (("before training (random speeds)", before), ("after training (RL)", after)):
        lines.append(
            f"| {name} | {values['force_below_limit']:.2%} | {values['distance_within_limit']:.2%} | "
            f"{values['distance_median_um']:.3f} | {values['distance_p99_um']:.3f} | {values['samples']} |"
        )
    lines += [
        "",
        f"Samples: every control step of the {episodes} episodes per policy (force per robot, distance "
        f"per handle). Paper: {PAPER_SAFETY}. Figure: `speed_control/safety.png`.",
        "",
    ]
    if not checks["distance_safe"]:
        lines += [
            f"The handle-distance limit of {distance_limit_um:g} um was kept in {after['distance_within_limit']:.1%} "
            f"of RL's steps and {before['distance_within_limit']:.1%} of the random speeds': in this run the "
            f"median handle sat {after['distance_median_um']:.3f} um from its trap under RL "
            f"({before['distance_median_um']:.3f} um under random speeds; 99th percentiles "
            f"{after['distance_p99_um']:.3f} and {before['distance_p99_um']:.3f} um)"
            + (
                ": the limit lies inside where the traps hold the handles at these speeds."
                if min(after["distance_median_um"], before["distance_median_um"]) > distance_limit_um
                else "."
            ),
            "",
        ]
    return lines


def whole_path_section(summary: dict) -> list[str]:
    """The whole path past the moving obstacles (``otgym.experiments.demo.whole_path``): per
    mode, the runs that reached the goal (with a 95 % Wilson interval), those that
    reached it untouched, the obstacles avoided of those met and the times, on the
    seeded scenarios it names."""
    scenarios = summary["scenarios"]
    named = f"scenario {scenarios[0]}" if len(scenarios) == 1 else f"scenarios {scenarios[0]}-{scenarios[-1]}"
    lines = [
        "## The whole path past the moving obstacles (interactive task)",
        "",
        f"The cell carried from the chip's start to its goal ({summary['route_length_um']:g} um of route) past "
        f"four obstacles that cross it, on {summary['runs']} seeded {named} (seed {summary['seed']}; "
        f"`--runs` sets how many), each run by the route follower at a constant {summary['speed_um_s']:g} um/s "
        f"(the paper's autonomous mode, blind to the obstacles) and by {summary['autonomy_text']}, in one batch; "
        f"trials cut at "
        f"{summary['time_limit_s']:g} s. An obstacle's touch does not end a trial, so the goals reached "
        f"untouched are counted apart.",
        "",
        "| autonomy | runs | goal reached [95 % CI] | goal reached untouched | obstacles avoided / met | "
        "touches | trap losses | time to goal (s) |",
        "|---|---:|---|---:|---:|---:|---:|---|",
    ]
    for row in summary["modes"]:
        low, high = wilson_interval(row["reached_goal"], row["runs"])
        times = ", ".join(f"{t:.1f}" for t in row["completion_times_s"]) or "-"
        lines.append(
            f"| {row['name']} | {row['runs']} | {row['reached_goal']} of {row['runs']} [{100 * low:.0f}, {100 * high:.0f} %] "
            f"| {row['reached_goal_clean']} of {row['runs']} | {row['obstacles_avoided']} / "
            f"{row['obstacles_encountered']} | {row['collisions']} | {row['trap_losses']} | {times} |"
        )
    lines += [
        "",
        f"{summary['runs']} run{'s' * (summary['runs'] > 1)} per autonomy "
        f"{'show' if summary['runs'] > 1 else 'shows'} the behaviour, not a rate: "
        f"{summary['measured_text']}. Files: "
        "`whole_path/trials.csv`, `whole_path/cells.csv`, figure `whole_path/whole_path.png`.",
        "",
    ]
    return lines


def _percent(value: float | None, spec: str = ".1f") -> str:
    return "-" if value is None else format(100 * value, spec)


def _pooled_success(row: dict) -> tuple[float | None, float, float]:
    """A mode's obstacles avoided / encountered, pooled over its trials, with its 95 %
    Wilson interval (None, NaN, NaN when it met no obstacle)."""
    encountered, avoided = int(row["obstacles_encountered"]), int(row["obstacles_avoided"])
    low, high = wilson_interval(avoided, encountered)
    return (avoided / encountered if encountered else None), low, high


def _goals(row: dict) -> str:
    """Goals reached of a mode's trials, with the rate's 95 % Wilson interval."""
    goals, trials = int(row["goals_reached"]), int(row["trials"])
    low, high = wilson_interval(goals, trials)
    return (
        f"{goals} of {trials} ({_percent(goals / trials, '.0f')} % [{_percent(low, '.0f')}, {_percent(high, '.0f')}])"
    )


def _study_design(size: dict) -> str:
    """What was run: participants, trials, scenarios and the cut, in one sentence."""
    participants, trials = size["participants"], size["trials_per_mode"]
    per_mode, scenarios = participants * trials, sorted(size["scenarios"])
    named = (
        f"scenario {scenarios[0]}"
        if len(scenarios) == 1
        else f"scenarios {scenarios[0]}-{scenarios[-1]}"
        if scenarios == list(range(scenarios[0], scenarios[-1] + 1))
        else "scenarios " + ", ".join(str(s) for s in scenarios)
    )
    if size.get("scenario_per_participant") and len(scenarios) > 1:
        where = (
            f"each participant on {'a seeded scenario' if trials == 1 else 'seeded scenarios'} of their own "
            f"({named}; every mode on the same, so the modes are compared within participant and scenario)"
        )
    else:
        where = (
            f"every mode with the same participants on the same "
            f"{'seeded scenario' if len(scenarios) == 1 else f'{len(scenarios)} seeded scenarios'} ({named})"
        )
    batch = ", all trials simulated together in one batch" if size.get("one_batch") else ""
    return (
        f"A small study that fits the demo's time: {participants} simulated participants x {trials} "
        f"trial{'s' * (trials > 1)} = {per_mode} trials per mode, {where}{batch}, each trial cut at "
        f"{size['time_limit_s']:g} s of simulated time. The scenarios are the full experiment's seeded ones in "
        f"order, not chosen by their outcome. The paper had 8 participants x 8 trials per mode; the full study "
        f"is `otgym experiment shared-control` (8 x 8, trials up to 300 s). With {per_mode} trials per mode "
        f"the intervals are wide: compare the ordering, not the values."
    )


def shared_control_section(modes: list[dict], size: dict, shipped: dict | None = None) -> list[str]:
    """The demo's small shared-control study beside the paper's Fig. 8, then the shipped
    full-size report runs (``shipped``: ``shipped_results.shipped_fig8()``; see
    ``shipped_results.fig8_lines``). ``modes``: the
    per-mode rows of ``summary.csv`` (``otgym.study.summarize``; None for NaN);
    ``size``: participants, trials_per_mode, time_limit_s, scenarios and optionally
    scenario_per_participant and one_batch (how ``run_experiment`` of
    ``otgym.experiments.shared_control.run`` ran it) and encounter_gap_um (the task's).
    Success is pooled over a mode's trials (obstacles avoided / encountered) with its
    95 % Wilson interval, as is the share of trials that reached the goal; time is the
    mean over participants of their trials that reached the goal. Every sentence is
    computed from these numbers."""
    limit = size["time_limit_s"]
    lines = [
        "## Shared control: manual, autonomous, shared (paper Fig. 8), a small study",
        "",
        _study_design(size),
        "",
        "| mode | trials | obstacles avoided / encountered | success % [95 % CI] | paper success % | "
        "reached the goal [95 % CI] | completion time (s) | paper time (s) | trap losses |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    rates = {}
    for row in modes:
        rate, low, high = _pooled_success(row)
        rates[row["mode"]] = (rate, low, high)
        paper = PAPER_FIG8.get(row["mode"])
        success = "- (no obstacle met)" if rate is None else f"{_percent(rate)} [{_percent(low)}, {_percent(high)}]"
        time_s = (
            "-"
            if row["completion_time_mean_s"] is None
            else (
                f"{row['completion_time_mean_s']:.1f}"
                + ("" if row["completion_time_sd_s"] is None else f" ± {row['completion_time_sd_s']:.1f}")
            )
        )
        paper_success = (
            "-"
            if paper is None
            else f"{_percent(paper['success_mean'], '.0f')} ± {_percent(paper['success_sd'], '.0f')}"
        )
        paper_time = "-" if paper is None else f"{paper['time_mean_s']:.1f} ± {paper['time_sd_s']:.1f}"
        lines.append(
            f"| {row['mode']} | {row['trials']} | {row['obstacles_avoided']} / "
            f"{row['obstacles_encountered']} | {success} | {paper_success} | {_goals(row)} | {time_s} | "
            f"{paper_time} | {row['trap_losses']} |"
        )
    lines += [
        "",
        *_success_sentences(rates),
        *_ending_sentences(modes, limit),
        *_time_sentences(modes, limit),
        "",
        "Success: obstacles avoided / encountered"
        + (
            f" (an obstacle counts as encountered once it comes within {size['encounter_gap_um']:g} um of the assembly)"
            if size.get("encounter_gap_um")
            else ""
        )
        + ", pooled over the mode's trials (the paper's metric), with 95 % Wilson "
        "intervals; these treat every obstacle as independent, but a trial's obstacles share its participant "
        "and scenario, so the true uncertainty is wider still. Reached the goal: trials, with the rate's 95 % "
        "Wilson interval. Completion time: mean ± SD over participants of their trials that reached "
        "the goal. Paper: Sec. III-C, mean ± SD. Files: `shared_control/trials.csv` (one row per trial), "
        "`summary.md` (with the repeated-measures ANOVA and Holm-corrected paired tests, of little power "
        f"with {size['participants']} participants), `stats.json`, `fig8.png`, `acceptance.json` (the "
        "paper's ordering, checked on this small sample).",
        "",
    ]
    return lines + fig8_lines(shipped)


def _success_sentences(rates: dict) -> list[str]:
    measured = sorted(
        ((mode, value) for mode, value in rates.items() if value[0] is not None), key=lambda item: -item[1][0]
    )
    if not measured:
        return ["No trial met an obstacle before it ended, so success is undefined here."]

    def ordering(pairs):
        text = ""
        for index, (mode, rate) in enumerate(pairs):
            if index:
                text += " = " if rate == pairs[index - 1][1] else " > "
            text += f"{mode} {_percent(rate, '.0f')} %"
        return text

    ours = ordering([(mode, rate) for mode, (rate, _, _) in measured])
    paper_order = sorted((mode for mode in rates if mode in PAPER_FIG8), key=lambda m: -PAPER_FIG8[m]["success_mean"])
    paper = ordering([(mode, PAPER_FIG8[mode]["success_mean"]) for mode in paper_order])
    text = f"Success ordering here: {ours}; the paper's: {paper}."
    separated = [
        f"{a} and {b}"
        for i, (a, (_, low_a, high_a)) in enumerate(measured)
        for b, (_, low_b, high_b) in measured[i + 1 :]
        if low_a > high_b or low_b > high_a
    ]
    if len(measured) > 1:
        text += (
            " The 95 % intervals of every pair of modes overlap: this sample does not separate them."
            if not separated
            else f" Separated by their 95 % intervals: {', '.join(separated)}."
        )
    unmet = [mode for mode, value in rates.items() if value[0] is None]
    if unmet:
        text += f" {', '.join(unmet).capitalize()}: no obstacle met before the trials ended, so no success rate."
    return [text]


def _ending_sentences(modes: list[dict], limit: float) -> list[str]:
    """How the trials of each mode that did not all reach the goal ended: a trap lost its
    robot (which ends a trial) or still on the way at the cut."""
    parts = []
    for row in modes:
        trials, goals, lost = int(row["trials"]), int(row["goals_reached"]), int(row["trap_losses"])
        if goals == trials:
            continue
        cut = trials - goals - lost
        endings = [f"{goals} reached the goal"] if goals else []
        if lost:
            endings.append(f"{lost} ended early when a trap lost its robot")
        if cut:
            endings.append(f"{cut} {'was' if cut == 1 else 'were'} still on the way at the {limit:g} s cut")
        text = f"{row['mode'].capitalize()}: of {trials} trials, " + ", ".join(endings)
        paper = PAPER_FIG8.get(row["mode"])
        if cut and paper is not None and paper["time_mean_s"] > limit:
            text += f" (the paper's {row['mode']} trials took {paper['time_mean_s']:g} s on average)"
        if cut or lost:
            text += "; its success counts only the obstacles met before the trials ended"
        parts.append(text + ".")
    return [" ".join(parts)] if parts else []


def _time_sentences(modes: list[dict], limit: float) -> list[str]:
    if not any(row["goals_reached"] for row in modes):
        return [
            f"No trial reached the goal within the {limit:g} s limit, so there is no completion time to set "
            f"beside the paper's; the full study has them."
        ]
    timed = [row for row in modes if row["completion_time_mean_s"] is not None and row["mode"] in PAPER_FIG8]
    text = (
        "Completion time against the paper's: "
        + ", ".join(
            f"{row['mode']} {row['completion_time_mean_s']:.1f} s against {PAPER_FIG8[row['mode']]['time_mean_s']:g} s "
            f"({row['completion_time_mean_s'] / PAPER_FIG8[row['mode']]['time_mean_s']:.2f} x)"
            for row in timed
        )
        + "."
    )
    if not timed:
        text = ""
    cut = [
        row["mode"]
        for row in modes
        if row["completion_time_mean_s"] is not None
        and int(row["trials"]) - int(row["goals_reached"]) - int(row["trap_losses"]) > 0
    ]
    if cut:
        text += (
            f" Trials of {', '.join(cut)} still running at {limit:g} s are left out of the times, which "
            f"favours the fast ones."
        )
    return [text.strip()] if text.strip() else []


def write_report(path: Path, sections: list[list[str]], header: str) -> Path:
    path = Path(path)
    lines = ["# otgym demo report", "", header, ""]
    for section in sections:
        lines += section
    path.write_text("\n".join(lines))
    return path
