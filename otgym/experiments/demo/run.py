"""The main job, ``otgym demo``: the paper's pipeline end to end on the default chip,
headless, at small sizes (the time it takes on two CPU cores is in the README), most
of it the study.

1. ``plan/``: A* + B-spline on the chip image against a simulated manual path
   (Table I, ``otgym.planning``).
2. ``speed_control/``: the shipped DQN speed controller against the six constant
   speeds on the same seeded episodes of the ``paper`` preset (Table II and the safety
   violins of Fig. 7, ``otgym.experiments.speed_control.evaluate``); the demo runs
   ``DEMO_EPISODES`` episodes per policy, ``otgym evaluate`` the full 256.
3. ``whole_path/``: the cell carried from the chip's start to its goal past the
   interactive task's moving obstacles by the autonomy otgym recommends (the learned
   speed; ``--autonomy mpc``: the MPC) beside the constant-speed route follower, on the
   same seeded scenarios (``otgym.experiments.demo.whole_path``).
4. ``shared_control/``: a small manual / autonomous / shared study with simulated
   participants (the paper's Fig. 8; ``otgym.experiments.shared_control.run``, whose full
   size is ``otgym experiment shared-control``), its trials cut at 90 s of simulated
   time: long enough to meet the obstacles and for the autonomous and shared trials to
   reach the goal (``StudyConfig``).
5. ``report.md``: our numbers beside the paper's, with every sample size.

Every size is checked against its range (``SIZE_RANGES``) and the output folder is
checked for writing before any work.
"""

from __future__ import annotations

import dataclasses
import json
import math
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from otgym.experiments.common.output_folder import check_out_dir

if TYPE_CHECKING:  # imported when needed: the command line reads this module's sizes without loading JAX
    from otgym.experiments.demo.whole_path import WholePathDemo

PLAN_ROBOT_RADIUS_UM = 5.0
"""Robot radius of the Table I plan (the ``otgym plan`` default: one robot, as the
paper's Table I); the whole path plans for the whole two-robot assembly instead."""

DEMO_EPISODES = 16
"""Speed-control episodes per policy in the demo (8 policies: RL, G1..G6, untrained).
Measured on 2 cores: the full evaluation's 256 (``otgym evaluate``) take about 3
minutes; with 16 the stage takes 15-20 s with warm caches and 20-45 s cold, most of it
compiling."""

DEMO_RUNS = 1
"""Whole-path scenarios of the demo, each run by the route follower and by the
autonomy, all in one batch of 20 ms ticks until its slowest trial ends. One shows the
behaviour; ``--runs`` adds more (and the MPC, ``--autonomy mpc``, replans every 0.1 s
at about 74 ms of CPU per environment, docs/mpc.md)."""

DEMO_SPEED_UM_S = 5.0
"""The whole-path route follower's constant speed: the autonomous mode's pace
(``otgym.runtime.trials.CRUISE_SPEED_UM_S``), around which the scenarios' crossing
times are drawn."""

FULL_EPISODES = 256
"""Episodes per policy of the full evaluation, ``otgym evaluate``."""


