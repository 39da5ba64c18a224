"""The seed protocol: development seeds are flagged, report seeds are not, and no
report seed is among the development ones."""

from __future__ import annotations

import pytest

from otgym.experiments.common import seeds


def test_a_development_seed_is_flagged():
    assert seeds.is_development("evaluate", 201)
    assert seeds.is_development("evaluate", 199, batches=4)  # batches 199-202 reach Table II's 201
    assert seeds.is_development("shared-control", 10)
    assert seeds.is_development("shared-control", 2, trials=8)  # scenarios 20000-20007 and population seed 2
    assert seeds.is_development("route-bound", 91, trials=4)
    note = seeds.development_note("speed-front", 5001, batches=4)
    assert note.startswith("development seed") and "5001" in note
    assert seeds.seed_status("evaluate", 1) == "development seed"


def test_a_report_seed_is_not_flagged():
    for command, seed in seeds.REPORT_SEEDS.items():
        assert not seeds.is_development(command, seed, batches=4, trials=64), command
        assert seeds.development_note(command, seed, batches=4, trials=64) is None
        assert seeds.seed_status(command, seed) == "report seed"


def test_every_report_seed_is_absent_from_the_development_list():
    spaces = {"evaluate": ["episodes"], "speed-front": ["episodes"]} | {task: [task] for task in seeds.TASK_REPORTS}
    for command, seed in seeds.REPORT_SEEDS.items():
        for use in seeds.DEVELOPMENT:
            if use.space in spaces.get(command, ["study", "population"]):
                assert not use.first <= seed <= use.last, (command, seed, use)
            if use.space == "scenarios" and command in ("shared-control", "route-bound"):
                first = seed * seeds.SCENARIOS_PER_STUDY_SEED
                assert not use.overlaps(first, first + seeds.SCENARIOS_PER_STUDY_SEED - 1), (command, use)


def test_the_issue_s_development_seeds_are_listed():
    listed = {(use.space, n) for use in seeds.DEVELOPMENT for n in range(use.first, min(use.last, use.first + 200) + 1)}
    for space, number in [
        ("study", 0),
        ("study", 1),
        ("study", 5),
        ("study", 8),
        ("study", 9),
        ("study", 10),
        ("scenarios", 10001),
        ("scenarios", 20001),
        ("scenarios", 20008),
        ("scenarios", 910000),
        ("scenarios", 910007),
        ("population", 2),
        ("population", 3),
        ("episodes", 1),
        ("episodes", 201),
        ("episodes", 204),
        ("training", 0),
        ("training", 2),
        ("episodes", 1000),
    ]:
        assert (space, number) in listed, (space, number)


def test_the_tasks_development_seeds_are_flagged_and_their_training_seeds_unused():
    assert seeds.is_development("assemble", 0) and seeds.is_development("assemble", 100)
    assert seeds.is_development("orient", 1)
    assert seeds.is_development("sort-cells", 0) and seeds.is_development("sort-cells", 100)
    assert seeds.seed_status("sort-cells", seeds.REPORT_SEEDS["sort-cells"]) == "report seed"
    assert seeds.seed_status("orient", seeds.REPORT_SEEDS["orient"]) == "report seed"
    assert not seeds.is_development("assemble", 1)  # a different space from orient's seed 1
    for task, seed in seeds.TRAINING_SEEDS.items():
        uses = [u for u in seeds.DEVELOPMENT if u.space == "training" and u.first <= seed <= u.last]
        assert not uses, (task, uses)
    assert len(set(seeds.TRAINING_SEEDS.values())) == len(seeds.TRAINING_SEEDS)  # one shipped policy per seed


def test_unknown_command_and_bad_sizes_are_refused():
    with pytest.raises(ValueError):
        seeds.is_development("play", 1)
    with pytest.raises(ValueError):
        seeds.is_development("evaluate", 1, batches=0)
