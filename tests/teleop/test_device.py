"""The device protocol: samples, capabilities, force saturation and ``open_device``."""

from __future__ import annotations

import numpy as np
import pytest

from otgym import registry
from otgym.teleop.device import DeviceCaps, Sample, open_device, saturate_force


def test_unknown_device_name_lists_the_choices():
    with pytest.raises(ValueError, match="unknown device 'spacemouse'") as info:
        open_device("spacemouse")
    assert all(name in str(info.value) for name in registry.names("devices", "driver"))


def test_sample_holds_read_only_vectors_and_checks_shapes():
    sample = Sample(1.0, 3, [1, 2, 3], [0, 0, np.nan], 5)
    assert sample.position_mm.dtype == np.float64 and not sample.position_mm.flags.writeable
    assert not sample.finite
    assert Sample(1.0, 3, [1, 2, 3], [0, 0, 0], 0).finite
    with pytest.raises(ValueError, match="position_mm"):
        Sample(1.0, 3, [1, 2], [0, 0, 0], 0)
    with pytest.raises(ValueError, match="buttons"):
        Sample(1.0, 3, [1, 2, 3], [0, 0, 0], -1)


def test_caps_are_validated():
    DeviceCaps("ok", 3, 0.88, (160, 120, 70), 1000.0)
    with pytest.raises(ValueError, match="dof"):
        DeviceCaps("bad", 0, 0.0, (1, 1, 1), 1.0)
    with pytest.raises(ValueError, match="force_limit_n"):
        DeviceCaps("bad", 3, -1.0, (1, 1, 1), 1.0)
    with pytest.raises(ValueError, match="workspace_mm"):
        DeviceCaps("bad", 3, 0.0, (1, 0, 1), 1.0)
    with pytest.raises(ValueError, match="rate_hz"):
        DeviceCaps("bad", 3, 0.0, (1, 1, 1), 0.0)


def test_force_saturation_keeps_direction_and_rejects_non_finite():
    np.testing.assert_allclose(saturate_force([3.0, 4.0, 0.0], 0.88), [0.528, 0.704, 0.0])
    np.testing.assert_array_equal(saturate_force([0.1, 0.2, 0.0], 0.88), [0.1, 0.2, 0.0])
    np.testing.assert_array_equal(saturate_force([np.nan, 0.0, 0.0], 0.88), np.zeros(3))


def test_open_simulated_gives_a_servo_stylus_that_follows_its_hand():
    """``open_device("simulated")`` (it named a class that did not exist) gives a
    simulated stylus in its own servo process; held by a hand moving at 10 mm/s along
    x, 0.3 s of its own sample time after its first sample its tip has moved along x
    (more than 1 mm of the hand's 3, the stylus starting from rest) and reports a finite
    sample. The test waits for samples (60 s at most, a bound against hangs), never for
    a fixed time."""
    import time

    from otgym.teleop.servo import SteadyHand

    def wait_for(condition):
        deadline = time.monotonic() + 60.0
        while not condition(sample := device.read()):
            assert time.monotonic() < deadline, "the servo process gave no such sample within 60 s"
            time.sleep(0.01)
        return sample

    device = open_device("simulated", hand=SteadyHand(velocity_mm_s=(10.0, 0.0, 0.0)))
    device.start()
    try:
        first = wait_for(lambda sample: sample is not None)  # None until the first servo tick
        later = wait_for(lambda sample: sample.time_s >= first.time_s + 0.3)
    finally:
        device.stop()
    assert later.finite and later.sequence > first.sequence
    moved = later.position_mm - first.position_mm
    assert moved[0] > 1.0 and abs(moved[1]) < 0.1 * moved[0], moved


def test_every_driver_name_resolves_to_its_class_or_factory():
    """The name -> "module:callable" table names callables that exist (a typo in a
    module or class name fails here, not when a user first asks for that device)."""
    from otgym.teleop.device import driver
    from otgym.teleop.pygame_devices import GamepadDevice, KeyboardMouseDevice
    from otgym.teleop.replay import ReplayDevice
    from otgym.teleop.servo import simulated_haptic_device
    from otgym.teleop.touch import TouchDevice

    expected = {
        "keyboard": KeyboardMouseDevice,
        "gamepad": GamepadDevice,
        "touch": TouchDevice,
        "simulated": simulated_haptic_device,
        "replay": ReplayDevice,
    }
    assert set(registry.names("devices", "driver")) == set(expected)
    for name, made in expected.items():
        assert driver(name) is made, name
