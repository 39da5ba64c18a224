"""``otgym experiment shared-control --trace P:T`` end to end, tiny (1 participant x 1
trial x 3 modes, cut at 3 s of simulated time): the trace agrees with the trial's row in
trials.csv, writes the blend as the law computes it, and tracing changes no result."""

import numpy as np
import pandas as pd
import pytest

from otgym.runtime.trials import TASK_RETARGET
from otgym.shared import paper_alpha
from otgym.task.task import InteractiveConfig
from tests.otgym_cli import run_otgym

ARGS = ["experiment", "shared-control", "--participants", "1", "--trials", "1", "--time-limit-s", "3", "--seed", "0"]
MODES = ("manual", "autonomous", "shared")


def _events(trace: pd.DataFrame) -> list[str]:
    return [e for text in trace["events"].fillna("") for e in text.split(";") if e]


@pytest.mark.slow
def test_trace_matches_the_trial_and_changes_nothing(tmp_path):
    """Fails if trials.csv differs with --trace (the recorder disturbed the run), if a
    trace does not end on its trial's completion time or disagrees with its row (grip
    time, goal, collisions, trap losses, detachments), if alpha is written outside
    shared control or is not the paper's law of the previous tick's obstacle gap, if
    dP_r shows in manual control or dP_h in autonomous, or if dP_s is not their blend."""
    plain, traced = tmp_path / "plain", tmp_path / "traced"
    assert run_otgym(ARGS + ["--out", plain]).returncode == 0
    run = run_otgym(ARGS + ["--trace", "0:0", "--out", traced])
    assert run.returncode == 0, run.stderr
    assert (plain / "trials.csv").read_bytes() == (traced / "trials.csv").read_bytes()
    assert not list(plain.glob("trace_*"))
    trials = pd.read_csv(traced / "trials.csv").set_index("mode")
    tick_s = InteractiveConfig().tick_s
    max_step_um = TASK_RETARGET.max_trap_speed_um_s * tick_s
    for mode in MODES:
        trace = pd.read_csv(traced / f"trace_p0_t0_{mode}.csv")
        row = trials.loc[mode]
        assert (trace["mode"] == mode).all()
        assert np.allclose(np.diff(trace["time_s"]), tick_s, atol=1e-5) and len(trace) == round(3 / tick_s)
        assert trace["time_s"].iloc[-1] == row.completion_time_s
        events = _events(trace)
        grips = trace.loc[trace["events"].fillna("").str.contains("grip"), "time_s"]
        assert (grips.iloc[0] == row.grip_time_s) if len(grips) else np.isnan(row.grip_time_s)
        assert ("goal reached" in events) == bool(row.reached_goal)
        assert ("time limit" in events) == (not row.reached_goal and row.trap_losses == 0)
        assert len({e for e in events if e.startswith("collision start")}) == row.collisions
        assert events.count("trap loss") == row.trap_losses and events.count("detach") == row.detachments
        human = trace.filter(regex=r"^dP_h_trap").to_numpy()
        robot = trace.filter(regex=r"^dP_r_trap").to_numpy()
        moved = trace.filter(regex=r"^dP_s_trap").to_numpy()
        if mode == "shared":
            alpha = trace["alpha"].to_numpy()
            assert ((0 <= alpha) & (alpha <= 1)).all()
            law = paper_alpha(trace["nearest_obstacle_gap_um"].to_numpy()[:-1], 10.0, 20.0)
            assert np.allclose(alpha[1:], law)
        else:
            assert trace["alpha"].isna().all()
            alpha = np.where(mode == "manual", 1.0, 0.0) * np.ones(len(trace))
        assert not np.any(robot) if mode == "manual" else np.any(robot)
        assert not np.any(human) if mode == "autonomous" else True
        blended = alpha[:, None] * human + (1 - alpha[:, None]) * robot
        free = np.abs(blended).max(axis=1) < 0.5 * max_step_um  # well below the trap-speed clamp
        assert free.sum() > len(trace) // 2 and np.allclose(moved[free], blended[free], atol=1e-9)
    assert "traced participant 0's trial 0" in run.stdout