@dataclasses.dataclass(frozen=True)
class StudyConfig:
    """The demo's small shared-control study: every mode for every simulated
    participant, participant p on seeded scenarios of their own (every mode on the same
    ones), all trials in one batch, each trial cut at ``time_limit_s`` of simulated time
    (the full study, ``otgym experiment shared-control``: 8 participants x 8 trials,
    300 s).

    Why 90 s: an obstacle counts as met once it comes within 20 um of the assembly,
    and the obstacles cross the route in the chip's central chamber, 35-65 % of the way
    along it; at the autonomy's 5 um/s the assembly gets there about 20 s into a trial,
    so a 20 s cut met none. Autonomous trials reach the goal in about 61 s and shared
    ones in 70-86 s (seed 1's scenarios 10000-10002), so 90 s lets both finish and give
    their completion times; manual trials (2 um/s, the paper's 163.5 s) are cut on the
    way, after their first obstacles.

    Its cost: time_limit_s / 20 ms control ticks of one batch (it runs until its
    slowest trial ends; a batch's tick costs about 7.4 ms of CPU for 3 trials and
    10-11 ms for 9 on this machine's cores), about 45-50 s of CPU for the defaults,
    plus about 15 s to build the task and compile it with cold caches. It runs beside
    the other stages and is the demo's longest: measured 64-66 s of the 74-76 s the
    whole demo took on this machine's 2 cores with cold caches and no other job."""

    participants: int = 3
    trials: int = 1
    modes: tuple[str, ...] = ("manual", "autonomous", "shared")
    time_limit_s: float = 90.0

    def __post_init__(self):
        from otgym.shared import MODES

        check_range("--study-participants", self.participants, *SIZE_RANGES["study_participants"])
        check_range("--study-trials", self.trials, *SIZE_RANGES["study_trials"])
        check_range(
            "--study-time-limit-s", self.time_limit_s, *SIZE_RANGES["study_time_limit_s"], integer=False, unit=" s"
        )
        unknown = [mode for mode in self.modes if mode not in MODES]
        if unknown or not self.modes or len(set(self.modes)) != len(self.modes):
            raise ValueError(f"study modes must be distinct ones of {', '.join(MODES)}, got {', '.join(self.modes)}")


SIZE_RANGES = {
    "episodes": (1, 4096),
    "runs": (1, 64),
    "speed_um_s": (0.5, 20.0),
    "seed": (0, 2**32 - 1),
    "study_participants": (2, 16),  # a repeated-measures analysis needs two
    "study_trials": (1, 8),
    "study_time_limit_s": (1.0, 300.0),  # 300 s is the full study's limit
}
"""Valid ranges (inclusive) of the demo's sizes. The speed's
top is the interactive task's trap-speed clamp (``otgym.runtime.trials``): beyond it the
formation outruns what the traps are meant to carry; at its bottom the whole 307 um path
takes over 10 minutes of simulated time, longer than the rest of the demo together."""


def check_range(name: str, value, low, high, integer: bool = True, unit: str = "") -> None:
    """Raise ValueError naming ``name``, its valid range and ``value`` if ``value`` is
    not an integer (``integer``) or a finite number in [low, high]."""
    if integer:
        if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
            raise ValueError(f"{name} must be an integer in [{low}, {high}], got {value!r}")
    elif (
        isinstance(value, bool)
        or not isinstance(value, (int, float))
        or not math.isfinite(value)
        or not low <= value <= high
    ):
        raise ValueError(f"{name} must lie in [{low:g}, {high:g}]{unit}, got {value!r}")


@dataclasses.dataclass(frozen=True)
class DemoConfig:
    policy: str = "pretrained"
    episodes: int = DEMO_EPISODES
    seed: int = 1
    whole_path: WholePathDemo = dataclasses.field(default_factory=lambda: _whole_path(runs=DEMO_RUNS, seed=1))
    study: StudyConfig | None = StudyConfig()
    """None leaves the shared-control study out."""
    background_study: bool = True
    """Run the study in a thread beside the speed control and the whole path (they share
    no state; the demo's work is mostly single-threaded, so two cores run both)."""

    def __post_init__(self):
        check_range("--episodes", self.episodes, *SIZE_RANGES["episodes"])
        check_range("--seed", self.seed, *SIZE_RANGES["seed"])
        check_range("--runs", self.whole_path.runs, *SIZE_RANGES["runs"])
        check_range("--speed-um-s", self.whole_path.speed_um_s, *SIZE_RANGES["speed_um_s"], integer=False, unit=" um/s")
        check_range("whole-path seed", self.whole_path.seed, *SIZE_RANGES["seed"])


def _whole_path(**options) -> WholePathDemo:
    from otgym.experiments.demo.whole_path import WholePathDemo

    return WholePathDemo(**options)


