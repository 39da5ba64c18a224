"""Retargeting a device's samples to the human's trap increment dP_h, tick by tick at
50 Hz. All streams are deterministic, so tolerances are numerical, not statistical."""

from __future__ import annotations

import numpy as np
import pytest

from otgym.teleop.device import Sample
from otgym.teleop.retarget import RetargetConfig, Retargeter, tremor_filter_gain_db

TICK_HZ = 50.0


def _sample(t, sequence, velocity, buttons=1, position=(0.0, 0.0, 0.0)):
    return Sample(t, sequence, position, velocity, buttons)


def _run(retargeter, velocities, buttons=1):
    """Feed one fresh sample per tick; returns the (N, 2) increments."""
    out = []
    for i, v in enumerate(velocities):
        t = i / TICK_HZ
        out.append(retargeter(_sample(t, i + 1, v, buttons), t))
    return np.array(out)


def test_constant_tip_velocity_gives_steady_scaled_increments_with_y_flipped():
    """4 mm/s along device (0.6, 0.8) held 2 s (100 ticks): after the filter settles
    (t >= 1 s; its step response has decayed below 1e-4 by then) every increment is
    v tau / 50 um, chip y = -device y (chip y points down)."""
    config = RetargetConfig(motion_scale_um_per_mm=2.5)
    velocity = 4.0 * np.array([0.6, 0.8, 0.0])
    dp = _run(Retargeter(config, TICK_HZ), [velocity] * 100)
    expected = np.array([0.6, -0.8]) * 4.0 * 2.5 / TICK_HZ
    np.testing.assert_allclose(dp[50:], np.broadcast_to(expected, (50, 2)), rtol=1e-4)
    xz = _run(Retargeter(RetargetConfig(plane="xz"), TICK_HZ), [np.array([0.0, 0.0, 4.0])] * 100)
    np.testing.assert_allclose(xz[-1], [0.0, 4.0 * 2.0 / TICK_HZ], rtol=1e-4)


def test_dead_band_removes_drift_only():
    slow = _run(Retargeter(RetargetConfig(), TICK_HZ), [np.array([0.8, 0.0, 0.0])] * 100)
    assert np.all(slow == 0.0)
    fast = _run(Retargeter(RetargetConfig(), TICK_HZ), [np.array([1.2, 0.0, 0.0])] * 100)
    np.testing.assert_allclose(fast[-1], [1.2 * 2.0 / TICK_HZ, 0.0], rtol=1e-4)


def test_clutch_gates_motion_and_restarts_from_rest():
    velocity = [np.array([4.0, 0.0, 0.0])] * 100
    assert np.all(_run(Retargeter(RetargetConfig(), TICK_HZ), velocity, buttons=0) == 0.0)
    assert np.all(_run(Retargeter(RetargetConfig(), TICK_HZ), velocity, buttons=0b10) == 0.0)
    always = _run(Retargeter(RetargetConfig(clutch_bit=None), TICK_HZ), velocity, buttons=0)
    assert always[-1, 0] > 0
    retargeter = Retargeter(RetargetConfig(), TICK_HZ)
    steady = _run(retargeter, velocity)[-1]
    released = retargeter(_sample(2.0, 101, velocity[0], buttons=0), 2.0)
    np.testing.assert_array_equal(released, [0.0, 0.0])
    first_again = retargeter(_sample(2.02, 102, velocity[0], buttons=1), 2.02)
    assert 0 <= first_again[0] < 0.2 * steady[0]  # the filter starts from rest, no stored motion


def test_trap_speed_is_clamped():
    config = RetargetConfig(max_trap_speed_um_s=10.0)
    dp = _run(Retargeter(config, TICK_HZ), [np.array([15.0, -20.0, 0.0])] * 100)
    assert np.all(np.linalg.norm(dp, axis=1) <= 10.0 / TICK_HZ + 1e-12)
    np.testing.assert_allclose(np.linalg.norm(dp[-1]), 10.0 / TICK_HZ)
    np.testing.assert_allclose(dp[-1] / np.linalg.norm(dp[-1]), [0.6, 0.8], rtol=1e-4)


