"""``otgym experiment human-sensitivity``: which assumed parameters of the simulated
participants (``otgym.human.assumptions.ASSUMPTIONS``, every one of them) decide Fig. 8's
items (b) and (d), by global sensitivity analysis with SALib (Herman & Usher, J. Open
Source Softw. 2, 97, 2017; Iwanaga, Usher & Herman, Socio-Environ. Syst. Model. 4,
18155, 2022): Morris screening (elementary effects, Campolongo, Cariboni & Saltelli,
Environ. Model. Softw. 22, 1509, 2007: mu*, the mean absolute effect, and sigma, its
spread) over all of them, then Sobol indices (Saltelli et al., Comput. Phys. Commun.
181, 259, 2010: first-order S1 and total ST, with bootstrap intervals) over the few
that matter.

Each sample of the design (a point in the parameters' plausible ranges, each uniform
over its range) runs both modes, manual and shared (over the route navigator), for the
same ``participants`` x ``trials``. Common random numbers: participant p of every sample
is drawn from the same stream (``sample_population(participants, seed)``: the same
standard-normal draws, scaled by the sample's means and spreads) and meets the same
scenarios (trial t: ``seed * 10000 + p * trials + t``); the hands' motor noise and the
physics' noise are drawn per batch (random seed ``seed``) and are not common. All
samples run as one batch (``run_trials(participant_tasks=..., display_latency_s=...)``).

Outputs per sample (``sample_outputs``): (b) = manual mean time to the goal / shared
mean time to the goal (a trial still running at the limit extrapolated at the pace it
kept, one that ended by a trap loss left out: ``time_to_goal_s``; so a development run
may cut its trials short), and (d) = shared success mean - manual success mean
(success: obstacles avoided / met, pooled per participant), as ``otgym experiment
shared-control`` judges them. A ``dummy`` parameter that the model never reads is
sampled with the others: its index is what noise alone gives (Khorashadi Zadeh et al.,
Environ. Model. Softw. 91, 210, 2017).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence

import numpy as np
import pandas as pd

from otgym.experiments.common.progress import tenths
from otgym.experiments.human_sensitivity.config import CONFIDENCE, DUMMY, MODES, MORRIS_LEVELS, OUTPUTS, RESAMPLES
from otgym.human.assumptions import by_label
from otgym.human.params import POPULATION_CV, HumanParams, sample_population
from otgym.human.participant_task import ParticipantTask
from otgym.human.percept import DISPLAY_LATENCY_S
from otgym.runtime.trials import TrialSpec, run_trials
from otgym.study.stats import participant_means
from otgym.task.task import InteractiveConfig, InteractiveTask


def problem(labels: Sequence[str]) -> dict:
    """The SALib problem: each label's plausible range, then ``DUMMY`` on [0, 1]."""
    table = by_label()
    return {
        "num_vars": len(labels) + 1,
        "names": list(labels) + [DUMMY],
        "bounds": [[table[label].low, table[label].high] for label in labels] + [[0.0, 1.0]],
    }


def design(method: str, labels: Sequence[str], size: int, seed: int) -> np.ndarray:
    """The samples (n, len(labels) + 1): Morris, ``size`` trajectories of
    ``MORRIS_LEVELS`` levels (n = size * (k + 1)); Sobol, Saltelli's scheme for first
    and total indices over a scrambled Sobol sequence of ``size`` (n = size * (k + 2))."""
    from SALib.sample import morris, sobol

    spec = problem(labels)
    if method == "morris":
        return morris.sample(spec, size, num_levels=MORRIS_LEVELS, seed=seed)
    return sobol.sample(spec, size, calc_second_order=False, seed=seed)


def sample_settings(row: np.ndarray, labels: Sequence[str]):
    """One sample's model: (the population's means ``HumanParams``, its coefficients of
    variation, the ``ParticipantTask``, the window's latency in s); the parameters not
    in ``labels`` at the model's values."""
    table = by_label()
    values = {kind: {} for kind in ("motor", "spread", "task", "window")}
    for label, value in zip(labels, row):
        values[table[label].kind][table[label].name] = float(value)
    mean = dataclasses.replace(HumanParams(), **values["motor"])
    cv = {**POPULATION_CV, **values["spread"]}
    task = dataclasses.replace(ParticipantTask(), **values["task"])
    return mean, cv, task, values["window"].get("display_latency_s", DISPLAY_LATENCY_S)


