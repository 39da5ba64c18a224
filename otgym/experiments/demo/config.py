"""What ``otgym demo`` runs (``DemoConfig``, built by ``demo_config`` from the command
line's values), every size checked against its range (``SIZE_RANGES``) before any work;
light to import (no JAX), so the command line reads its defaults and refuses bad input
at once."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # imported when needed: the command line reads this module's sizes without loading JAX
    from otgym.experiments.demo.whole_path import WholePathDemo

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

DEMO_TASK_EPISODES = 8
"""Paired episodes of each other task (assemble, orient, sort-cells: learned policy
against scripted baseline, ``otgym.experiments.demo.tasks``); the report runs 256.
Measured cold on 2 cores: 8 cost about 16, 30 and 20 CPU-s, most of it compiling."""
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
    slowest trial ends), most of it Python per tick (the simulated participants and the
    task's bookkeeping between small XLA calls): for the defaults, 4,500 ticks of 9
    trials, about 125 CPU-s with warm caches on two cores. It runs beside the other
    stages and is the demo's longest (docs/performance.md has the measured times and
    their commands)."""

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
    "task_episodes": (0, 256),  # 0 leaves the other tasks out; 256 is their report's size
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
    task_episodes: int = DEMO_TASK_EPISODES
    """Paired episodes of each other task; 0 leaves them out."""
    background_study: bool = True
    """Run the study in a thread beside the speed control and the whole path (they share
    no state; the demo's work is mostly single-threaded, so two cores run both)."""

    def __post_init__(self):
        check_range("--episodes", self.episodes, *SIZE_RANGES["episodes"])
        check_range("--seed", self.seed, *SIZE_RANGES["seed"])
        check_range("--task-episodes", self.task_episodes, *SIZE_RANGES["task_episodes"])
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
    task_episodes: int = DEMO_TASK_EPISODES,
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
        task_episodes=task_episodes,
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
    if config.task_episodes:
        from otgym.experiments.demo.tasks import task_names

        names.append(
            f"the other tasks ({', '.join(task_names())}): each learned policy against its scripted baseline, "
            f"{config.task_episodes} paired episodes each (the report's 256: otgym experiment TASK)"
        )
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
