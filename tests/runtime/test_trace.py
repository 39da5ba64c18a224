"""The tick recorder (``otgym.runtime.trace``) on hand-made ticks of a batch of three
environments, tracing the middle one: every event fires on the tick it happens (and
only then), the rows stop at the trial's end, and only the traced row is copied."""

from types import SimpleNamespace

import numpy as np

from otgym.runtime.tick import TickCommand
from otgym.runtime.trace import TickView, TraceRecorder
from otgym.task.task import APPROACH, CARRY, DONE, Observation, TrialMetrics

E, T, R, K = 3, 4, 2, 2


def observation(time_s, phase, gaps, touched=(False, False)):
    """E environments; environment 1 gets ``phase``, obstacle ``gaps`` and ``touched``,
    the others stay far from everything (their values must never show up)."""
    gap = np.full((E, K), 500.0)
    gap[1] = gaps
    touch = np.zeros((E, K), bool)
    touch[1] = touched
    cell = np.zeros((E, 2))
    cell[1] = (time_s, 2 * time_s)
    return Observation(
        time_s=np.full(E, time_s),
        phase=np.array([APPROACH, phase, APPROACH]),
        cell_xy_um=cell,
        cell_arc_um=np.zeros(E),
        trap_xy_um=np.arange(E * T * 2, dtype=float).reshape(E, T, 2),
        handle_xy_um=np.zeros((E, T, 2)),
        robot_xy_um=np.zeros((E, R, 2)),
        obstacle_xy_um=np.zeros((E, K, 2)),
        obstacle_gap_um=gap,
        contact_force_pn=np.zeros((E, R)),
        cell_gap_um=np.zeros((E, R)),
        trap_distance_um=np.zeros((E, T)),
        obstacle_touched=touch,
    )


def command(mode, alpha):
    modes = np.array(["shared", mode, "shared"])
    return TickCommand(modes, np.array([0.3, alpha, 0.3]), np.full((E, T, 2), 0.2), np.full((E, T, 2), 0.1))


def run(mode, alpha, ticks):
    """Feed ``ticks`` [(observation, metrics changes)] to a recorder of environment 1."""
    metrics = TrialMetrics.empty(E, K)
    recorder = TraceRecorder({1: mode})
    before = observation(0.0, APPROACH, (50.0, 60.0))
    for obs, change in ticks:
        for name, value in change.items():
            getattr(metrics, name)[1] = value
        robot = np.full((E, T, 2), 0.05)
        lapsed = np.array([True, obs.time_s[0] in (0.06, 0.08), True])
        recorder(TickView(before, obs, command(mode, alpha), robot, SimpleNamespace(metrics=metrics), lapsed))
        before = obs
    return recorder.rows[1]


def test_events_fire_once_on_their_tick_and_rows_stop_at_the_end():
    """Fails if an event is missed, repeated while it lasts (a contact held two ticks
    is one collision start), fired for another environment, or if rows go on after the
    trial is done."""
    ticks = [
        (observation(0.02, APPROACH, (40.0, 60.0)), {}),
        (observation(0.04, CARRY, (30.0, 0.0)), {"grip_time_s": 0.04}),  # grip; obstacle 1 touches
        (observation(0.06, CARRY, (20.0, -0.1)), {}),  # still touching: no new start; lapse starts
        (observation(0.08, APPROACH, (5.0, 3.0), touched=(True, False)), {"detachments": 1}),
        (observation(0.10, CARRY, (6.0, 3.0)), {}),  # re-grip; lapse ends
        (observation(0.12, DONE, (9.0, 3.0)), {"done": True, "reached_goal": True, "completion_time_s": 0.12}),
        (observation(0.14, DONE, (9.0, 3.0)), {}),  # after the end: not recorded
    ]
    rows = run("shared", 0.4, ticks)
    assert [r["time_s"] for r in rows] == [0.02, 0.04, 0.06, 0.08, 0.10, 0.12]
    assert [r["events"] for r in rows] == [
        "",
        "grip;collision start 1",
        "lapse start",
        "detach;collision start 0",
        "grip;lapse end",
        "goal reached",
    ]
    assert [r["nearest_obstacle"] for r in rows] == [0, 1, 1, 1, 1, 1]
    assert rows[1]["nearest_obstacle_gap_um"] == 0.0 and rows[0]["nearest_obstacle_gap_um"] == 40.0
    assert rows[3]["phase"] == "approach" and rows[-1]["phase"] == "done"
    assert (rows[2]["cell_x_um"], rows[2]["cell_y_um"]) == (0.06, 0.12)  # environment 1's own row
    assert rows[0]["trap0_x_um"] == 8.0  # environment 1's first trap (the batch counts from 0)


def test_trap_loss_and_time_limit():
    """A lost trap ends the trial with ``trap loss``, never ``time limit``; a trial cut
    by the time limit says so."""
    lost = run("shared", 0.1, [(observation(0.02, DONE, (40.0, 60.0)), {"trap_losses": 1, "done": True})])
    assert lost[0]["events"] == "trap loss"
    cut = run("manual", 1.0, [(observation(0.02, DONE, (40.0, 60.0)), {"done": True})])
    assert cut[0]["events"] == "time limit"


def test_what_each_mode_writes_of_the_blend():
    """alpha only in shared control (NaN where the mode fixes it); dP_r written as 0 in
    manual control, dP_h as 0 in autonomous: the increment the blend gives no weight."""
    tick = [(observation(0.02, APPROACH, (40.0, 60.0)), {})]
    shared, manual, auto = run("shared", 0.4, tick)[0], run("manual", 1.0, tick)[0], run("autonomous", 0.0, tick)[0]
    assert shared["alpha"] == 0.4 and np.isnan(manual["alpha"]) and np.isnan(auto["alpha"])
    assert (shared["dP_h_trap0_x_um"], shared["dP_r_trap0_x_um"], shared["dP_s_trap0_x_um"]) == (0.2, 0.05, 0.1)
    assert manual["dP_r_trap3_y_um"] == 0.0 and manual["dP_h_trap3_y_um"] == 0.2
    assert auto["dP_h_trap3_y_um"] == 0.0 and auto["dP_r_trap3_y_um"] == 0.05