def demo_config(
    policy: str = "pretrained",
    episodes: int = DEMO_EPISODES,
    speed_um_s: float = DEMO_SPEED_UM_S,
    runs: int = DEMO_RUNS,
    seed: int = 1,
    study_participants: int = StudyConfig.participants,
    study_trials: int = StudyConfig.trials,
    study_time_limit_s: float = StudyConfig.time_limit_s,
    background_study: bool = True,
    autonomy: str | None = None,
) -> DemoConfig:
    """The demo's configuration from the command line's values (study_participants 0
    leaves the study out; ``autonomy`` None: the whole path's recommended one); every
    value checked against ``SIZE_RANGES`` first, so a bad one is named with its valid
    range."""
    if policy != "pretrained" and Path(policy).is_dir():
        raise ValueError(f"--policy {policy} is a folder; give a policy file (policy.npz from otgym train)")
    check_range("--runs", runs, *SIZE_RANGES["runs"])
    check_range("--speed-um-s", speed_um_s, *SIZE_RANGES["speed_um_s"], integer=False, unit=" um/s")
    check_range("--seed", seed, *SIZE_RANGES["seed"])
    study = (
        None
        if study_participants == 0
        else StudyConfig(study_participants, study_trials, time_limit_s=study_time_limit_s)
    )
    return DemoConfig(
        policy=policy,
        episodes=episodes,
        seed=seed,
        study=study,
        background_study=background_study,
        whole_path=_whole_path(
            speed_um_s=float(speed_um_s), runs=runs, seed=seed, **({} if autonomy is None else {"autonomy": autonomy})
        ),
    )


def stage_names(config: DemoConfig) -> list[str]:
    """The demo's stages in the order they start, one progress line each, with their
    sizes. The study, when there is one, starts second and runs in the background."""
    from otgym.experiments.demo.whole_path import mode_name

    whole_path = config.whole_path
    names = [
        "planning on the default chip (Table I)",
        f"speed control: RL, G1..G6 and untrained, {config.episodes} episodes each (Table II, Fig. 7; "
        f"the full {FULL_EPISODES}: otgym evaluate)",
        f"carrying the cell along the whole path past the moving obstacles: {whole_path.runs} "
        f"scenario{'s' * (whole_path.runs > 1)}, the {mode_name(whole_path.autonomy)} beside the route follower at "
        f"{whole_path.speed_um_s:g} um/s",
    ]
    if config.study is not None:
        study = config.study
        names.insert(
            1,
            f"shared-control study (Fig. 8): {study.participants} simulated participants x "
            f"{study.trials} trial{'s' * (study.trials > 1)} x {len(study.modes)} modes in one batch, "
            f"trials cut at {study.time_limit_s:g} s of simulated time (the full study: otgym experiment "
            f"shared-control)" + (", in the background" if config.background_study else ""),
        )
    return names


class _Cancelled(Exception):
    """Raised inside the background study to stop it when the other stages failed."""


class _Background:
    """``work()`` in a daemon thread (a failed demo must not wait for it to exit);
    ``result()`` waits for it and returns its value or raises its exception."""

    def __init__(self, work: Callable[[], object]):
        self._outcome: tuple[bool, object] | None = None
        self._thread = threading.Thread(target=self._run, args=(work,), name="otgym-demo-study", daemon=True)
        self._thread.start()

    def _run(self, work) -> None:
        try:
            self._outcome = (True, work())
        except BaseException as error:  # noqa: BLE001 - handed to the caller by result()
            self._outcome = (False, error)

    def running(self) -> bool:
        return self._thread.is_alive()

    def result(self, timeout_s: float | None = None):
        self._thread.join(timeout_s)
        if self._outcome is None:
            return None
        done, value = self._outcome
        if not done:
            raise value
        return value


