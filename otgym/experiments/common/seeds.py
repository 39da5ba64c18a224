"""One seed protocol for every figure otgym reports.

The rule: tune only on development seeds; report on held-out ones. A held-out seed is
run once, for the report. A seed whose result led to a change (of the code, a
parameter, a threshold, a choice among variants) becomes a development seed, and the
next report uses a new one. ``DEVELOPMENT`` lists every seed and scenario range that
development has looked at, each with what it was used for; ``REPORT_SEEDS`` names the
held-out seed each full-size command uses by default. A full-size run on a development
seed still runs, and says "development seed" in its printed output and report files
(``development_note``), so that no figure from a seed tuning has seen passes as held out.

Seed spaces (what a number seeds; the same number in two spaces is two different draws):

- ``episodes``: the speed-control evaluation episodes, ``jax.random.PRNGKey(seed)`` per
  batch (``otgym evaluate`` batch r uses seed + r; ``otgym experiment speed-front``
  the same; the demo's Table II; ``otgym.experiments.speed_control.pretrain``'s validation;
  ``benchmarks/training.py``'s test episodes; ``otgym.experiments.speed_control.reward_terms``).
- ``training``: a DQN training run's ``PRNGKey`` (``otgym train --seed``).
- ``study``: the shared-control study's seed (``otgym experiment shared-control``,
  ``route-bound``): population seed ``seed``, scenario ``seed * 10000 + t`` for trial t,
  mode i's simulation seed ``seed + i``.
- ``scenarios``: one scenario's number (``InteractiveTask.scenario(n)``), whatever
  the study seed that reached it.
- ``population``: the simulated participants (``sample_population(n, seed)``).
- ``transport``: the demo's whole-path transport runs (``otgym demo --runs``).
- one space per task with a report (a registry entry with ``report_seed``: assemble,
  orient, sort-cells): its evaluation episodes, one batch from ``jax.random.PRNGKey(seed)``
  (``otgym experiment NAME``; the same starts and step keys for every policy compared).

``TRAINING_SEEDS`` names the training seed (space ``training``) of each task's shipped
learned policy, named before it was trained. A task's report and training seeds are
written in its registry entry (``report_seed``, ``training_seed``) and gathered here,
so the seed registry covers them and a task added with a report adds its own.

Where a development figure was recorded without its seed (the issue that introduced
this module tried Table II on "another fresh seed", 256 episodes, and Fig. 8 on
"another fresh seed", 4 participants x 4 trials, without naming them), the report
seeds below were chosen far from every small number.
"""

from __future__ import annotations

import dataclasses

from otgym import registry

TASK_REPORTS = {entry.name: entry.extras for entry in registry.entries("tasks") if "report_seed" in entry.extras}
"""The registered tasks with a report-seed comparison, and their entries' extras."""

SPACES = ("episodes", "training", "study", "scenarios", "population", "transport", *TASK_REPORTS)

SCENARIOS_PER_STUDY_SEED = 10_000
"""Study seed s reaches scenarios s * 10000 .. s * 10000 + 9999 (trial t: + t)."""

EPISODES_PER_BATCH = 256
"""Evaluation batch size of ``otgym experiment speed-front`` (batch r on seed + r)."""


@dataclasses.dataclass(frozen=True)
class SeedUse:
    """Seeds ``first`` .. ``last`` (inclusive) of one space and what development used them for."""

    space: str
    first: int
    last: int
    used_for: str

    def __post_init__(self):
        if self.space not in SPACES:
            raise ValueError(f"unknown seed space {self.space!r}; one of {SPACES}")
        if not 0 <= self.first <= self.last:
            raise ValueError(f"need 0 <= first <= last, got {self.first}..{self.last}")

    def overlaps(self, first: int, last: int) -> bool:
        return self.first <= last and first <= self.last


def _one(space: str, seed: int, used_for: str) -> SeedUse:
    return SeedUse(space, seed, seed, used_for)


