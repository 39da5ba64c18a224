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
5. ``tasks/``: each task beyond the paper's (assemble, orient, sort-cells), its
   learned policy against its scripted baseline on a few paired episodes
   (``otgym.experiments.demo.tasks``; the full reports: ``otgym experiment TASK``).
6. ``report.md``: our numbers beside the paper's, with every sample size.

Every size is checked against its range (``otgym.experiments.demo.config``) and the
output folder is checked for writing before any work.
"""

from __future__ import annotations

import dataclasses
import json
import math
import threading
import time
from collections.abc import Callable
from pathlib import Path

from otgym.experiments.common.output_folder import check_out_dir
from otgym.experiments.demo.config import FULL_EPISODES, DemoConfig, StudyConfig, stage_names

PLAN_ROBOT_RADIUS_UM = 5.0
"""Robot radius of the Table I plan (the ``otgym plan`` default: one robot, as the
paper's Table I); the whole path plans for the whole two-robot assembly instead."""


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
    from otgym.experiments.demo.tasks import run_tasks, tasks_section
    from otgym.experiments.demo.whole_path import run as run_whole_path
    from otgym.experiments.speed_control.evaluate import evaluate
    from otgym.experiments.speed_control.report import write_results
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

        tasks_last = 1 if config.task_episodes else 0  # the other tasks' stage comes last
        announce(count - 1 - tasks_last)
        start = time.perf_counter()
        evaluation = evaluate(spc.make_params(task), q_params, meta["hidden"], config.episodes, config.seed)
        speed_dir = out_dir / "speed_control"
        limits = task.force_band_pn[1], task.deviation_limit_um
        rows, safety, checks = write_results(evaluation, speed_dir, *limits)
        timings["speed_control_s"] = time.perf_counter() - start

        announce(count - tasks_last)
        start = time.perf_counter()
        whole_path_summary = run_whole_path(config.whole_path, out_dir / "whole_path", progress)
        timings["whole_path_s"] = time.perf_counter() - start
        task_rows = None
        if config.task_episodes:
            announce(count)
            start = time.perf_counter()
            task_rows = run_tasks(config.task_episodes, config.seed, out_dir / "tasks", progress)
            timings["tasks_s"] = time.perf_counter() - start
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
    if task_rows is not None:
        sections.append(tasks_section(task_rows, config.seed))
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
        "tasks": task_rows,
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
