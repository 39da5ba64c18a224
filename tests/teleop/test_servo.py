"""The servo loop in its own process, driven by the simulated haptic backend (a
virtual 45 g stylus held by a scripted hand with a 300 N/m grip). No assertion on
timing: bounds are on motion against the servo's own sample times, and a test waits for
what it needs (the stylus moving, a span of sample time, the stylus back) with a
deadline that only bounds a hang. The servo's rate and jitter are measured in
``benchmarks/interactive.py``."""

from __future__ import annotations

import functools
import multiprocessing
import os
import signal as process_signals
import time
from pathlib import Path

import numpy as np
import pytest
from scipy import signal

from otgym.teleop.device import DeviceError
from otgym.teleop.servo import (
    SIMULATED_HAPTIC_CAPS,
    ServoDevice,
    SimulatedHapticBackend,
    SteadyHand,
    VelocityEstimator,
    butterworth3_sos,
)

HAND_SPEED_MM_S = 20.0


def _simulated_device(**backend_options):
    hand = SteadyHand(velocity_mm_s=(HAND_SPEED_MM_S, 0.0, 0.0))
    return ServoDevice(functools.partial(SimulatedHapticBackend, hand=hand, **backend_options), SIMULATED_HAPTIC_CAPS)


def samples_until(device, condition, timeout_s: float = 60.0, force_n=None) -> list:
    """Read ``device`` (every new sample, refreshing ``force_n`` if given) until
    ``condition(samples)`` holds; the deadline only bounds a hang."""
    samples, deadline = [], time.monotonic() + timeout_s
    while not samples or not condition(samples):
        assert time.monotonic() < deadline, f"not within {timeout_s} s ({len(samples)} samples)"
        if force_n is not None:
            device.set_force(force_n)
        sample = device.read()
        if sample is not None and (not samples or sample.sequence != samples[-1].sequence):
            samples.append(sample)
        time.sleep(0.005)
    return samples


def test_servo_device_tracks_the_hand_and_feels_the_force():
    """The hand moves the stylus along device x at 20 mm/s. Once the stylus moves (its
    tip 2 mm along), over the next 0.3 s of the servo's own sample times: sequences and
    times advance, the tip advances at 20 mm/s within 3 mm/s (its position against its
    sample times; a steady spring lag does not change the slope) and the reported
    velocity's median is within 5 mm/s of 20 (the estimator is exact on a ramp once its
    20 Hz filter has settled; the margin covers the transient of a late tick). A 0.5 N
    push along +y, refreshed, deflects the grip by F/k = 1.67 mm: 0.3 s of servo time
    after it starts the tip is 1.2-2.2 mm along y. No longer refreshed, the force times
    out (after 0.25 s) and the stylus returns to within 0.3 mm of y = 0 (waited for, 60
    s at most: a force that never times out keeps it at 1.67 mm). Every servo tick after
    the first recorded its period. Stopped, the process has ended and reads give None.
    Only the servo's own clock measures here: a loaded machine makes the test wait
    longer, not fail (the servo's rate and jitter: ``benchmarks/interactive.py``)."""
    device = _simulated_device()
    with device:
        start = samples_until(device, lambda s: s[-1].position_mm[0] > 2.0)[-1]
        samples = [start] + samples_until(device, lambda s: s[-1].time_s >= start.time_s + 0.3)
        assert all(b.sequence > a.sequence for a, b in zip(samples, samples[1:]))
        assert all(b.time_s > a.time_s for a, b in zip(samples, samples[1:]))
        times = np.array([s.time_s for s in samples])
        slope_mm_s = np.polyfit(times, [s.position_mm[0] for s in samples], 1)[0]
        assert abs(slope_mm_s - HAND_SPEED_MM_S) < 3.0, slope_mm_s
        assert abs(np.median([s.velocity_mm_s[0] for s in samples]) - HAND_SPEED_MM_S) < 5.0
        assert samples[-1].buttons == 1
        push = [0.0, 0.5, 0.0]
        device.set_force(push)
        pushed_from = device.read().time_s
        pushed = samples_until(device, lambda s: s[-1].time_s >= pushed_from + 0.3, force_n=push)[-1]
        assert 1.2 < pushed.position_mm[1] < 2.2, pushed.position_mm
        samples_until(device, lambda s: abs(s[-1].position_mm[1]) < 0.3)  # no refresh: the force times out
        last = device.read()
        periods = device.loop_periods_s()
        assert len(periods) >= min(last.sequence - 1, 4096) and np.all(periods > 0)
    assert not device.process.is_alive()
    assert device.read() is None
    device.stop()  # idempotent


def test_a_backend_that_cannot_open_gives_a_one_line_device_error():
    device = _simulated_device(mass_kg=-1.0)
    with pytest.raises(DeviceError, match="simulated haptic stylus: mass_kg must be positive") as info:
        device.start()
    assert "\n" not in str(info.value)
    assert not device.process.is_alive()


def _hold_a_servo_device(conn):
    device = _simulated_device()
    device.start()
    conn.send(device.process.pid)
    time.sleep(600)  # held until the test kills this process


