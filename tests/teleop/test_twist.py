"""The Twist device (``otgym.teleop.twist``): mapping, clamping, non-finite commands
dropped and counted, silence as zero input; and end to end, a ROS 2 teleop's
``geometry_msgs/Twist`` on ``/cmd_vel`` (CDR written here by hand, key and attachment as
rmw_zenoh writes them) moving a robot through a device node and the simulator's loop."""

from __future__ import annotations

import struct
import threading
import time

import numpy as np
import pytest

from otgym.bus import twist_source
from otgym.bus.intake import TYPE_HASH
from otgym.bus.transport import Node
from otgym.teleop.twist import CLUTCH, TwistDevice


class Clock:
    def __init__(self):
        self.now_s = 100.0

    def __call__(self) -> float:
        return self.now_s


def test_linear_x_and_y_become_the_tip_velocity_clamped_with_the_clutch_held():
    clock = Clock()
    device = TwistDevice(mm_s_per_m_s=4.0, max_speed_mm_s=10.0, clock=clock)
    assert device.feed((0.5, -0.25, 9.0))
    sample = device.read()
    np.testing.assert_allclose(sample.velocity_mm_s, [2.0, -1.0, 0.0])  # z is not used
    assert sample.buttons == CLUTCH
    assert device.feed((10.0, 0.0, 0.0))
    clock.now_s += 0.001
    np.testing.assert_allclose(device.read().velocity_mm_s, [10.0, 0.0, 0.0])  # 40 mm/s clamped to 10
    assert device.clamped == 1 and device.received == 2


def test_a_non_finite_command_is_dropped_and_counted_and_the_last_good_one_stays():
    clock = Clock()
    device = TwistDevice(clock=clock)
    device.feed((0.5, 0.0, 0.0))
    assert not device.feed((float("nan"), 0.0, 0.0)) and not device.feed((0.0, float("inf"), 0.0))
    clock.now_s += 0.1
    assert device.dropped_nonfinite == 2
    np.testing.assert_allclose(device.read().velocity_mm_s, [2.0, 0.0, 0.0])


def test_silence_is_zero_input_with_the_clutch_released_and_samples_stay_fresh_meanwhile():
    clock = Clock()
    device = TwistDevice(timeout_s=0.5, rate_hz=50.0, clock=clock)
    assert device.read().buttons == 0 and not device.read().velocity_mm_s.any()  # nothing received yet
    device.feed((0.5, 0.0, 0.0))
    first = device.read()
    clock.now_s += 0.49
    held = device.read()
    assert held.sequence > first.sequence and held.time_s == clock.now_s and held.buttons == CLUTCH
    clock.now_s += 0.02
    silent = device.read()
    assert silent.buttons == 0 and not silent.velocity_mm_s.any()


@pytest.mark.parametrize("option", ["mm_s_per_m_s", "max_speed_mm_s", "timeout_s", "rate_hz"])
def test_bad_options_are_refused(option):
    with pytest.raises(ValueError, match=option):
        TwistDevice(**{option: float("nan")})


def twist_cdr(vx_m_s: float, vy_m_s: float) -> bytes:
    """A geometry_msgs/Twist as Fast-CDR writes it: encapsulation 00 01 00 00, six float64."""
    return b"\x00\x01\x00\x00" + struct.pack("<6d", vx_m_s, vy_m_s, 0.0, 0.0, 0.0, 0.5)


@pytest.mark.slow
def test_a_ros2_teleop_twist_on_cmd_vel_moves_the_robot_and_silence_holds_the_traps():
    from otgym.bus.nodes import RemoteDevice, run_device_node
    from otgym.runtime.loop import DeviceBinding, InteractiveLoop
    from tests.bus.test_nodes import free_endpoint, wait_until
    from tests.bus.test_ros2_graph import peer_session
    from tests.task import fast_scenario, shared_task

    task = shared_task()
    endpoint = free_endpoint()
    stop = threading.Event()
    with Node("sim", "sim", listen=[endpoint]) as sim, Node("device", "device0", connect=[endpoint]) as device_node:
        remote = RemoteDevice(sim, "device0")
        loop = InteractiveLoop(task, [DeviceBinding(remote, robots=(0,))], fast_scenario(7), "manual")
        loop.start()
        device = TwistDevice()
        assert twist_source.attach(device_node, device) == "/cmd_vel"
        worker = threading.Thread(target=run_device_node, args=(device_node, device, "device0", stop), daemon=True)
        worker.start()
        teleop = peer_session(endpoint)
        try:
            key = f"0/cmd_vel/geometry_msgs::msg::dds_::Twist_/{TYPE_HASH['geometry_msgs/msg/Twist']}"
            sequence = iter(range(1, 100_000))

            def send(vx, vy=0.0, at=key):
                attachment = struct.pack("<qqB", next(sequence), time.time_ns(), 16) + b"teleop_keyboard!"
                teleop.put(at, twist_cdr(vx, vy), attachment=attachment)

            wait_until(lambda: (send(0.5), remote.alive and device.received > 0 and remote.read() is not None)[1], 30)
            driven = []
            for _ in range(30):
                send(0.5)
                driven.append(loop.tick())
                time.sleep(0.02)
            moved = np.array([r.human_um[0] for r in driven[10:]])
            assert (moved[:, 0] > 0).all() and np.abs(moved[:, 1]).max() < 1e-9  # +x forward, as sent
            wrong = key.replace(TYPE_HASH["geometry_msgs/msg/Twist"], "RIHS01_" + "3" * 64)
            for _ in range(5):
                send(-0.5, at=wrong)  # a Twist of another definition: never applied
            wait_until(lambda: device_node.dropped.get("/cmd_vel", 0) == 5, 5.0)
            silent_since = time.monotonic()
            wait_until(lambda: time.monotonic() - silent_since > device.timeout_s + 0.2, 5.0)
            held = loop.run(0.2, realtime=True)
            for record in held:
                np.testing.assert_array_equal(record.human_um, 0.0)
                np.testing.assert_array_equal(record.trap_xy_um, held[0].trap_xy_um)
        finally:
            stop.set()
            worker.join(5.0)
            teleop.close()
