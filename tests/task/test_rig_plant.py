"""A rig as the interactive task's plant (``otgym.task.rig.RigPlant``), in one process:
the example rig's first-order law (``examples/rig/first_order_rig.py``, no ROS here)
answers each tick's trap commands with its measured spheres, and the controller (the
real-time loop's tick, unchanged) drives it. The same law behind real rclpy, each side
its own process: ``tests/bus/test_rig_ros2.py``."""

import importlib.util

import jax
import numpy as np
import pytest

from otgym.bus.task_messages import session_description
from otgym.runtime.loop import DeviceBinding, InteractiveLoop
from otgym.task.rig import RIG_TIMEOUT_S, MeasuredPoses, RigPlant
from otgym.task.task import CARRY
from otgym.teleop.device import Device, DeviceCaps, Sample
from tests.bus.test_nodes import ROOT
from tests.task import fast_scenario, shared_task


def _example():
    spec = importlib.util.spec_from_file_location("first_order_rig", ROOT / "examples" / "rig" / "first_order_rig.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


class _Clocks:
    """Wall and monotonic time both following the ticks (simulated), so the run does not
    depend on how fast this machine is."""

    def __init__(self):
        self.now_s = 1000.0

    def __call__(self) -> float:
        return self.now_s


def _rig_loop(time_constant_s=0.02, mode="autonomous", seed=3, bindings=(), clock=None):
    task = shared_task()
    description = session_description(task, [])
    rig = _example().FirstOrderRig(
        description["sphere_body"],
        description["sphere_kind"],
        description["sphere_radius_um"],
        description["handle_spheres"],
        time_constant_s,
    )
    clocks, measured = _Clocks(), MeasuredPoses()
    plant = RigPlant(task, measured, lambda xy, stamp_s: rig.start(xy), clock=clocks, wall_clock=clocks)
    loop = InteractiveLoop(plant, list(bindings), fast_scenario(seed), mode, seed=seed, clock=clocks)
    return loop, plant, rig, clocks, measured


def _answer(loop, rig, clocks, measured, steps=2):
    """The rig's side between two ticks: the tick's traps commanded, ``steps`` of its law
    over the tick, its spheres measured and received."""
    rig.command(loop.observation.trap_xy_um[0])
    for _ in range(steps):
        clocks.now_s += loop.tick_s / steps
        xy = rig.advance(loop.tick_s / steps)
    measured.update(clocks(), clocks(), xy)


@pytest.mark.slow  # an end-to-end carry of the whole route: 37 s, the quick tier's longest test
def test_the_first_order_rig_reaches_the_goal_under_the_route_autonomy():
    """Autonomous mode on scenario 3: the robots grip the cell and carry it to the goal
    (307 um of route) with no trap lost, every tick's observation built from the rig's
    measured spheres. Fails if the plant took the task's physics instead (the rig's
    spheres would not be the observation's)."""
    loop, plant, rig, clocks, measured = _rig_loop()
    for _ in range(int(150.0 / loop.tick_s)):
        _answer(loop, rig, clocks, measured)
        loop.tick()
        np.testing.assert_array_equal(loop.sphere_xy_um(), measured.latest()[2])
        if loop.done:
            break
    row = loop.state.metrics.rows()[0]
    assert row["reached_goal"] and row["trap_losses"] == 0, row
    assert np.isfinite(row["grip_time_s"]) and np.isnan(row["peak_contact_force_pn"]), row
    assert np.linalg.norm(loop.observation.cell_xy_um[0] - shared_task().route_um[-1]) <= 3.0
    assert plant.held_ticks == 0, plant.held_ticks  # a rig this quick never lags half the escape distance


def test_a_silent_rig_holds_the_traps_and_a_stale_answer_counts_as_none():
    """No answer from the rig: every tick holds the traps, though the autonomy asks to
    move them. An answer older than the timeout, or stamped before the trial's start,
    or with the bodies away from the trial's start (the rig not yet reset), is
    none either. Fails without the plant's safety limits."""
    loop, plant, rig, clocks, measured = _rig_loop()
    start = loop.observation.trap_xy_um.copy()
    for _ in range(10):
        clocks.now_s += loop.tick_s
        record = loop.tick()
        assert np.abs(record.robot_um).max() > 0  # the autonomy asked
    np.testing.assert_array_equal(loop.observation.trap_xy_um, start)
    assert plant.held_ticks == 10
    measured.update(clocks(), clocks() - 10.0, rig.xy)  # stamped before the start
    loop.tick()
    measured.update(clocks() - 1.0, clocks(), rig.xy)  # arrived a second ago
    loop.tick()
    measured.update(clocks(), clocks(), rig.xy + [5.0, 0.0])  # the bodies 5 um from the start (not reset)
    loop.tick()
    np.testing.assert_array_equal(loop.observation.trap_xy_um, start)
    np.testing.assert_array_equal(loop.sphere_xy_um(), rig.xy)
    assert plant.held_ticks == 13
    measured.update(clocks(), clocks(), rig.xy)
    loop.tick()
    assert np.abs(loop.observation.trap_xy_um - start).max() > 0


def test_the_traps_wait_for_robots_that_lag():
    """A rig whose handles are 0.4 um off every trap command of the last 0.2 s (more
    than half the 0.6 um escape distance; sideways to the motion): the traps hold until
    it has caught up, and no trap is lost. Fails without the wait."""
    loop, plant, rig, clocks, measured = _rig_loop()
    traps_seen = []
    for _ in range(20):
        _answer(loop, rig, clocks, measured)
        loop.tick()
        traps_seen.append(loop.observation.trap_xy_um[0, 0].copy())
    held, traps = plant.held_ticks, loop.observation.trap_xy_um.copy()
    heading = traps_seen[-1] - traps_seen[-11]
    sideways = np.array([-heading[1], heading[0]]) / np.linalg.norm(heading)
    lagging = rig.xy.copy()
    lagging[loop.task.trap_sphere] += 0.4 * sideways
    clocks.now_s += loop.tick_s
    measured.update(clocks(), clocks(), lagging)
    loop.tick()
    np.testing.assert_array_equal(loop.observation.trap_xy_um, traps)
    assert plant.held_ticks == held + 1 and loop.state.metrics.rows()[0]["trap_losses"] == 0
    _answer(loop, rig, clocks, measured)
    loop.tick()
    assert plant.held_ticks == held + 1 and np.abs(loop.observation.trap_xy_um - traps).max() > 0


def test_a_rig_runs_one_environment():
    task = shared_task()
    plant = RigPlant(task, MeasuredPoses(), lambda xy, stamp_s: None)
    with pytest.raises(ValueError, match="one environment"):
        plant.reset([fast_scenario(1), fast_scenario(2)], jax.random.PRNGKey(0))


def test_the_rig_law_turns_and_moves_a_robot_onto_its_traps():
    """The example's law alone: a robot whose traps are turned by 30 degrees and moved
    3 um converges onto them, 1 - exp(-t / tau) of the way after t; a body without
    traps stays where it is."""
    module = _example()
    rig = module.FirstOrderRig([0, 0, 0, 1], ["robot"] * 3 + ["obstacle"], [1.0] * 4, [0, 2], 0.1)
    rig.start([[0, 0], [1, 0], [2, 0], [20, 20]])
    turn = np.deg2rad(30)
    traps = np.array([[0, 0], [2 * np.cos(turn), 2 * np.sin(turn)]]) + [3.0, 1.0]
    rig.command(traps)
    for _ in range(100):
        xy = rig.advance(0.001)  # 0.1 s: one time constant
    handles = xy[[0, 2]]
    pivot = handles.mean(axis=0)
    np.testing.assert_allclose(pivot, (1 - np.exp(-1)) * (traps.mean(axis=0) - [1, 0]) + [1, 0], atol=1e-9)
    angle = np.arctan2(*(handles[1] - handles[0])[::-1])
    np.testing.assert_allclose(angle, (1 - np.exp(-1)) * turn, atol=1e-9)
    for _ in range(2000):
        xy = rig.advance(0.001)
    np.testing.assert_allclose(xy[[0, 2]], traps, atol=1e-6)
    np.testing.assert_array_equal(xy[3], [20, 20])


@pytest.mark.slow
def test_a_rig_that_stalls_holds_the_traps_and_loses_none():
    """The rig falls silent for half a second in the approach (the traps moving at the
    autonomy's 20 um/s): the traps hold from the timeout on, the handles' distance is
    still taken against the commands the last measurement answered, so no trap is lost,
    and the trial goes on when the rig is back. Fails if a stale measurement were
    compared with the latest command (4 um ahead of it by then)."""
    loop, plant, rig, clocks, measured = _rig_loop()
    for tick in range(150):
        if 20 <= tick < 45:
            clocks.now_s += loop.tick_s  # silent: nothing measured, nothing received
        else:
            _answer(loop, rig, clocks, measured)
        loop.tick()
    row = loop.state.metrics.rows()[0]
    assert row["trap_losses"] == 0 and not loop.done, row
    assert plant.held_ticks >= 25 - int(RIG_TIMEOUT_S / loop.tick_s), plant.held_ticks
    assert int(loop.observation.phase[0]) == CARRY


def test_a_rig_that_does_not_follow_the_commands_is_waited_for_and_loses_none():
    """The rig answers every tick, but its robots stay where the trial started, as when
    the commands stop reaching it (a bus or controller stalled under load): the traps
    move at most the escape distance ahead of the command it follows (the start), then
    hold, and no trap is lost over 2 s; once it follows again the trial goes on. Fails
    against the rules before (the traps ran 0.8 um ahead of the robots while the start
    was among the last second's commands; a trap counted lost once it fell out)."""
    loop, plant, rig, clocks, measured = _rig_loop()
    start = loop.observation.trap_xy_um[0].copy()
    escape_um = plant.escape_distance_um
    for _ in range(100):
        clocks.now_s += loop.tick_s
        measured.update(clocks(), clocks(), rig.xy)  # fresh, and where the trial started
        loop.tick()
        lead = np.linalg.norm(loop.observation.trap_xy_um[0] - start, axis=-1).max()
        assert lead <= escape_um + 1e-9, lead
    assert lead > 0.5 * escape_um  # the traps did move toward the route before they held
    assert loop.state.metrics.rows()[0]["trap_losses"] == 0 and not loop.done
    held = plant.held_ticks
    for _ in range(30):
        _answer(loop, rig, clocks, measured)
        loop.tick()
    assert np.linalg.norm(loop.observation.trap_xy_um[0] - start, axis=-1).max() > 2 * escape_um
    assert plant.held_ticks < held + 30 and loop.state.metrics.rows()[0]["trap_losses"] == 0


class _Stylus(Device):
    """A stylus moved at a constant 2 mm/s along x with its clutch held, on the test's clock."""

    caps = DeviceCaps("test stylus", 3, 3.3, (160.0, 120.0, 70.0), 1000.0)

    def __init__(self, clocks):
        self.clocks, self.sequence, self.forces = clocks, 0, []

    def start(self):
        pass

    def stop(self):
        pass

    def read(self):
        self.sequence += 1
        return Sample(self.clocks(), self.sequence, np.zeros(3), np.array([2.0, 0.0, 0.0]), 1)

    def set_force(self, force_n):
        self.forces.append(np.asarray(force_n, float))


def test_teleoperation_moves_the_rigs_robot_and_feeds_back_a_force():
    """Manual mode, a stylus on robot 0: its traps and the rig's robot move along x, robot
    1 stays, no trap is lost, and the stylus gets finite forces from the vision sensor
    reading the rig's spheres. Fails if the device's dP_h did not reach the rig."""
    clocks = _Clocks()
    stylus = _Stylus(clocks)
    loop, plant, rig, clocks, measured = _rig_loop(mode="manual", bindings=[DeviceBinding(stylus, robots=(0,))])
    stylus.clocks = clocks
    start = rig.xy.copy()
    for _ in range(100):
        _answer(loop, rig, clocks, measured)
        loop.tick()
    moved = rig.xy - start
    body = np.asarray(loop.task.scene.model.sphere_body)
    robot0, robot1 = body == 0, body == 1
    assert moved[robot0, 0].min() > 1.0 and np.abs(moved[robot1]).max() < 0.1, moved[:, 0]
    assert loop.state.metrics.rows()[0]["trap_losses"] == 0
    assert stylus.forces and np.all(np.isfinite(stylus.forces))


def test_a_session_on_a_rig_sends_one_start_per_trial():
    """``Session.start`` on a rig plant: the rig hears trial 1's start once (a session's
    warm-up loop on the plant sent it a start of its own before, for a throwaway loop)."""
    from otgym.runtime.session import Session

    starts = []
    plant = RigPlant(shared_task(), MeasuredPoses(), lambda xy, stamp_s: starts.append(np.array(xy)))
    session = Session(plant, [], "P1", "autonomous", 3)
    session.start()
    try:
        assert len(starts) == 1 and session.trial == 1
    finally:
        session.close()
