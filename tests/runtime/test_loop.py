"""The real-time interactive loop (``otgym.runtime.loop``) on the interactive task, one
environment: silent and broken devices hold the traps, a replayed stylus velocity
moves them by tau v dt, the feedback opposes the traps' lead and saturates at the
device's limit, the autonomy carries the cell, the vision sensor agrees with the trap
law, pacing, the end of the task, and a real servo process.

The task is built once per process (``tests.runtime.shared_task``) and every loop runs
one environment, so its jitted step compiles once. Scenario seed 7: its obstacles
cross the route more than 100 um along it, far from the assembly in the few seconds
these tests run. Devices are driven by simulated time (``SimClock``) wherever a
test checks numbers, and the loop's wall clock is a fake one (``FakeWallTime``) where a
test checks stage times or pacing, so no result depends on the machine's speed (real
timings: ``benchmarks/interactive.py``)."""

from __future__ import annotations

import functools
import time

import numpy as np
import pytest

from otgym.runtime.loop import DeviceBinding, InteractiveLoop
from otgym.runtime.trials import TASK_RETARGET
from otgym.task.task import CARRY, DONE
from otgym.teleop.device import Device, DeviceCaps, DeviceError, Sample
from otgym.teleop.feedback import FeedbackConfig, newtons_per_pn_for
from otgym.teleop.replay import ReplayDevice, record_samples
from otgym.teleop.retarget import RetargetConfig, device_to_chip
from otgym.teleop.servo import SIMULATED_HAPTIC_CAPS, ServoDevice, SimulatedHapticBackend, SteadyHand
from tests.task import fast_scenario, shared_task

TAU_UM_PER_MM = TASK_RETARGET.motion_scale_um_per_mm
SENSOR_POSITION_BOUND_UM = 0.020
"""The vision sensor's requirement (tests/sim/test_sensor.py: 99th percentile of the
handle-position error at most 20 nm on 0.1 um pixels; about 2-5 nm measured)."""
SETTLED_TICK = 50
"""The retargeter's tremor filter (3rd-order Butterworth, 3.5 Hz) has settled to 1e-4
of a step after 1 s (tests/teleop/test_retarget.py); the feedback's 10 Hz filter sooner."""


class SimClock:
    """Device time that follows the loop's simulated time (from 1000 s), so a device
    ages by ticks, not by how fast this machine runs them."""

    def __init__(self):
        self.loop = None

    def __call__(self) -> float:
        return 1000.0 + (self.loop.time_s if self.loop is not None else 0.0)


class ScriptedDevice(Device):
    """An in-process haptic device: ``kind`` "steady" gives fresh samples at a constant
    tip velocity with ``buttons`` held, "silent" never gives one, "nan" gives NaN
    samples, "stale" stops renewing its sample at device time 1000.1 s (0.1 s into the
    loop), so the last one ages, "lost" raises DeviceError (its link is gone).
    Records every force command it receives, unsaturated."""

    def __init__(self, clock, kind="steady", velocity_mm_s=(0.0, 0.0, 0.0), buttons=1, force_limit_n=0.88):
        self.caps = DeviceCaps("scripted stylus", 3, force_limit_n, (160.0, 120.0, 70.0), 1000.0)
        self.clock, self.kind, self.buttons = clock, kind, buttons
        self.velocity_mm_s = np.asarray(velocity_mm_s, float)
        self.forces, self.sequence, self.running, self.stops = [], 0, False, 0
        self.last = None

    def start(self):
        self.running = True

    def stop(self):
        self.running = False
        self.stops += 1

    def read(self):
        if not self.running or self.kind == "silent":
            return None
        if self.kind == "lost":
            raise DeviceError("scripted stylus: link lost")
        now = self.clock()
        if self.kind == "stale" and now > 1000.1:
            return self.last
        self.sequence += 1
        if self.kind == "nan":
            return Sample(now, self.sequence, [np.nan] * 3, [np.nan] * 3, self.buttons)
        self.last = Sample(now, self.sequence, self.velocity_mm_s * (now - 1000.0), self.velocity_mm_s, self.buttons)
        return self.last

    def set_force(self, force_n):
        self.forces.append(np.array(force_n, float))


@pytest.fixture(scope="module")
def task():
    return shared_task()


