"""``ForwardedDevice``: the latest fed sample, a lost link raises as a lost driver
does, forces go to ``on_force``; the retargeter takes its samples as a local device's."""

from __future__ import annotations

import time

import numpy as np
import pytest

from otgym.teleop.device import DeviceCaps, DeviceError, Sample
from otgym.teleop.forwarded import ForwardedDevice
from otgym.teleop.retarget import RetargetConfig, Retargeter

CAPS = DeviceCaps("keyboard and mouse", 2, 0.0, (160.0, 120.0, 70.0), 60.0)


def sample(sequence: int, vx: float = 2.0, buttons: int = 1) -> Sample:
    return Sample(time.monotonic(), sequence, np.zeros(3), (vx, 0.0, 0.0), buttons)


def test_read_gives_the_latest_fed_sample_and_raises_once_lost():
    device = ForwardedDevice(CAPS)
    assert device.read() is None
    device.feed(sample(1, 1.0))
    device.feed(sample(2, 3.0))
    assert device.read().sequence == 2 and device.read().velocity_mm_s[0] == 3.0
    device.lose("gamepad 0 was disconnected")
    with pytest.raises(DeviceError, match="keyboard and mouse: gamepad 0 was disconnected"):
        device.read()


def test_forces_go_to_on_force_and_nowhere_without_it():
    sent = []
    ForwardedDevice(CAPS, on_force=sent.append).set_force([0.1, 0.0, -0.2])
    ForwardedDevice(CAPS).set_force([0.1, 0.0, 0.0])  # no haptics: nothing to call
    assert len(sent) == 1 and np.allclose(sent[0], [0.1, 0.0, -0.2])


def test_a_forwarded_sample_moves_the_traps_as_the_device_itself_would():
    """The same samples through a ForwardedDevice and straight into a retargeter give
    the same increments (the retargeter sees only samples)."""
    config = RetargetConfig(clutch_bit=0)
    direct, forwarded = Retargeter(config, 50.0), Retargeter(config, 50.0)
    device = ForwardedDevice(CAPS)
    for sequence in range(1, 30):
        each = sample(sequence)
        device.feed(each)
        np.testing.assert_array_equal(forwarded(device.read(), each.time_s), direct(each, each.time_s))
    assert np.linalg.norm(direct(sample(31), time.monotonic())) > 0  # it moved at all


def test_a_takeover_device_passes_the_primary_until_the_other_holds_its_clutch():
    from otgym.teleop.takeover import TakeoverDevice

    sent = []
    primary, mouse = ForwardedDevice(CAPS, on_force=sent.append), ForwardedDevice(CAPS)
    device = TakeoverDevice(primary, mouse)
    primary.feed(sample(1, 1.0))
    assert device.read().velocity_mm_s[0] == 1.0  # nothing from the mouse yet
    mouse.feed(sample(1, 5.0, buttons=1))
    assert device.read().velocity_mm_s[0] == 5.0  # a drag takes over
    mouse.feed(sample(2, 5.0, buttons=0))
    assert device.read().velocity_mm_s[0] == 1.0  # released
    mouse.feed(Sample(time.monotonic() - 0.5, 3, np.zeros(3), (5.0, 0.0, 0.0), 1))
    assert device.read().velocity_mm_s[0] == 1.0  # a stale drag does not
    device.set_force([0.2, 0.0, 0.0])
    assert len(sent) == 1  # forces go to the primary
    assert TakeoverDevice(None, mouse).read() is None