DEVELOPMENT: tuple[SeedUse, ...] = (
    # speed-control evaluation episodes
    _one("episodes", 1, "otgym evaluate's and otgym demo's old default: the demo's Table II (16 episodes), early runs"),
    SeedUse("episodes", 3, 4, "tests of the evaluation (small batches, --repeats 2 from seed 3)"),
    _one("episodes", 101, "the paper preset's medium chosen (water at 20 C) from the constant speeds, 128 episodes"),
    SeedUse(
        "episodes",
        201,
        204,
        "Table II (README) on 1024 episodes, re-run after each physics change; its misses led to issue 29",
    ),
    SeedUse("episodes", 301, 302, "benchmarks/training.py's test episodes: training reliability, 5 of 5 seeds"),
    _one("episodes", 401, "reward terms' per-step distributions (otgym experiment reward-terms)"),
    _one("episodes", 1000, "pretrain's validation episodes: the shipped policy picked among training seeds 0-2"),
    SeedUse(
        "episodes",
        5001,
        5009,
        "issue 29's development of the speed front: failure causes (the cell slides out of the notches), "
        "feedback rules, reward and loss variants, a development front on 5005-5008 (with the training "
        "seeds speed-front drew from 5005)",
    ),
    # DQN training
    SeedUse(
        "training",
        0,
        4,
        "benchmarks/training.py's training seeds; pretrain's candidates 0-2 (seed 1 shipped, as the policy "
        "file's metadata says; seed 2 before it); "
        "otgym train's default 0; the reward variants of RewardWeights' docstring (seed 0, seed 1); "
        "the development DQN runs of assemble (seed 1), orient (seed 0) and sort-cells (seed 1) in docs/tasks.md",
    ),
    SeedUse(
        "training", 10, 19, "issue 29's development of the speed front's family (reward and loss variants, seed 10)"
    ),
    _one("training", 29, "the interactive task's first learned speed policy (the first trainer, rounds of 64)"),
    _one(
        "training",
        31,
        "the interactive task's learned speed policy by the one DQN trainer (otgym.experiments.learned_speed.train, "
        "task interactive-speed, preset train)",
    ),
    # shared-control study seeds (population, scenarios seed*10000+t, simulation seed+i)
    _one("study", 0, "otgym experiment shared-control's old default: the first Fig. 8 runs, participant development"),
    _one(
        "study",
        1,
        "participant development (shared 94.9 %, careful closing); the demo's study (10000-10002); the MPC tried "
        "for the demo's whole path on 10000-10001",
    ),
    _one("study", 2, "shared-control diagnosis loop (64 trials; side-steps into walls; the rm-ANOVA's crash)"),
    _one("study", 5, "Fig. 8 on a 'fresh' seed, followed by participant changes"),
    _one("study", 7, "participant change measured (shared goal 98 -> 78 %); benchmarks/interactive.py's scenario 7"),
    _one("study", 8, "Fig. 8 on a 'fresh' seed after the hydrodynamics, followed by the grip fix"),
    _one("study", 9, "Fig. 8 on a 'fresh' seed after the grip fix, followed by navigator and scenario fixes"),
    _one("study", 10, "Fig. 8 (README), route-bound, the traced shared collisions; its misses led to issue 29"),
    _one("study", 13, "the MPC navigator's acceptance, 128 scenarios (130000-130127)"),
    _one("study", 14, "the distilled MPC clone's evaluation, 64 scenarios (140000-140063)"),
    _one("study", 15, "the chosen DAgger clone's evaluation, 64 scenarios (150000-150063)"),
    _one(
        "study",
        90,
        "scenario calibration (crossing-time spread) and route bound on 900000-900063; "
        "otgym experiment calibrate-scenarios' default and docs examples (900000-900015, the default's check on -900063)",
    ),
    _one("study", 91, "DAgger round selection on 910000-910015"),
    _one("study", 97, "the learned-speed navigator (mode rl) against the route follower, development comparison"),
    _one(
        "study",
        7500,
        "issue 29's first Fig. 8 report (8 x 8, commit 16c423d): the human model was changed from sources "
        "after its miss of (d), so the next report uses seed 7600",
    ),
    _one(
        "study",
        7600,
        "issue 29's Fig. 8, (e) and rl reports (8 x 8) with the participant of decision 0045; the participant "
        "was changed after it (issue 40: decision 0027, the watched pace), so the next report uses seed 7700, "
        "pre-registered on docs/results.md",
    ),
    _one(
        "study",
        7800,
        "the learned speed's report (one DQN trainer's policy against the first's and the route follower, "
        "1 x 128, planned in docs/rl-navigator.md before its run)",
    ),
    # scenarios reached outside their study seed's own runs
    _one("scenarios", 10001, "shared diagnosis of an obstacle held against a wall (side-step before waiting)"),
    SeedUse("scenarios", 20001, 20008, "manual diagnosis: wall clearance, two hands planning as one"),
    SeedUse(
        "scenarios",
        15000,
        15063,
        "the demo's whole path: run i of otgym demo --seed 1 on 15000 + i; the learned speed tried on 15000-15002",
    ),
    SeedUse(
        "scenarios",
        900000,
        900123,
        "participant and navigator development (900000-900003), calibration (-900063), "
        "MPC clone data (900000-900007, 900100-900123)",
    ),
    SeedUse("scenarios", 910000, 910015, "grip-place fix on 64 manual trials (910000-910007), DAgger selection"),
    SeedUse("scenarios", 910016, 910255, "tick-cost timing of 32-256 batched trials (no outcome read), learned speed"),
    SeedUse("scenarios", 960000, 961023, "training episodes of the learned speed policy (rounds of 64 from 960000)"),
    SeedUse(
        "scenarios",
        962000,
        962639,
        "the pool of task interactive-speed (preset train: 962000-962639; default and the tests: 962000-962063)",
    ),
    # simulated participants
    SeedUse("population", 2, 3, "diagnosis of squeeze losses at the grip (pop-seed 3: 12 x 12 s, 2: 8 x 30 s)"),
    _one("population", 4242, "participant model development (scenarios 900000-900003, 910000-910007)"),
    _one(
        "population",
        90,
        "issue 29 item 5: the human model's sourced changes (lapses, tremor and drift, one cue threshold) "
        "on study seed 90 (scenarios 900000-900007); otgym experiment human-sensitivity's default; "
        "the --trace example of docs/study.md (shared-control --seed 90 --trace 0:0); issue 40 item 1: "
        "the participant who perceives the window against the old one (4 x 2, manual and shared, 900000-900001)",
    ),
    # the demo's transport
    _one("transport", 1, "the demo's whole-path transport (otgym demo --runs 8 --seed 1)"),
    # the assemble, orient and sort-cells tasks' evaluation episodes
    _one("assemble", 0, "the baseline's pace table in docs/tasks.md (64 episodes per pace, ring and ring-16)"),
    _one(
        "assemble",
        100,
        "the development learned pace against the baseline (64 episodes); otgym experiment assemble's "
        "cost measured on 16 episodes before its report run",
    ),
    _one(
        "orient",
        1,
        "the scripted policies and the development DQN in docs/tasks.md (64 episodes); otgym experiment "
        "orient's cost measured on 16 episodes before its report run",
    ),
    _one("sort-cells", 0, "the scripted, random and idle policies' table in docs/tasks.md (64 episodes per preset)"),
    SeedUse("sort-cells", 5, 6, "the development DQN's actions against the baseline's (32 episodes from keys 5 and 6)"),
    _one(
        "sort-cells",
        100,
        "the development DQN runs against the baseline, random and idle (64 episodes); otgym experiment "
        "sort-cells' cost measured on 16 episodes before its report run",
    ),
)