@pytest.fixture(scope="module")
def scenario(task):
    return fast_scenario(7)


def make_loop(task, scenario, devices, mode, clock=None, **options):
    """A started loop; ``devices`` is a list of (device, robots) or DeviceBindings."""
    bindings = [d if isinstance(d, DeviceBinding) else DeviceBinding(d[0], d[1]) for d in devices]
    if clock is not None:
        options["clock"] = clock
    loop = InteractiveLoop(task, bindings, scenario, mode, seed=3, **options)
    if clock is not None:
        clock.loop = loop
    loop.start()
    return loop


def traps_of(task, robots):
    return np.isin(task.trap_robot, [task.scene.robots[r] for r in robots])


def ticks_with_truth(loop, n):
    """n ticks: (record, observation after it, observation of the frame its sensor read:
    the tick's start)."""
    out = []
    for _ in range(n):
        frame = loop.observation
        record = loop.tick()
        out.append((record, loop.observation, frame))
    return out


def replay_file(tmp_path, velocity_mm_s, duration_s, rate_hz=100.0, buttons=1):
    """A recorded stream at a constant tip velocity, the clutch (bit 0) held."""
    times = np.arange(int(round(duration_s * rate_hz)) + 1) / rate_hz
    velocity = np.asarray(velocity_mm_s, float)
    path = tmp_path / "stream.csv"
    record_samples([Sample(t, i + 1, velocity * t, velocity, buttons) for i, t in enumerate(times)], path)
    return path


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["silent", "nan", "stale", "lost"])
def test_a_silent_or_broken_device_holds_the_traps_in_manual_mode(task, scenario, kind):
    """Manual mode (alpha 1), one device at 5 mm/s on robot 0, none on robot 1.
    "silent": no sample ever; "nan": every sample NaN; "stale": samples stop after
    0.1 s, so the last is older than the retargeter's 100 ms from t = 0.2 s on (its
    first ticks move the traps); "lost": read raises DeviceError. Then on each of 15
    ticks the device gives no fresh input, dP_h and dP_s are exactly zero, every trap
    stays exactly where it was (float32 positions compared bit for bit) and the device
    is sent zero force (a lost link gets no feedback). Catches stale motion
    extrapolated, NaN reaching the physics (the task raises), a lost link that
    crashes the loop, the autonomy leaking into manual mode, or feedback pushed on a
    silent stylus."""
    clock = SimClock()
    device = ScriptedDevice(clock, kind=kind, velocity_mm_s=(5.0, 0.0, 0.0))
    loop = make_loop(task, scenario, [(device, (0,))], "manual", clock)
    if kind == "stale":
        moving = ticks_with_truth(loop, 13)  # stale from the tick that starts after t = 0.2 s
        assert moving[0][0].device_live[0] and max(np.abs(r.shared_um).max() for r, *_ in moving) > 0
        assert not moving[-1][0].device_live[0]
    device.forces = []
    before = loop.observation.trap_xy_um.copy()
    for record, obs, _ in ticks_with_truth(loop, 15):
        assert not record.device_live[0] and record.alpha == 1.0
        np.testing.assert_array_equal(record.human_um, 0.0)
        np.testing.assert_array_equal(record.shared_um, 0.0)
        np.testing.assert_array_equal(obs.trap_xy_um, before)
    assert len(device.forces) == 15
    np.testing.assert_array_equal(np.array(device.forces), 0.0)
    loop.close()
    assert device.stops == 1 and not device.running