def run_demo(
    config: DemoConfig,
    out_dir: Path,
    stage: Callable[[str], None] = lambda _: None,
    progress: Callable[[int, int], None] | None = None,
    detail: Callable[[str], None] = lambda _: None,
) -> dict:
    """Run the stages into ``out_dir``; ``stage(text)`` announces each (``stage_names``),
    ``progress(done, total)`` follows the whole path's simulated seconds and ``detail(text)``
    the study's batches (from the study's thread when it runs in the background).
    Returns a summary (also written as ``summary.json``). Policy and output-folder
    problems raise before any work.

    Most of the demo's work runs on one core (compiling, and Python between small
    XLA calls), so the chip's fields (what every later stage reads) are solved in a
    thread beside the planning (which reads only the chip's image), and with
    ``config.background_study`` the study runs in that thread as soon as they are on
    disk, beside the planning, the speed control and the whole path (numba compiles
    the planner both threads use once, under its compiler lock). It is the demo's
    longest stage, so it starts first. No result depends on which thread runs what."""
    from otgym.experiments.demo import report, shipped_results
    from otgym.experiments.demo.whole_path import run as run_whole_path
    from otgym.experiments.speed_control.evaluate import evaluate, write_results
    from otgym.human.operator import simulate_operator
    from otgym.planning.pipeline import plan_path, write_plan
    from otgym.rl.policy import PRETRAINED_POLICY, load_policy, policy_meta, resolve_policy
    from otgym.sim.cache import chip_fields
    from otgym.sim.chip import load_chip
    from otgym.task.task import InteractiveConfig
    from otgym.tasks.transport import core as tr
    from otgym.tasks.transport import speed_control as spc
    from otgym.tasks.transport.presets import preset

    policy_path = resolve_policy(config.policy)
    task = preset(policy_meta(policy_path).get("preset", "paper"))
    q_params, meta = load_policy(policy_path, tr.OBS_SIZE, task.n_actions)
    out_dir = check_out_dir(out_dir)
    names = iter(stage_names(config))
    count = len(stage_names(config))
    announce = lambda index: stage(f"[{index}/{count}] {next(names)}")  # noqa: E731
    began = time.perf_counter()
    timings = {}

    study, stop = None, threading.Event()

    def study_work():
        start = time.perf_counter()

        def report_line(text: str) -> None:
            if stop.is_set():
                raise _Cancelled("the demo stopped")
            detail(text)

        result = run_study(config.study, config.seed, out_dir / "shared_control", report_line)
        return result, time.perf_counter() - start

    announce(1)
    start = time.perf_counter()
    chip = load_chip("default")
    background_study = config.study is not None and config.background_study
    fields_ready = threading.Event()

    def fields_then_study():
        chip_fields(chip)  # walls and flow, solved once into the disk cache for every later stage
        if not background_study:
            fields_ready.set()
            return None
        announce(2)  # the study, the demo's longest stage, needs only the fields: it starts beside the planning
        fields_ready.set()
        return study_work()

    # the planning reads only the chip's image: it runs while the fields are solved
    study = _Background(fields_then_study)
    try:
        task_config = InteractiveConfig()  # the task's route: between the chip's sites
        ends = chip.site_um(task_config.start_um), chip.site_um(task_config.goal_um)
        plan = plan_path(chip.image, chip.pixel_size_um, *ends, PLAN_ROBOT_RADIUS_UM, threshold=0.5)
        manual_um = simulate_operator(plan.occupancy.planning, chip.pixel_size_um, *ends)
        metrics = write_plan(plan, manual_um, out_dir / "plan")
        while not fields_ready.wait(0.05):
            if not study.running():
                study.result()  # raises the fields' error
        timings["plan_s"] = time.perf_counter() - start
        if not background_study:
            study.result()
            study = None
        if config.study is not None and not config.background_study:
            announce(2)
            study_result = study_work()

        announce(count - 1)
        start = time.perf_counter()
        evaluation = evaluate(spc.make_params(task), q_params, meta["hidden"], config.episodes, config.seed)
        speed_dir = out_dir / "speed_control"
        limits = task.force_band_pn[1], task.deviation_limit_um
        rows, safety, checks = write_results(evaluation, speed_dir, *limits)
        timings["speed_control_s"] = time.perf_counter() - start

        announce(count)
        start = time.perf_counter()
        whole_path_summary = run_whole_path(config.whole_path, out_dir / "whole_path", progress)
        timings["whole_path_s"] = time.perf_counter() - start
        if study is not None:
            if study.running():
                stage("waiting for the shared-control study")
            study_result = study.result()
    except BaseException:
        stop.set()
        if study is not None:
            try:
                study.result(timeout_s=10.0)  # it stops at its next report
            except BaseException:  # noqa: BLE001 - the first error is the one to report
                pass
        raise

    sections = [
        report.speed_control_section(
            rows,
            safety,
            checks,
            *limits,
            task.name,
            full_episodes=FULL_EPISODES,
            front=shipped_results.shipped_front() if policy_path == PRETRAINED_POLICY else None,
        ),
        report.planning_section(metrics),
        report.whole_path_section(whole_path_summary),
    ]
    study_summary = None
    if config.study is not None:
        study_summary, timings["shared_control_s"] = study_result
        sections.append(
            report.shared_control_section(study_summary["modes"], study_summary["size"], shipped_results.shipped_fig8())
        )
    total = time.perf_counter() - began
    beside = " (the study ran beside the planning, the speed control and the whole path)" if study is not None else ""
    header = (
        f"Policy `{policy_path.name}` (preset `{task.name}`, trained {meta.get('env_steps', '?')} steps), "
        f"seed {config.seed}. The demo runs small samples to fit a few minutes on two cores; each "
        f"section gives its sample size and the command of its full-size run. Wall times: "
        + ", ".join(f"{name[:-2].replace('_', ' ')} {seconds:.0f} s" for name, seconds in timings.items())
        + f"{beside}; {total:.0f} s in all."
    )
    report.write_report(out_dir / "report.md", sections, header)
    rl = next(row for row in rows if row["policy"] == "RL")
    summary = {
        "table_ii": rows,
        "safety": safety,
        "whole_path": whole_path_summary,
        "table_i": {name: dataclasses.asdict(row) for name, row in metrics.items()},
        "rl_asr": rl["ASR"],
        "rl_atct_s": rl["ATCT_s"],
        "episodes": config.episodes,
        "limits": {"force_pn": limits[0], "distance_um": limits[1]},
        "shared_control": study_summary,
        "timings_s": {**{name: round(seconds, 1) for name, seconds in timings.items()}, "total_s": round(total, 1)},
    }
    (out_dir / "summary.json").write_text(json.dumps(summary, indent=2))
    return summary