REPORT_SEEDS = {
    "evaluate": 73_000,
    "speed-front": 74_000,
    "shared-control": 7_700,
    "route-bound": 7_700,
} | {name: int(extras["report_seed"]) for name, extras in TASK_REPORTS.items()}
"""The held-out seed each full-size command uses by default, named before it was run
(route-bound bounds shared-control's scenarios, so the two share it). Evaluation
commands use ``seed .. seed + batches - 1``."""

COMMANDS = tuple(REPORT_SEEDS)

TRAINING_SEEDS = {name: int(extras["training_seed"]) for name, extras in TASK_REPORTS.items()}
"""The ``otgym train --task NAME --seed`` of each task's shipped learned policy (the
report's policy), named before its training; unused by development (space ``training``)."""


def _spans(command: str, seed: int, batches: int, trials: int) -> list[tuple[str, int, int]]:
    """The (space, first, last) seed ranges one run of ``command`` draws from."""
    if command in ("evaluate", "speed-front"):
        return [("episodes", seed, seed + batches - 1)]
    if command in TASK_REPORTS:
        return [(command, seed, seed + batches - 1)]
    if command in ("shared-control", "route-bound"):
        first = seed * SCENARIOS_PER_STUDY_SEED
        spans = [("study", seed, seed), ("scenarios", first, first + trials - 1)]
        return spans + ([("population", seed, seed)] if command == "shared-control" else [])
    raise ValueError(f"unknown command {command!r}; one of {COMMANDS}")