@pytest.mark.slow
@pytest.mark.parametrize("robots", [(0,), (0, 1)], ids=["one robot", "formation"])
def test_replayed_constant_velocity_moves_the_traps_by_tau_v_dt(task, scenario, tmp_path, robots):
    """A replayed stylus at (2, 1, 3) mm/s (device frame: x right, y up, z toward the
    user), manual mode, 60 ticks. Once the tremor filter has settled (tick 50 on),
    each driven trap moves by tau v dt = 2 um/mm x (2, -1) mm/s x 0.02 s = (0.08,
    -0.04) um per tick (chip y points down, device z is not in the xy plane), to 1e-4
    relative (the filter's settled error); traps of an undriven robot do not move at
    all. On every tick the traps move by exactly dP_s (to 2e-5 um, float32 positions
    of a few hundred um). With robots (0, 1) one device drives the formation. Catches
    a wrong scale (tau applied twice or not at all), a flipped y axis, increments
    applied to the wrong robot, or a stale-sample rule that cuts a live replay."""
    clock = SimClock()
    device = ReplayDevice(replay_file(tmp_path, (2.0, 1.0, 3.0), 3.0), clock=clock)
    loop = make_loop(task, scenario, [(device, robots)], "manual", clock)
    driven = traps_of(task, robots)
    expected = TAU_UM_PER_MM * np.array([2.0, -1.0]) * task.config.tick_s
    previous = loop.observation.trap_xy_um[0]
    for index, (record, obs, _) in enumerate(ticks_with_truth(loop, 60)):
        assert record.device_live[0] and record.alpha == 1.0
        moved = obs.trap_xy_um[0] - previous
        np.testing.assert_allclose(moved, record.shared_um, atol=2e-5)
        np.testing.assert_array_equal(record.human_um[~driven], 0.0)
        np.testing.assert_array_equal(moved[~driven], 0.0)
        if index >= SETTLED_TICK:
            np.testing.assert_allclose(record.human_um[driven], np.broadcast_to(expected, (driven.sum(), 2)), rtol=1e-4)
            np.testing.assert_array_equal(record.shared_um, record.human_um)
        previous = obs.trap_xy_um[0]
    loop.close()


DRAG_TICKS = 35


@pytest.fixture(scope="module")
def dragged(task, scenario):
    """Both robots dragged along chip +x at 100 um/s (styluses at 50 mm/s along device x,
    trap-speed clamps raised to 100 um/s) for 35 ticks in manual mode, down the straight
    first 70 um of the route's channel, against a relative flow of about 95 um/s (the
    chip's flow there is 5 um/s along +x). Device A drives robot 0 with the default
    feedback scale and a 0.88 N limit; device B drives robot 1 with ten times the
    scale and a 0.3 N limit. One run serves both feedback tests."""
    clock = SimClock()
    a = ScriptedDevice(clock, velocity_mm_s=(50.0, 0.0, 0.0), force_limit_n=0.88)
    b = ScriptedDevice(clock, velocity_mm_s=(50.0, 0.0, 0.0), force_limit_n=0.3)
    scale = newtons_per_pn_for(task.config.scene.trap_law)
    fast = RetargetConfig(dead_band_mm_s=0.3, max_trap_speed_um_s=100.0)
    loop = make_loop(
        task,
        scenario,
        [
            DeviceBinding(a, (0,), retarget=fast),
            DeviceBinding(b, (1,), retarget=fast, feedback=FeedbackConfig(newtons_per_pn=10 * scale)),
        ],
        "manual",
        clock,
        max_trap_speed_um_s=100.0,
    )
    history = ticks_with_truth(loop, DRAG_TICKS)
    loop.close()
    return a, b, scale, history


def lead_and_force(task, history, device_index, robots):
    """Per settled tick (from tick 15, 0.3 s: the 10 Hz feedback filter has settled):
    the traps' lead over their true handles summed over the robot's handles (um, chip
    frame), the trap-law force on them (pN), and the device force mapped to the chip
    plane (N)."""
    law = task.config.scene.trap_law
    mask = traps_of(task, robots)
    lead, law_force, device_force = [], [], []
    for record, _, frame in history[15:]:
        offsets = frame.trap_xy_um[0, mask] - frame.handle_xy_um[0, mask]
        lead.append(offsets.sum(axis=0))
        law_force.append(np.asarray(law.force_pn(offsets)).sum(axis=0))
        device_force.append(device_to_chip(record.feedback_n[device_index], "xy"))
    return np.array(lead), np.array(law_force), np.array(device_force)


