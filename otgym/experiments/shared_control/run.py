"""The trials of ``otgym experiment shared-control`` (the paper's manual / autonomous /
shared experiment, section III-C, Fig. 8 a-b) with simulated participants: every mode
for every participant on the same seeded scenarios (trial t of every participant and
mode meets scenario ``seed * 10000 + t``). Beside the paper's three modes, every
registered navigator tagged ``trial-mode`` is a mode (``mpc``: the model-predictive
navigator alone, no participant acts; ``rl``: the learned speed), and shared control may
blend with any navigator tagged ``shared`` (``shared_autonomy``). The files and the
acceptance: ``otgym.experiments.shared_control.report``."""

from __future__ import annotations

from collections.abc import Callable, Mapping

import pandas as pd

from otgym.experiments.common.progress import tenths
from otgym.experiments.shared_control.config import check_arguments
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