def development_uses(
    command: str, seed: int, batches: int = 1, trials: int = SCENARIOS_PER_STUDY_SEED
) -> list[SeedUse]:
    """The development uses a run of ``command`` on ``seed`` meets: its ``batches``
    episode batches (evaluate, speed-front) or its ``trials`` scenarios and population
    (shared-control, route-bound). Empty for a held-out seed."""
    if batches < 1 or trials < 1:
        raise ValueError(f"batches and trials must be positive, got {batches}, {trials}")
    spans = _spans(command, seed, batches, trials)
    return [
        use for use in DEVELOPMENT for space, first, last in spans if use.space == space and use.overlaps(first, last)
    ]


def is_development(command: str, seed: int, batches: int = 1, trials: int = SCENARIOS_PER_STUDY_SEED) -> bool:
    """Whether a run of ``command`` on ``seed`` draws from a development seed."""
    return bool(development_uses(command, seed, batches, trials))


def development_note(command: str, seed: int, batches: int = 1, trials: int = SCENARIOS_PER_STUDY_SEED) -> str | None:
    """One line for a run's output and report files when its seed is a development seed
    (what development used it for), else None."""
    uses = development_uses(command, seed, batches, trials)
    if not uses:
        return None
    named = "; ".join(f"{use.space} {_range(use)}: {use.used_for}" for use in uses)
    return (
        f"development seed: seed {seed} was used in development ({named}), so these figures are not held out "
        f"(the held-out report seed of otgym {command} is {REPORT_SEEDS[command]})"
    )


def seed_status(command: str, seed: int, batches: int = 1, trials: int = SCENARIOS_PER_STUDY_SEED) -> str:
    """``"report seed"``, ``"development seed"`` or ``"other seed"`` (held out as far as
    ``DEVELOPMENT`` knows, but not the command's named report seed)."""
    if is_development(command, seed, batches, trials):
        return "development seed"
    return "report seed" if seed == REPORT_SEEDS[command] else "other seed"


def mark_report_files(
    command: str, seed: int, markdown=(), json_files=(), batches: int = 1, trials: int = SCENARIOS_PER_STUDY_SEED
) -> str | None:
    """Say in a run's report files whether its seed is held out: each JSON file (an
    object) gains ``seed``, ``seed_status`` and ``development_note``; on a development
    seed each markdown file starts with the note in bold. Returns the note (None when
    held out)."""
    import json
    from pathlib import Path

    note = development_note(command, seed, batches, trials)
    status = seed_status(command, seed, batches, trials)
    for path in map(Path, json_files):
        data = json.loads(path.read_text())
        data.update(seed=seed, seed_status=status, development_note=note)
        path.write_text(json.dumps(data, indent=2))
    if note:
        for path in map(Path, markdown):
            path.write_text(f"**{note}.**\n\n" + path.read_text())
    return note


def _range(use: SeedUse) -> str:
    return str(use.first) if use.first == use.last else f"{use.first}-{use.last}"


def _check_report_seeds_held_out() -> None:
    for command, seed in REPORT_SEEDS.items():
        if is_development(command, seed, batches=16):
            raise AssertionError(f"report seed {seed} of {command} is a development seed")
    for task, seed in TRAINING_SEEDS.items():
        if any(use.space == "training" and use.first <= seed <= use.last for use in DEVELOPMENT):
            raise AssertionError(f"training seed {seed} of {task}'s shipped policy is a development seed")


_check_report_seeds_held_out()