def test_non_finite_samples_are_dropped_and_counted():
    """100 ticks, every 5th sample non-finite (NaN or inf in velocity or position):
    20 dropped, none reaches the output, which holds the last good sample's motion."""
    retargeter = Retargeter(RetargetConfig(), TICK_HZ)
    outputs = []
    for i in range(100):
        t = i / TICK_HZ
        if i % 5 == 4:
            bad = [np.nan, 0.0, 0.0] if i % 2 else [np.inf, 0.0, 0.0]
            sample = _sample(t, i + 1, bad) if i % 10 == 4 else _sample(t, i + 1, [4.0, 0, 0], position=bad)
        else:
            sample = _sample(t, i + 1, [4.0, 0.0, 0.0])
        outputs.append(retargeter(sample, t))
        outputs.append(retargeter(sample, t))  # the same sample seen twice is counted once
    assert retargeter.dropped_nonfinite == 20
    outputs = np.array(outputs)
    assert np.isfinite(outputs).all()
    np.testing.assert_allclose(outputs[-1], [4.0 * 2.0 / TICK_HZ, 0.0], rtol=1e-4)


def test_silent_device_gives_zero_within_the_timeout():
    """Samples for 1 s, then the device falls silent (its last sample repeats, then
    None): output is exactly zero from the first tick more than 0.1 s after the last
    sample, and never extrapolated before that."""
    retargeter = Retargeter(RetargetConfig(), TICK_HZ)
    last = None
    for i in range(50):
        last = _sample(i / TICK_HZ, i + 1, [4.0, 0.0, 0.0])
        steady = retargeter(last, last.time_s)
    for i in range(50, 75):
        t = i / TICK_HZ
        dp = retargeter(last if i < 60 else None, t)
        if t - last.time_s > 0.1:
            np.testing.assert_array_equal(dp, [0.0, 0.0])
        else:
            assert np.linalg.norm(dp) <= np.linalg.norm(steady) * (1 + 1e-9)
    assert retargeter.silent_ticks == sum(1 for i in range(50, 75) if i / TICK_HZ - last.time_s > 0.1)
    assert np.all(retargeter(None, 0.0) == 0.0)
    retargeter.reset()
    assert retargeter.silent_ticks == 0 and retargeter.dropped_nonfinite == 0


@pytest.mark.parametrize("freq_hz", [1.0, 8.0, 10.0, 12.0])
def test_tremor_filter_gain_measured_by_streaming_a_sinusoid(freq_hz):
    """A 2 mm/s sinusoid of device x velocity streamed tick by tick for 20 s; the
    output's amplitude at that frequency (lock-in over the last 10 s, a whole number of
    cycles) gives the gain: <= -20 dB at 10 Hz (tremor), >= -1 dB at 1 Hz (voluntary
    motion), and equal to the design formula within 0.1 dB."""
    config = RetargetConfig(dead_band_mm_s=0.0, max_trap_speed_um_s=1e6, motion_scale_um_per_mm=1.0)
    t = np.arange(int(20 * TICK_HZ)) / TICK_HZ
    velocity = 2.0 * np.sin(2 * np.pi * freq_hz * t)
    dp = _run(Retargeter(config, TICK_HZ), [np.array([v, 0.0, 0.0]) for v in velocity])[:, 0] * TICK_HZ
    tail = t >= 10.0
    phasor = 2 * np.mean(dp[tail] * np.exp(-2j * np.pi * freq_hz * t[tail]))
    measured_db = 20 * np.log10(abs(phasor) / 2.0)
    assert abs(measured_db - tremor_filter_gain_db(config, TICK_HZ, freq_hz)) < 0.1
    if freq_hz == 10.0:
        assert measured_db <= -20.0
    if freq_hz == 1.0:
        assert measured_db >= -1.0


def test_config_validation_names_the_parameter():
    for kwargs, name in [
        ({"motion_scale_um_per_mm": 0.0}, "motion_scale_um_per_mm"),
        ({"dead_band_mm_s": -1.0}, "dead_band_mm_s"),
        ({"filter_order": 0}, "filter_order"),
        ({"clutch_bit": 40}, "clutch_bit"),
        ({"plane": "yz"}, "plane"),
    ]:
        with pytest.raises(ValueError, match=name):
            RetargetConfig(**kwargs)
    with pytest.raises(ValueError, match="tremor_cutoff_hz"):
        Retargeter(RetargetConfig(tremor_cutoff_hz=30.0), TICK_HZ)
