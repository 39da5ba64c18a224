"""``otgym experiment human-sensitivity``: how much Fig. 8's item (d), "shared control
avoids at least as many obstacles as manual", moves when each assumed parameter of the
simulated participants moves by -50 % and +50 %.

(d) is shared control's success mean minus manual control's (success: obstacles avoided
/ obstacles met, per trial; a trial that met none has no success and is left out), as
``otgym experiment shared-control`` judges it. Here it is computed per participant
(their trials' mean per mode, shared minus manual) and averaged over participants, with
a t interval over participants (95 %); the move of (d) from the baseline is paired by
participant (the same participant and scenarios at 1x and at the scaled value).

Every variant runs both modes (shared over the route navigator) for the same
participants (``sample_population(participants, seed)``, each with its drawn spread
around the scaled means) on the same scenarios (participant p's trial t:
``seed * 10000 + p * trials + t``, as ``run_experiment(scenario_per_participant=True)``),
random seed ``seed``. All variants run as one batch: motor parameters (``HumanParams``)
and the population's spread vary between participants anyway, and task parameters
(``ParticipantTask``) per trial through ``otgym.human.participant_groups``.

Writes sensitivity.csv (one row per parameter and scale), sensitivity.md (the table,
the seed's status, the command) and sensitivity.png (each parameter's (d) at 0.5x, 1x,
1.5x with its interval) and trials.csv (every trial, with its ``variant``).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import stats

from otgym.experiments.progress import tenths
from otgym.human.params import POPULATION_CV, HumanParams, sample_population, scaled
from otgym.human.participant_task import ParticipantTask
from otgym.runtime.trials import TrialSpec, run_trials
from otgym.task.task import InteractiveConfig, InteractiveTask

MODES = ("manual", "shared")
SCALES = (0.5, 1.5)
"""The factors each assumed parameter is scaled by (the baseline, 1x, runs once)."""

POPULATION_SPREAD = "population_cv"
"""The name of one variant: every assumed between-participant coefficient of variation
(``ASSUMED_CV``) scaled together."""

ASSUMED_MOTOR = ("correction_jitter_fraction", "signal_dependent_noise", "preferred_speed_mm_s")
"""``HumanParams`` fields with no measured value (``otgym.human.params``' docstring)."""

ASSUMED_CV = tuple(name for name in POPULATION_CV if name not in ("lapse_rate_per_h", "lapse_duration_s"))
"""The population's coefficients of variation that are assumed (the lapses' are Peiris et al.'s)."""

ASSUMED_TASK = tuple(field.name for field in dataclasses.fields(ParticipantTask) if field.name != "bimanual")
"""``ParticipantTask`` fields: none has a literature value (the geometric ones carry an
assumed margin; the reasons for the others: docs/decisions/0041-0045); ``bimanual`` is
the paper's set-up, not a parameter."""

ASSUMED = ASSUMED_MOTOR + (POPULATION_SPREAD,) + ASSUMED_TASK
"""Every assumed parameter, in the order the command runs and reports them."""


GROUPS = {
    "all": ASSUMED,
    "motor": ASSUMED_MOTOR + (POPULATION_SPREAD,),
    "task": ASSUMED_TASK,
}
"""Names for sets of parameters. ``motor`` runs as one group of participants; each task
parameter's scale adds a group (``otgym.human.participant_groups``) whose per-tick cost
is the participants' own again: ``all`` (39 groups) spent 0.35 s of CPU per 20 ms tick
at 3 participants x 1 trial on 2 shared cores, about 45 minutes for a study's trials."""


def parse_parameters(text: str) -> list[str]:
    """A name from ``GROUPS`` or comma-separated names from ``ASSUMED`` (each once)."""
    if text.strip() in GROUPS:
        return list(GROUPS[text.strip()])
    names = [name.strip() for name in text.split(",") if name.strip()]
    unknown = [name for name in names if name not in ASSUMED]
    if unknown or not names:
        raise ValueError(
            f"unknown parameter(s) {', '.join(unknown) or '(none)'}; {', '.join(GROUPS)} or names from: "
            f"{', '.join(ASSUMED)}"
        )
    if len(set(names)) != len(names):
        raise ValueError(f"--parameters names a parameter twice: {text}")
    return names


def check_arguments(participants: int, trials: int, seed: int) -> None:
    """Refuse bad sizes before any work or any file."""
    if participants < 2:
        raise ValueError(f"--participants must be at least 2 (the interval is over participants), got {participants}")
    if trials < 1:
        raise ValueError(f"--trials must be at least 1, got {trials}")
    if not 0 <= seed < 2**32:
        raise ValueError(f"--seed must lie in [0, 2**32), got {seed}")


def _population(participants: int, seed: int, parameter: str | None, factor: float) -> list[HumanParams]:
    if parameter == POPULATION_SPREAD:
        cv = {name: value * (factor if name in ASSUMED_CV else 1.0) for name, value in POPULATION_CV.items()}
        return sample_population(participants, seed, cv=cv)
    scale = {parameter: factor} if parameter in ASSUMED_MOTOR else None
    return sample_population(participants, seed, scale=scale)


def variants(parameters: Sequence[str]) -> list[tuple[str, float]]:
    """(parameter, factor) of every variant: the baseline at 1x, then each parameter at
    each of ``SCALES``."""
    return [("baseline", 1.0)] + [(name, factor) for name in parameters for factor in SCALES]


def run_sensitivity(
    parameters: Sequence[str],
    participants: int,
    trials: int,
    seed: int,
    report: Callable[[str], None] = print,
    time_limit_s: float = 300.0,
) -> pd.DataFrame:
    """Every trial of the baseline and of each parameter at each of ``SCALES``, in one
    batch (each trial's participant with its variant's motor parameters and task
    parameters: ``run_trials(participant_tasks=...)``): one row per trial
    (``run_trials``' columns, ``participant`` numbered within its variant) with
    ``variant``, ``parameter`` (``baseline`` for 1x) and ``scale``."""
    check_arguments(participants, trials, seed)
    unknown = [name for name in parameters if name not in ASSUMED]
    if unknown:
        raise ValueError(f"unknown parameter(s) {', '.join(unknown)}")
    task = InteractiveTask(InteractiveConfig(time_limit_s=time_limit_s))
    people, specs, tasks, labels = {}, [], [], {}
    for v, (name, factor) in enumerate(variants(parameters)):
        task_variant = name in ASSUMED_TASK
        participant_task = scaled(ParticipantTask(), {name: factor}) if task_variant else ParticipantTask()
        population = _population(participants, seed, None if task_variant or name == "baseline" else name, factor)
        for p, person in enumerate(population):
            key = v * participants + p
            people[key] = person
            labels[key] = (name, factor, p)
            for mode in MODES:
                for t in range(trials):
                    specs.append(TrialSpec(key, mode, t, seed * 10_000 + p * trials + t))
                    tasks.append(participant_task)
    report(
        f"{len(variants(parameters))} variants (baseline and {len(parameters)} parameters x {len(SCALES)} scales) "
        f"x {participants} participants x {trials} trials x {len(MODES)} modes: {len(specs)} trials in one batch"
    )
    rows = pd.DataFrame(run_trials(task, specs, people, seed, progress=tenths(report), participant_tasks=tasks))
    rows.insert(0, "parameter", [labels[key][0] for key in rows.participant])
    rows.insert(1, "scale", [labels[key][1] for key in rows.participant])
    rows["participant"] = [labels[key][2] for key in rows.participant]
    rows.insert(0, "variant", [f"{name} x{factor:g}" for name, factor in zip(rows.parameter, rows.scale)])
    return rows


def _mean_ci(values: np.ndarray) -> tuple[float, float, float]:
    """Mean and 95 % t interval over the finite ``values`` (NaN bounds with fewer than 2)."""
    values = values[np.isfinite(values)]
    if len(values) == 0:
        return math.nan, math.nan, math.nan
    mean = float(values.mean())
    if len(values) < 2:
        return mean, math.nan, math.nan
    half = float(stats.t.ppf(0.975, len(values) - 1) * values.std(ddof=1) / math.sqrt(len(values)))
    return mean, mean - half, mean + half


def per_participant(trials: pd.DataFrame) -> pd.DataFrame:
    """Per variant and participant: each mode's success mean and (d) = shared - manual."""
    means = trials.groupby(["parameter", "scale", "participant", "mode"]).success.mean().unstack("mode")
    for mode in MODES:
        if mode not in means:
            means[mode] = math.nan
    means["d"] = means["shared"] - means["manual"]
    return means.reset_index()


def summarise(trials: pd.DataFrame) -> pd.DataFrame:
    """sensitivity.csv: per parameter and scale (the baseline's row under every
    parameter at 1x), the mean success of each mode, (d) with its 95 % t interval over
    participants, and its move from the baseline, paired by participant."""
    people = per_participant(trials)
    base = people[people.parameter == "baseline"].set_index("participant")
    parameters = [name for name in dict.fromkeys(trials.parameter) if name != "baseline"]
    rows = []
    for name in parameters or ["baseline"]:
        for factor in (SCALES[0], 1.0, SCALES[1]) if parameters else (1.0,):
            rows_of = (
                base.reset_index() if factor == 1.0 else people[(people.parameter == name) & (people.scale == factor)]
            )
            if rows_of.empty:
                continue
            d, low, high = _mean_ci(rows_of.d.to_numpy(float))
            move = rows_of.set_index("participant").d - base.d
            move_mean, move_low, move_high = _mean_ci(move.to_numpy(float))
            mine = trials[(trials.parameter == ("baseline" if factor == 1.0 else name)) & (trials.scale == factor)]
            rows.append(
                {
                    "parameter": name,
                    "scale": factor,
                    "participants": int(np.isfinite(rows_of.d.to_numpy(float)).sum()),
                    "trials_per_mode": int((mine["mode"] == MODES[0]).sum()),
                    "manual_success": float(rows_of.manual.mean()),
                    "shared_success": float(rows_of.shared.mean()),
                    "d": d,
                    "d_ci_low": low,
                    "d_ci_high": high,
                    "d_move": move_mean,
                    "d_move_ci_low": move_low,
                    "d_move_ci_high": move_high,
                }
            )
    return pd.DataFrame(rows)


def write_sensitivity(trials: pd.DataFrame, out: Path, command: str, note: str | None) -> pd.DataFrame:
    """Write trials.csv, sensitivity.csv, sensitivity.md and sensitivity.png; return the summary."""
    out.mkdir(parents=True, exist_ok=True)
    trials.to_csv(out / "trials.csv", index=False)
    summary = summarise(trials)
    summary.to_csv(out / "sensitivity.csv", index=False)
    (out / "sensitivity.md").write_text(_markdown(summary, command, note))
    _plot(summary, out / "sensitivity.png")
    return summary


def _number(value: float, digits: int = 3) -> str:
    return "n/a" if not math.isfinite(value) else f"{value:+.{digits}f}"


def _markdown(summary: pd.DataFrame, command: str, note: str | None) -> str:
    lines = [f"**{note}.**", ""] if note else []
    n = int(summary.participants.max()) if len(summary) else 0
    lines += [
        "# Sensitivity of (d) to the simulated participants' assumed parameters",
        "",
        f"Made by `{command}`. (d) = shared success mean - manual success mean (success: obstacles "
        f"avoided / met); mean over {n} participants with a 95 % t interval over participants; "
        "the move from 1x is paired by participant.",
        "",
        "| parameter | scale | manual success | shared success | (d) [95 % CI] | move of (d) [95 % CI] |",
        "|---|---|---|---|---|---|",
    ]
    for row in summary.itertuples():
        move = (
            "0 (baseline)"
            if row.scale == 1.0
            else f"{_number(row.d_move)} [{_number(row.d_move_ci_low)}, {_number(row.d_move_ci_high)}]"
        )
        lines.append(
            f"| {row.parameter} | {row.scale:g}x | {row.manual_success:.3f} | {row.shared_success:.3f} | "
            f"{_number(row.d)} [{_number(row.d_ci_low)}, {_number(row.d_ci_high)}] | {move} |"
        )
    return "\n".join(lines) + "\n"


def _plot(summary: pd.DataFrame, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(dict.fromkeys(summary.parameter))
    fig, ax = plt.subplots(figsize=(7.0, 0.45 * len(names) + 1.5))
    offsets = {SCALES[0]: -0.2, 1.0: 0.0, SCALES[1]: 0.2}
    colours = {SCALES[0]: "tab:blue", 1.0: "black", SCALES[1]: "tab:red"}
    for factor, offset in offsets.items():
        rows = summary[summary.scale == factor]
        y = np.array([names.index(name) for name in rows.parameter]) + offset
        low = (rows.d - rows.d_ci_low).fillna(0.0).to_numpy()
        high = (rows.d_ci_high - rows.d).fillna(0.0).to_numpy()
        ax.errorbar(rows.d, y, xerr=[low, high], fmt="o", ms=4, color=colours[factor], label=f"{factor:g}x")
    ax.axvline(0.0, color="grey", lw=0.8)
    ax.set_yticks(range(len(names)), names)
    ax.invert_yaxis()
    ax.set_xlabel("(d) = shared - manual success mean (95 % CI over participants)")
    ax.legend(loc="lower right", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
