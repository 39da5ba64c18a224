"""``otgym experiment shared-control`` end to end from the command line, small: 2
participants x 1 trial x 3 modes, trials cut at 6 s of simulated time."""

import json

import pandas as pd
import pytest

from otgym.experiments.shared_control.config import parse_modes
from otgym.runtime.trials import TRIAL_COLUMNS
from tests.otgym_cli import run_otgym

COMMAND = ["experiment", "shared-control"]


@pytest.mark.slow
def test_small_experiment_writes_every_file(tmp_path):
    """Fails if a file is missing, a trial is lost or a column renamed, if modes do not
    share their scenarios, or if the autonomy does not move off the start in 6 s
    (it grips in under 0.1 s and carries at 5 um/s: a cell near the start at 6 s means
    the navigator or the task's stepping is broken)."""
    out = tmp_path / "fig8"
    run = run_otgym(
        COMMAND + ["--participants", "2", "--trials", "1", "--time-limit-s", "6", "--seed", "0", "--out", str(out)]
    )
    assert run.returncode == 0, run.stderr
    for name in (
        "trials.csv",
        "summary.csv",
        "summary.md",
        "stats.json",
        "fig8.png",
        "acceptance.json",
        "route_bound.csv",
        "route_bound.md",
    ):
        assert (out / name).stat().st_size > 0, name
    trials = pd.read_csv(out / "trials.csv")
    bound = pd.read_csv(out / "route_bound.csv")  # the route-keeping bound on the trials' own scenarios
    assert list(bound.scenario) == sorted(set(trials.scenario)) and (bound.earliest_s >= bound.free_s - 1e-6).all()
    assert list(trials.columns[: len(TRIAL_COLUMNS)]) == TRIAL_COLUMNS
    assert len(trials) == 6 and set(trials["mode"]) == {"manual", "autonomous", "shared"}
    assert trials.groupby("mode")["scenario"].apply(tuple).nunique() == 1
    assert (abs(trials["completion_time_s"] - 6.0) < 0.02).all() and not trials["reached_goal"].any()
    assert (trials["grip_time_s"][trials["mode"] == "autonomous"] < 0.5).all()
    json.loads((out / "stats.json").read_text())
    assert "% of trials done" in run.stdout
    # seed 0 is a development seed: the output and the report files say so
    assert "development seed: seed 0" in run.stdout
    assert (out / "summary.md").read_text().startswith("**development seed")
    assert (out / "route_bound.md").read_text().startswith("**development seed")
    assert json.loads((out / "acceptance.json").read_text())["seed_status"] == "development seed"


@pytest.mark.slow
def test_mpc_mode_alone_with_one_participant(tmp_path):
    """Mode mpc from the command line, small (12 rollouts, 5 steps of 0.1 s), one
    participant, cut at 4 s: fails if the MPC's trials are not written as mpc with the
    MPC's dP_r, if mpc.json or acceptance.json's MPC figures (with 95 % intervals) are
    missing, or if the MPC does not grip in the route navigator's 0.5 s."""
    out = tmp_path / "mpc"
    run = run_otgym(
        COMMAND
        + [
            "--participants",
            "1",
            "--trials",
            "1",
            "--modes",
            "mpc",
            "--time-limit-s",
            "4",
            "--mpc-rollouts",
            "12",
            "--mpc-plan-steps",
            "5",
            "--seed",
            "0",
            "--out",
            str(out),
        ]
    )
    assert run.returncode == 0, run.stderr
    trials = pd.read_csv(out / "trials.csv")
    assert list(trials["mode"]) == ["mpc"] and list(trials["autonomy"]) == ["mpc"]
    assert not (out / "route_bound.csv").exists()  # only beside shared and autonomous modes
    assert (trials["grip_time_s"] < 0.5).all() and not trials["reached_goal"].any()
    size = json.loads((out / "mpc.json").read_text())
    assert size["rollouts"] == 12 and size["modes"]["mpc"]["replans"] > 0
    evidence = json.loads((out / "acceptance.json").read_text())["mpc"]
    assert evidence["trials"] == 1 and evidence["goals_reached"] == 0
    low, high = evidence["goal_rate_ci95"]
    assert low == 0.0 < high < 1.0  # Wilson's interval for 0 of 1
    assert "no test" in (out / "summary.md").read_text().lower()


@pytest.mark.parametrize(
    "args, message",
    [
        (["--modes", "manual,manual"], "twice"),
        (["--mpc-rollouts", "3"], "mpc-rollouts"),
    ],
)
def test_bad_input_is_one_line_and_writes_nothing(tmp_path, args, message):
    """What the option's declaration cannot say (each option's own range and kind is
    tried by tests/cli/test_bad_input.py): a mode named twice; rollouts within the
    option's range but too few for the MPC's configuration."""
    out = tmp_path / "never"
    run = run_otgym(COMMAND + args + ["--out", str(out)])
    assert run.returncode == 2 and message in run.stderr and "Traceback" not in run.stderr
    assert not out.exists()


def test_out_that_is_a_file_is_refused(tmp_path):
    target = tmp_path / "file.txt"
    target.write_text("x")
    run = run_otgym(COMMAND + ["--out", str(target)])
    assert run.returncode == 2 and "is a file" in run.stderr


def test_parse_modes():
    assert parse_modes("shared, manual") == ["shared", "manual"]
    with pytest.raises(ValueError, match="twice"):
        parse_modes("manual,manual")


@pytest.mark.parametrize(
    "one_batch, per_participant, batches",
    [
        (False, False, [(["manual"] * 4, [10000, 10001] * 2, 1), (["shared"] * 4, [10000, 10001] * 2, 2)]),
        (True, True, [(["manual"] * 4 + ["shared"] * 4, [10000, 10001, 10002, 10003] * 2, 1)]),
    ],
)
def test_batches_and_scenarios_of_run_experiment(monkeypatch, one_batch, per_participant, batches):
    """Per mode (the full experiment: mode i's batch with seed + i, trial t of every
    participant on scenario seed * 10000 + t) or, for the demo, one batch of every mode
    with each participant on scenarios of their own (every mode on the same ones). The
    task and the trials are stand-ins: only the batches are checked."""
    import otgym.experiments.shared_control.run as experiment

    calls = []

    def trials(task, specs, people, seed, **options):
        calls.append(([s.mode for s in specs], [s.scenario for s in specs], seed))
        return [
            {
                **{column: 0 for column in TRIAL_COLUMNS},
                "participant": s.participant,
                "mode": s.mode,
                "trial": s.trial,
                "scenario": s.scenario,
            }
            for s in specs
        ]

    monkeypatch.setattr(experiment, "InteractiveTask", lambda config: None)
    monkeypatch.setattr(experiment, "run_trials", trials)
    lines = []
    frame = experiment.run_experiment(
        2,
        2,
        ["manual", "shared"],
        1,
        report=lines.append,
        one_batch=one_batch,
        scenario_per_participant=per_participant,
    )
    assert calls == batches
    assert len(frame) == 8 and list(frame.columns[: len(TRIAL_COLUMNS)]) == TRIAL_COLUMNS
    assert lines[0] == ("[1/1] manual, shared: 8 trials" if one_batch else "[1/2] manual: 4 trials")