@pytest.mark.slow
def test_feedback_opposes_the_lead_with_the_trap_laws_force(task, dragged):
    """Device A, default scale s = newtons_per_pn_for(law) (0.066 N/pN): the traps lead
    their handles along +x by about 0.07 um summed over the two handles (the robot's
    drag along its bar, 0.039 pN s/um with its spheres interacting, at 95 um/s through
    the fluid: 3.7 pN). The stylus force points against the lead on every settled tick
    (negative dot product) and on average within 8 degrees (cosine of the means below
    -0.99: the handles' thermal wander, sqrt(kT/k) = 9 nm per axis each, 13 nm summed,
    puts a single tick's lead up to 30 degrees off the drag, its mean over 20 ticks
    within 1 degree), and its mean equals
    -s times the mean trap-law force at the true offsets within s x 2 handles x 1 pN:
    the sensor's 20 nm position bound times the law's largest slope, its 50 pN/um
    centre stiffness, per handle (no bend stiffening: the lead stays far below half
    the 0.6 um escape distance; no contact cue: robot 0 does not touch the cell).
    The force stays within the device's 0.88 N. Catches a feedback sign that pulls the
    stylus along the motion, feedback from the wrong robot's handles, or a force
    scale off by more than the sensor's error."""
    a, _, scale, history = dragged
    lead, law_force, device_force = lead_and_force(task, history, 0, (0,))
    assert np.all(lead[:, 0] > 0.035)  # the traps lead along the drag (half the expected lead)
    assert np.all(np.sum(device_force * lead, axis=1) < 0)
    mean_force, mean_lead = device_force.mean(axis=0), lead.mean(axis=0)
    assert mean_force @ mean_lead / (np.linalg.norm(mean_force) * np.linalg.norm(mean_lead)) < -0.99
    np.testing.assert_allclose(
        device_force.mean(axis=0), -scale * law_force.mean(axis=0), atol=scale * 2 * 50.0 * SENSOR_POSITION_BOUND_UM
    )
    assert np.abs(np.array(a.forces)[-20:]).max() > 0.02  # not vacuous: a force is felt
    assert max(np.linalg.norm(f) for f in a.forces) <= 0.88 + 1e-12


def test_feedback_saturates_at_the_devices_limit(task, dragged):
    """Device B: ten times the scale puts the unsaturated force above 1 N, so every
    settled command has exactly the device's 0.3 N limit (the loop saturates at the
    device's caps, not only the Touch's 0.88 N), still against the lead. Catches a
    saturation at the feedback config's 0.88 N instead of the device's limit, or none."""
    _, b, _, history = dragged
    lead, law_force, device_force = lead_and_force(task, history, 1, (1,))
    assert np.all(10 * newtons_per_pn_for(task.config.scene.trap_law) * np.linalg.norm(law_force, axis=1) > 1.0)
    np.testing.assert_allclose(np.linalg.norm(device_force, axis=1), 0.3, rtol=1e-9)
    np.testing.assert_allclose([np.linalg.norm(f) for f in b.forces[15:DRAG_TICKS]], 0.3, rtol=1e-9)
    np.testing.assert_array_equal(b.forces[DRAG_TICKS], 0.0)  # close() zeroed it
    assert np.all(np.sum(device_force * lead, axis=1) < 0)


@pytest.fixture(scope="module")
def autonomous(task, scenario):
    """2.5 s of autonomous mode with no device: (records, observations)."""
    loop = make_loop(task, scenario, [], "autonomous")
    history = ticks_with_truth(loop, 125)
    loop.close()
    return history


@pytest.mark.slow
def test_autonomous_mode_carries_the_cell_along_the_route(task, autonomous):
    """No device, alpha 0: the traps move by exactly the navigator's dP_r (capped at
    20 um/s), the robots grip the cell within 1 s and from t = 1 s to 2.5 s the cell's
    progress along the route grows at the navigator's 5 um/s cruise speed within 15 %
    (route points are 0.125 um apart, 2 % of the 7.5 um). Catches a loop that ignores
    the autonomy in autonomous mode, or a blend with the weights swapped."""
    previous = None
    for record, obs, _ in autonomous:
        assert record.alpha == 0.0
        np.testing.assert_allclose(record.shared_um, record.robot_um, rtol=1e-12)  # capped twice: 1 ulp
        assert np.linalg.norm(record.shared_um, axis=1).max() <= 20.0 * task.config.tick_s + 1e-9
        if previous is not None:
            np.testing.assert_allclose(obs.trap_xy_um[0] - previous, record.shared_um, atol=2e-5)
        previous = obs.trap_xy_um[0]
    at_1s, end = autonomous[49][1], autonomous[-1][1]
    assert at_1s.phase[0] == CARRY and end.phase[0] == CARRY
    speed = (end.cell_arc_um[0] - at_1s.cell_arc_um[0]) / (end.time_s[0] - at_1s.time_s[0])
    assert speed == pytest.approx(5.0, rel=0.15)


