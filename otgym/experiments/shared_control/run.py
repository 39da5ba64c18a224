"""The trials of ``otgym experiment shared-control`` (the paper's manual / autonomous /
shared experiment, section III-C, Fig. 8 a-b) with simulated participants: every mode
for every participant on the same seeded scenarios (trial t of every participant and
mode meets scenario ``seed * 10000 + t``). Beside the paper's three modes, every
registered navigator tagged ``trial-mode`` is a mode (``mpc``: the model-predictive
navigator alone, no participant acts; ``rl``: the learned speed), and shared control may
blend with any navigator tagged ``shared`` (``shared_autonomy``). ``run_study`` is the
whole command: the trials, the route bound, the files and the acceptance
(``otgym.experiments.shared_control.report``)."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path

import pandas as pd

from otgym.experiments.common.progress import tenths
from otgym.experiments.shared_control.config import SharedControlConfig, check_arguments
from otgym.human.params import sample_population
from otgym.runtime.trace import TraceRecorder
from otgym.runtime.trials import TRIAL_COLUMNS, TrialSpec, run_trials, shared_autonomies
from otgym.task.task import InteractiveConfig, InteractiveTask


def run_experiment(
    participants: int,
    trials: int,
    modes: list[str],
    seed: int,
    chip: str = "default",
    report: Callable[[str], None] = print,
    time_limit_s: float = 300.0,
    shared_autonomy: str = "route",
    navigator_config: Mapping[str, Mapping] | None = None,
    navigator_stats: dict | None = None,
    one_batch: bool = False,
    scenario_per_participant: bool = False,
    trace: tuple[int, int] | None = None,
    traces: dict | None = None,
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
    many scenarios as it has trials per mode. Each mode's navigator is built by its
    registry name with its own options from ``navigator_config`` (name -> keywords of
    its ``for_task``: ``otgym.runtime.trials.run_trials``). ``navigator_stats`` (a dict)
    receives, per batch (keyed by its modes, joined by ``+``), what its navigators said
    of their work (the MPC: its replan statistics), where any did.
    ``trace`` (participant, trial) records that trial tick by tick in every mode
    (``otgym.runtime.trace``): ``traces`` (a dict) receives a DataFrame per mode."""
    check_arguments(participants, trials, seed)
    autonomies = shared_autonomies()
    if shared_autonomy not in autonomies:
        raise ValueError(f"--shared-autonomy must be one of {', '.join(autonomies)}, got {shared_autonomy!r}")
    from otgym.tasks.transport.interactive import interactive_scene

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
        stats = {}
        traced = {i: spec.mode for i, spec in enumerate(specs) if trace == (spec.participant, spec.trial)}
        recorder = TraceRecorder(traced) if traced else None
        rows += run_trials(
            task,
            specs,
            people,
            seed=seed + index,
            progress=tenths(report, name),
            shared_autonomy=shared_autonomy,
            navigator_config=navigator_config,
            navigator_stats=stats,
            recorder=recorder,
        )
        if recorder is not None and traces is not None:
            traces.update({mode: pd.DataFrame(recorder.rows[env]) for env, mode in traced.items()})
        if stats and navigator_stats is not None:
            navigator_stats[name] = stats
    frame = pd.DataFrame(rows)
    return frame[TRIAL_COLUMNS + [c for c in frame.columns if c not in TRIAL_COLUMNS]]


def run_study(config: SharedControlConfig, out: Path, report: Callable[[str], None] = print) -> dict:
    """``otgym experiment shared-control`` after its checks: the trials
    (``run_experiment``, one batch per mode), the route-keeping bound on the same
    scenarios where shared and autonomous both ran (route_bound.csv/.json/.md), the
    files and their acceptance (``report.write_experiment``; mpc.json where the MPC
    ran), each report file marked with its seed's status, and the traced trial's files.
    Progress goes to ``report``. Returns ``checks`` (the acceptance), ``note`` (the
    development-seed note, or None), ``written`` (the files' names) and ``traced`` (the
    trace files)."""
    from otgym.autonomy.mpc import MPCConfig
    from otgym.experiments.common.seeds import development_note, mark_report_files
    from otgym.experiments.shared_control.report import mpc_summary, write_experiment

    note = development_note("shared-control", config.seed, trials=config.trials)
    if note:
        report(note)
    stats, traces = {}, {}
    frame = run_experiment(
        config.participants,
        config.trials,
        list(config.modes),
        config.seed,
        config.chip,
        report=report,
        time_limit_s=config.time_limit_s,
        shared_autonomy=config.shared_autonomy,
        navigator_config=config.navigator_config,
        navigator_stats=stats,
        trace=config.trace,
        traces=traces,
    )
    written = ["trials.csv", "summary.csv", "summary.md", "stats.json", "fig8.png", "acceptance.json"]
    route_bound_s = None
    if "shared" in config.modes and "autonomous" in config.modes:
        from otgym.experiments.shared_control.route_bound import ROUTE_SPEED_UM_S, run_route_bound, write_route_bound

        report("route-keeping bound (the earliest passage on these scenarios, perfect foresight):")
        bound_frame = run_route_bound(config.trials, config.seed, [ROUTE_SPEED_UM_S], config.chip, report=report)
        best = write_route_bound(bound_frame, out)[f"{ROUTE_SPEED_UM_S:g}"]
        route_bound_s = float(best["earliest_mean_s"])
        report(
            f"      at {ROUTE_SPEED_UM_S:g} um/s: {best['earliest_mean_s']:.1f} s on average, "
            f"{best['earliest_over_free']:.3f}x the unobstructed route (see route_bound.md)"
        )
        mark_report_files("route-bound", config.seed, [out / "route_bound.md"], trials=config.trials)
    mpc_config = config.navigator_config.get("mpc", {}).get("config", MPCConfig())
    mpc = mpc_summary(stats, mpc_config, InteractiveConfig().tick_s)
    checks = write_experiment(frame, out, mpc, route_bound_s=route_bound_s, shared_autonomy=config.shared_autonomy)
    mark_report_files(
        "shared-control", config.seed, [out / "summary.md"], [out / "acceptance.json"], trials=config.trials
    )
    if mpc:
        written.append("mpc.json")
    if route_bound_s is not None:
        written.append("route_bound.csv/.json/.md")
    traced = []
    if config.trace is not None:
        from otgym.experiments.shared_control.trace_files import write_traces

        traced = write_traces(traces, out, *config.trace)
    return {"checks": checks, "note": note, "written": written, "traced": traced}