def _ended(pid: int) -> bool:
    stat = Path(f"/proc/{pid}/stat")
    try:
        return stat.read_text().rsplit(")", 1)[1].split()[0] in ("Z", "X")
    except OSError:
        return True


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads process states from /proc")
@pytest.mark.slow
def test_the_servo_process_ends_when_its_parent_dies():
    context = multiprocessing.get_context("spawn")
    receiver, sender = context.Pipe(duplex=False)
    parent = context.Process(target=_hold_a_servo_device, args=(sender,))  # daemons may not have children
    parent.start()
    try:
        deadline = time.monotonic() + 120.0
        while not receiver.poll(0.1):  # the helper's servo device has started (its pid sent)
            assert parent.is_alive(), "the helper failed to start its servo device"
            assert time.monotonic() < deadline, "the helper did not start its servo device within 120 s"
        servo_pid = receiver.recv()
        assert not _ended(servo_pid)
    finally:
        os.kill(parent.pid, process_signals.SIGKILL)
        parent.join()
    deadline = time.monotonic() + 60.0  # bounds a hang; it ends within a servo tick of noticing
    while not _ended(servo_pid) and time.monotonic() < deadline:
        time.sleep(0.05)
    ended = _ended(servo_pid)
    if not ended:
        os.kill(servo_pid, process_signals.SIGKILL)  # leave no orphan behind a failure
    assert ended


@pytest.mark.parametrize("cutoff_hz, rate_hz", [(20.0, 1000.0), (5.0, 100.0), (200.0, 1000.0)])
def test_closed_form_butterworth_matches_scipy(cutoff_hz, rate_hz):
    """Same filter as scipy's design (its sections split the gain differently, so the
    impulse responses are compared, 400 samples)."""
    impulse = np.zeros(400)
    impulse[0] = 1.0
    np.testing.assert_allclose(
        signal.sosfilt(butterworth3_sos(cutoff_hz, rate_hz), impulse),
        signal.sosfilt(signal.butter(3, cutoff_hz, fs=rate_hz, output="sos"), impulse),
        atol=1e-12,
    )


def test_velocity_estimator_streams_like_scipy():
    """Random positions at a steady 1 kHz: the estimator equals the second-order
    backward difference filtered offline by scipy.signal.sosfilt (to 1e-9)."""
    rng = np.random.default_rng(1)
    positions = np.cumsum(rng.normal(size=(300, 3)), axis=0)
    times = np.arange(300) * 1e-3
    estimator = VelocityEstimator(1000.0)
    streamed = np.array([estimator(p, t) for p, t in zip(positions, times)])
    raw = np.zeros_like(positions)
    raw[1] = (positions[1] - positions[0]) / 1e-3
    raw[2:] = (3 * positions[2:] - 4 * positions[1:-1] + positions[:-2]) / 2e-3
    offline = signal.sosfilt(signal.butter(3, 20.0, fs=1000.0, output="sos"), raw, axis=0)
    np.testing.assert_allclose(streamed, offline, atol=1e-9 * np.abs(offline).max())


def test_velocity_estimator_is_exact_on_a_ramp_with_uneven_steps():
    """Positions on a 12 mm/s ramp at steps jittered uniformly within 0.5-1.5 ms
    (seeded): the second-order difference is exact on a ramp, so after the low-pass
    has settled (1 s, 20 time constants) the estimate is 12 mm/s to 1e-6."""
    rng = np.random.default_rng(0)
    estimator = VelocityEstimator(1000.0)
    t = 0.0
    for _ in range(1000):
        t += rng.uniform(0.5e-3, 1.5e-3)
        velocity = estimator(np.array([12.0 * t, -3.0 * t, 0.0]), t)
    np.testing.assert_allclose(velocity, [12.0, -3.0, 0.0], atol=1e-6)
    np.testing.assert_array_equal(estimator(np.array([99.0, 0.0, 0.0]), t), velocity)


@pytest.mark.slow
@pytest.mark.parametrize("priority", [50, None])
def test_the_servo_loop_reports_the_scheduling_it_runs_under(priority):
    """Asked for SCHED_FIFO, the servo process runs under the policy its ``realtime``
    flag reports (FIFO where the kernel grants it, as to root here; normal scheduling
    where it does not); not asked, it runs under normal scheduling and says so. Catches
    a flag that is set without the call, or a call that is never made."""
    hand = SteadyHand(velocity_mm_s=(HAND_SPEED_MM_S, 0.0, 0.0))
    device = ServoDevice(
        functools.partial(SimulatedHapticBackend, hand=hand), SIMULATED_HAPTIC_CAPS, realtime_priority=priority
    )
    device.start()
    try:
        policy = os.sched_getscheduler(device.process.pid)
        assert device.realtime == (policy == os.SCHED_FIFO)
        if priority is None:
            assert policy != os.SCHED_FIFO
        elif os.geteuid() == 0:  # root may always ask for it
            assert device.realtime
    finally:
        device.stop()
    assert not device.realtime


def test_servo_options_are_validated():
    factory = functools.partial(SimulatedHapticBackend)
    for priority in (0, 100, 1.5):
        with pytest.raises(ValueError, match="realtime_priority"):
            ServoDevice(factory, SIMULATED_HAPTIC_CAPS, realtime_priority=priority)
    with pytest.raises(ValueError, match="busy_wait_s"):
        ServoDevice(factory, SIMULATED_HAPTIC_CAPS, busy_wait_s=0.01)
    with pytest.raises(ValueError, match="force_timeout_s"):
        ServoDevice(factory, SIMULATED_HAPTIC_CAPS, force_timeout_s=0.0)
    with pytest.raises(ValueError, match="hand_damping_n_s_per_m"):
        SimulatedHapticBackend(hand_damping_n_s_per_m=-1.0)
    with pytest.raises(ValueError, match="velocity_mm_s"):
        SteadyHand(velocity_mm_s=(1.0, 2.0))