def run_design(
    samples: np.ndarray,
    labels: Sequence[str],
    participants: int,
    trials: int,
    seed: int,
    report: Callable[[str], None] = print,
    time_limit_s: float = 300.0,
    config: InteractiveConfig | None = None,
) -> pd.DataFrame:
    """Every sample's trials, one batch: one row per trial (``run_trials``' columns,
    ``participant`` numbered within its sample) with ``sample``, ``arc_reached_um`` (the
    farthest the cell came along the route until the trial ended) and ``route_um`` (its length). ``config``: the task
    (default: the study's, with ``time_limit_s``)."""
    people, specs, tasks, latencies = {}, [], [], []
    for s, row in enumerate(samples):
        mean, cv, task, latency = sample_settings(row, labels)
        for p, person in enumerate(sample_population(participants, seed, mean=mean, cv=cv)):
            key = s * participants + p
            people[key] = person
            for mode in MODES:
                for t in range(trials):
                    specs.append(TrialSpec(key, mode, t, seed * 10_000 + p * trials + t))
                    tasks.append(task)
                    latencies.append(latency)
    report(
        f"{len(samples)} samples x {participants} participants x {trials} trials x {len(MODES)} modes: "
        f"{len(specs)} trials in one batch"
    )
    task = InteractiveTask(config or InteractiveConfig(time_limit_s=time_limit_s))
    reached, ended = np.zeros(len(specs)), np.zeros(len(specs), bool)

    def farthest(view) -> None:  # how far along the route each trial's cell came until its trial ended
        arc = np.asarray(view.obs.cell_arc_um, float)
        reached[~ended] = np.maximum(reached[~ended], arc[~ended])
        ended[:] |= np.asarray(view.state.metrics.done, bool)

    rows = pd.DataFrame(
        run_trials(
            task,
            specs,
            people,
            seed,
            progress=tenths(report),
            participant_tasks=tasks,
            display_latency_s=np.array(latencies),
            recorder=farthest,
        )
    )
    rows["arc_reached_um"] = reached
    rows["route_um"] = float(task.route_arc_um[-1])
    rows.insert(0, "sample", rows.participant // participants)
    rows["participant"] = rows.participant % participants
    return rows


def time_to_goal_s(trials: pd.DataFrame, time_limit_s: float) -> pd.Series:
    """Each trial's time to the goal: its completion time where it reached the goal;
    for a trial still running at ``time_limit_s`` (cut short, or stalled) that time
    extrapolated at the pace it kept along the route, time x route / farthest arc
    reached (at least 1 um), so that it weighs by how far it got; NaN for a trial that
    ended without reaching the goal (a trap loss: left out, as ``otgym experiment
    shared-control`` leaves it out)."""
    done_s = trials.completion_time_s
    running = ~trials.reached_goal.astype(bool) & ~(done_s < time_limit_s - 0.5)  # ran to the limit (or NaN)
    extrapolated = time_limit_s * trials.route_um / trials.arc_reached_um.clip(lower=1.0)
    time = trials.completion_time_s.where(trials.reached_goal.astype(bool), np.nan)
    return time.where(~running, extrapolated)


def sample_outputs(trials: pd.DataFrame, n_samples: int, time_limit_s: float) -> pd.DataFrame:
    """Per sample, each mode's time and success, (b) and (d), as ``otgym experiment
    shared-control`` forms them (means over participants of each participant's value,
    ``otgym.study.stats.participant_means``: success pooled over their trials) except
    that a trial still running at the limit counts at its extrapolated time to the goal
    (``time_to_goal_s``), so that a stall or a cut weighs. NaN where a mode met no
    obstacle, or had no trial with a time."""
    time = time_to_goal_s(trials, time_limit_s)
    frame = trials.assign(completion_time_s=time, reached_goal=np.isfinite(time))
    out = pd.DataFrame(index=pd.RangeIndex(n_samples, name="sample"))
    for metric, column in (("time", "time_s"), ("success", "success")):
        values = []
        for sample in range(n_samples):
            mine = frame[frame["sample"] == sample]
            means = participant_means(mine, metric).groupby("mode").value.mean() if len(mine) else pd.Series()
            values.append(means)
        for mode in MODES:
            out[f"{mode}_{column}"] = [float(v.get(mode, math.nan)) for v in values]
    out["b"] = out.manual_time_s / out.shared_time_s
    out["d"] = out.shared_success - out.manual_success
    return out.reset_index()


def analyse(method: str, samples: np.ndarray, outputs: pd.DataFrame, labels: Sequence[str], seed: int) -> pd.DataFrame:
    """The indices of every parameter (and ``DUMMY``) for each of ``OUTPUTS``: Morris'
    mu*, its ``CONFIDENCE`` bootstrap half-width, mu and sigma; or Sobol's S1 and ST with
    their half-widths. A sample's NaN output is replaced by the mean of the others (its
    count in ``imputed``)."""
    from SALib.analyze import morris, sobol

    spec = problem(labels)
    rows = []
    for item in OUTPUTS:
        y = outputs[item].to_numpy(float)
        missing = ~np.isfinite(y)
        y = np.where(missing, np.nanmean(y) if (~missing).any() else 0.0, y)
        if method == "morris":
            result = morris.analyze(
                spec, samples, y, num_resamples=RESAMPLES, conf_level=CONFIDENCE, num_levels=MORRIS_LEVELS, seed=seed
            )
            columns = {"mu_star": "mu_star", "mu_star_conf": "mu_star_conf", "mu": "mu", "sigma": "sigma"}
        else:
            result = sobol.analyze(
                spec, y, calc_second_order=False, num_resamples=RESAMPLES, conf_level=CONFIDENCE, seed=seed
            )
            columns = {"S1": "s1", "S1_conf": "s1_conf", "ST": "st", "ST_conf": "st_conf"}
        for i, name in enumerate(spec["names"]):
            row = {"item": item, "parameter": name, "imputed": int(missing.sum())}
            row.update({ours: float(np.asarray(result[theirs])[i]) for theirs, ours in columns.items()})
            rows.append(row)
    frame = pd.DataFrame(rows)
    key = "mu_star" if method == "morris" else "st"
    frame["rank"] = frame.groupby("item")[key].rank(ascending=False, method="first").astype(int)
    return frame.sort_values(["item", "rank"]).reset_index(drop=True)


def deciding(indices: pd.DataFrame, count: int = 3) -> dict[str, list[str]]:
    """Per item, the (at most) ``count`` parameters with the largest index (mu* or ST)
    above the dummy's (what noise alone gives), largest first."""
    key = "mu_star" if "mu_star" in indices else "st"
    chosen = {}
    for item, rows in indices.groupby("item"):
        floor = float(rows.loc[rows.parameter == DUMMY, key].max()) if (rows.parameter == DUMMY).any() else -np.inf
        above = rows[(rows.parameter != DUMMY) & (rows[key] > floor)]
        chosen[item] = list(above.sort_values(key, ascending=False).parameter[:count])
    return chosen