def run_study(study: StudyConfig, seed: int, out_dir: Path, detail: Callable[[str], None] = lambda _: None) -> dict:
    """The small shared-control study into ``out_dir`` with the full experiment's files
    (``write_experiment``: trials.csv, summary.csv/md, stats.json, fig8.png,
    acceptance.json): every mode's trials in one batch, participant p's trial t on
    scenario ``seed * 10000 + p * trials + t`` (``run_experiment``'s ``one_batch`` and
    ``scenario_per_participant``). Returns its size, its per-mode rows as written to
    summary.csv (``read_summary``) and the acceptance checks."""
    from otgym.experiments.shared_control.report import write_experiment
    from otgym.experiments.shared_control.run import run_experiment
    from otgym.task.task import InteractiveConfig

    out_dir = Path(out_dir)
    trials = run_experiment(
        study.participants,
        study.trials,
        list(study.modes),
        seed,
        "default",
        report=lambda line: detail(line.strip()),
        time_limit_s=study.time_limit_s,
        one_batch=True,
        scenario_per_participant=True,
    )
    checks = write_experiment(trials, out_dir)
    size = {
        "participants": study.participants,
        "trials_per_mode": study.trials,
        "modes": list(study.modes),
        "time_limit_s": study.time_limit_s,
        "seed": seed,
        "scenarios": sorted(int(s) for s in trials["scenario"].unique()),
        "scenario_per_participant": True,
        "one_batch": True,
        "encounter_gap_um": InteractiveConfig().encounter_gap_um,
    }
    return {"size": size, "modes": read_summary(out_dir / "summary.csv"), "acceptance": checks}


def read_summary(path: Path) -> list[dict]:
    """The per-mode rows of a study's ``summary.csv`` (``otgym.study.summarize``) as
    plain dicts, NaN as None."""
    import pandas as pd

    table = pd.read_csv(path)
    return [
        {key: (None if isinstance(value, float) and math.isnan(value) else value) for key, value in row.items()}
        for row in table.to_dict("records")
    ]