@pytest.mark.slow
def test_sensed_forces_agree_with_the_trap_law_at_the_true_offsets(task, autonomous):
    """Over 125 ticks x 4 handles of the autonomous carry (the cell pressed into the
    grippers, the chip's walls in the background), every handle is found, within the
    sensor's 20 nm of its true position, and its force within 50 pN/um x 20 nm = 1 pN
    of the Gaussian trap law (stiffness 50 pN/um at its centre, its steepest point) at
    the true offset. Catches crops misplaced (a handle outside its crop is not found
    or found off by pixels), crops offset by half a pixel (50 nm), or the sensor given
    the wrong pixel size or trap positions."""
    law = task.config.scene.trap_law
    for record, _, frame in autonomous:
        assert record.sensed_valid.all()
        np.testing.assert_array_equal(record.frame_trap_xy_um, frame.trap_xy_um[0])
        true_handles = frame.handle_xy_um[0]
        error = np.linalg.norm(record.sensed_handle_xy_um - true_handles, axis=1)
        assert error.max() <= SENSOR_POSITION_BOUND_UM, error
        truth = np.asarray(law.force_pn(frame.trap_xy_um[0] - true_handles))
        assert np.linalg.norm(record.sensed_force_pn - truth, axis=1).max() <= 50.0 * SENSOR_POSITION_BOUND_UM
    assert max(np.linalg.norm(r.sensed_force_pn, axis=1).max() for r, *_ in autonomous) > 1.0  # forces, not zeros


class FakeWallTime:
    """Stands in for the loop module's ``time`` (``monkeypatch``): ``perf_counter`` and
    ``monotonic`` read a clock that only ``sleep`` (recorded) and the test's ``advance``
    move, so the stage times and the pacing of a tick are exact and owe nothing to this
    machine's speed."""

    def __init__(self):
        self.now_s = 100.0
        self.sleeps_s: list[float] = []

    def monotonic(self) -> float:
        return self.now_s

    perf_counter = monotonic

    def sleep(self, seconds: float) -> None:
        assert seconds > 0
        self.sleeps_s.append(seconds)
        self.now_s += seconds

    def advance(self, seconds: float) -> None:
        self.now_s += seconds


class Costly:
    """``target`` with each method named in ``costs_s`` costing that many seconds of the
    fake clock per call (everything else delegated)."""

    def __init__(self, target, wall: FakeWallTime, **costs_s: float):
        self._target, self._wall, self._costs_s = target, wall, costs_s

    def __getattr__(self, name):
        value = getattr(self._target, name)
        return costing(self._wall, self._costs_s[name], value) if name in self._costs_s else value


def costing(wall: FakeWallTime, seconds: float, function):
    """``function`` that costs ``seconds`` of the fake clock per call."""

    def costly(*arguments, **options):
        wall.advance(seconds)
        return function(*arguments, **options)

    return costly


def test_tick_reports_each_stage_where_its_time_was_spent(task, scenario, monkeypatch):
    """A tick whose stages cost known times of a fake clock (binary fractions, exact in
    floating point): the device read 1/1024 s, the autonomy 1/512, dispatching the
    physics 1/256, rendering 1/128, sensing 1/64, sending the feedback 1/32, completing
    the physics 1/16. The record puts each where it belongs: physics_s = dispatch +
    complete, render_s, sense_s, rest_s = device read + autonomy + feedback, and wall_s
    is the whole tick as the clock measured it from outside. Catches stage stamps taken
    in the wrong order or place (render time counted as sensing, the physics' completion
    left out), or a part of the tick no stage accounts for. (How long the stages take on
    real hardware: ``benchmarks/interactive.py``.)"""
    import otgym.runtime.loop as loop_module

    wall = FakeWallTime()
    monkeypatch.setattr(loop_module, "time", wall)
    clock = SimClock()
    device = ScriptedDevice(clock, velocity_mm_s=(2.0, 0.0, 0.0))
    device.read = costing(wall, 2.0**-10, device.read)
    device.set_force = costing(wall, 2.0**-5, device.set_force)
    loop = make_loop(task, scenario, [(device, (0,))], "shared", clock)
    loop.task = Costly(task, wall, dispatch=2.0**-8, complete=2.0**-4)
    loop.autonomy = costing(wall, 2.0**-9, loop.autonomy)
    loop._render = costing(wall, 2.0**-7, loop._render)
    loop.sensor = Costly(loop.sensor, wall, measure=2.0**-6)
    for _ in range(3):
        before = wall.now_s
        record = loop.tick()
        assert record.physics_s == 2.0**-8 + 2.0**-4
        assert record.render_s == 2.0**-7 and record.sense_s == 2.0**-6
        assert record.rest_s == 2.0**-10 + 2.0**-9 + 2.0**-5
        assert record.wall_s == wall.now_s - before
    loop.close()


def test_realtime_run_paces_ticks_to_the_wall_clocks_schedule(task, scenario, monkeypatch):
    """run(0.3 s, realtime) on a fake wall clock, each tick costing 5 ms: 15 ticks, 0.3 s
    of simulated time, tick k starting at exactly k x 20 ms (each sleeps to its deadline)
    and the run ending at the 15th deadline. A tick that costs 30 ms (under two periods)
    is caught up: the next starts at once and the one after is back on the schedule. A
    tick that costs 50 ms (more than a period late) restarts the schedule from its end,
    counts in late_ticks, and the ticks after it do not burst to catch up: each starts 20
    ms after the previous. Without realtime the ticks never sleep. Catches a run that does
    not sleep, sleeps a whole period after each tick (drifting), bursts after a late tick,
    or does not count it. (The pace a real tick keeps: ``benchmarks/interactive.py``.)"""
    import otgym.runtime.loop as loop_module

    wall = FakeWallTime()
    monkeypatch.setattr(loop_module, "time", wall)

    def paced_starts(costs_s):
        """Run len(costs_s) ticks in real time; the fake times at which each began (from
        the run's start) and the run's end."""
        loop = make_loop(task, scenario, [], "shared")
        starts, costs = [], iter(costs_s)
        navigator = loop.autonomy

        def autonomy(observation):  # the first thing a tick does without devices
            starts.append(wall.now_s - begin)
            wall.advance(next(costs))
            return navigator(observation)

        loop.autonomy = autonomy
        begin = wall.now_s
        records = loop.run(len(costs_s) * task.config.tick_s, realtime=True)
        loop.close()
        return np.array(starts), wall.now_s - begin, records, loop.late_ticks

    tick_s = task.config.tick_s
    starts, elapsed, records, late = paced_starts([0.005] * 15)
    assert len(records) == 15 and records[-1].time_s == pytest.approx(0.3, abs=1e-4)
    np.testing.assert_allclose(starts, np.arange(15) * tick_s, atol=1e-9)
    assert elapsed == pytest.approx(15 * tick_s, abs=1e-9) and late == 0

    starts, _, _, late = paced_starts([0.005] * 5 + [0.03] + [0.005] * 4)
    np.testing.assert_allclose(starts, [0.0, 0.02, 0.04, 0.06, 0.08, 0.10, 0.13, 0.14, 0.16, 0.18], atol=1e-9)
    assert late == 0

    starts, _, _, late = paced_starts([0.005] * 5 + [0.05] + [0.005] * 4)
    np.testing.assert_allclose(starts, [0.0, 0.02, 0.04, 0.06, 0.08, 0.10, 0.15, 0.17, 0.19, 0.21], atol=1e-9)
    assert late == 1

    wall.sleeps_s.clear()
    loop = make_loop(task, scenario, [], "shared")
    assert len(loop.run(0.1, realtime=False)) == 5 and wall.sleeps_s == []
    loop.close()


def test_run_stops_when_a_trap_is_lost(task, scenario):
    """A stylus swept at 200 mm/s with the trap-speed clamp raised to 400 um/s (far past
    the 140 um/s at which two Gaussian traps of 9.1 pN can drag a robot through
    water) pulls robot 0 out of its traps: the task is DONE and run(1 s) stops after a
    few ticks instead of 50. Catches a run that ignores the task's end."""
    clock = SimClock()
    fast = RetargetConfig(dead_band_mm_s=0.3, max_trap_speed_um_s=400.0)
    device = ScriptedDevice(clock, velocity_mm_s=(200.0, 0.0, 0.0))
    loop = make_loop(
        task, scenario, [DeviceBinding(device, (0,), retarget=fast)], "manual", clock, max_trap_speed_um_s=400.0
    )
    records = loop.run(1.0, realtime=False)
    loop.close()
    assert loop.done and records[-1].phase == DONE and len(records) < 25
    assert loop.state.metrics.trap_losses[0] == 1
    assert device.stops == 1 and np.array_equal(device.forces[-1], np.zeros(3))


@pytest.mark.slow
def test_servo_device_drives_the_traps_and_stops_with_zero_force(task, scenario):
    """A simulated haptic stylus in its own 1 kHz servo process, its hand moving at
    5 mm/s along device x, drives robot 0 for 50 real-time ticks in manual mode, once it
    reports the hand's motion (a sample at 4 mm/s or more: an event waited for, 60 s at
    most). The loop reads the process's samples (ticks with fresh input; a tick without
    one moves nothing); robot 0's traps move by the sum of the ticks' increments, along
    chip +x (y under a tenth of x), and robot 1's do not move. The stylus is pushed
    against the motion (-x) on the live ticks once dragging (from tick 15, as the
    feedback filter settles). After close the servo process has ended. How far the traps get depends on how many ticks found a fresh sample, which
    is the machine's business; the rate the servo keeps and the age of its samples are
    measured in ``benchmarks/interactive.py``. Catches a loop that cannot read a real
    servo process, moves the wrong robot or the wrong way, or leaves the process running."""
    hand = SteadyHand(velocity_mm_s=(5.0, 0.0, 0.0))
    device = ServoDevice(functools.partial(SimulatedHapticBackend, hand=hand), SIMULATED_HAPTIC_CAPS)
    loop = make_loop(task, scenario, [(device, (0,))], "manual")
    try:
        deadline = time.monotonic() + 60.0
        while (sample := device.read()) is None or sample.velocity_mm_s[0] < 4.0:
            assert time.monotonic() < deadline, "the servo process never reported the hand's motion"
            time.sleep(0.01)
        before = loop.observation.trap_xy_um[0]
        records = loop.run(1.0, realtime=True)
    finally:
        loop.close()
    moved = loop.observation.trap_xy_um[0] - before
    driven = traps_of(task, (0,))
    assert len(records) == 50
    live = [r for r in records if r.device_live[0]]
    assert live, "no tick found a fresh sample"
    np.testing.assert_array_equal(sum(r.human_um for r in records if not r.device_live[0]), 0.0)
    np.testing.assert_allclose(moved, sum(r.shared_um for r in records), atol=2e-5 * len(records))
    assert np.all(moved[driven, 0] > 0) and np.all(np.abs(moved[driven, 1]) < 0.1 * moved[driven, 0]), moved
    np.testing.assert_array_equal(moved[~driven], 0.0)
    assert np.mean([r.feedback_n[0, 0] for r in records[15:] if r.device_live[0]]) < 0
    assert not device.process.is_alive()


def test_bad_configurations_are_refused(task, scenario):
    clock = SimClock()
    a, b = ScriptedDevice(clock), ScriptedDevice(clock)
    with pytest.raises(ValueError, match="mode"):
        InteractiveLoop(task, [], scenario, "telepathic")
    with pytest.raises(ValueError, match="driven twice"):
        InteractiveLoop(task, [DeviceBinding(a, (0,)), DeviceBinding(b, (0, 1))], scenario, "manual")
    with pytest.raises(ValueError, match="within 0..1"):
        InteractiveLoop(task, [DeviceBinding(a, (2,))], scenario, "manual")
    with pytest.raises(ValueError, match="distinct"):
        DeviceBinding(a, (0, 0))
    with pytest.raises(ValueError, match="plane"):
        DeviceBinding(a, (0,), feedback=FeedbackConfig(plane="xz"))
    with pytest.raises(ValueError, match="max_trap_speed_um_s"):
        InteractiveLoop(task, [], scenario, "manual", max_trap_speed_um_s=float("nan"))
