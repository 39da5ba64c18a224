"""The bridge's routing (``otgym.bus.ros2_bridge.Bridge``) with otgym's real bus and a
stand-in for rclpy's node that records what it is given: which way each topic goes,
the bytes unchanged, the checks on what comes from ROS 2, nothing sent back to its
sender, nothing sent to ROS 2 once closed. Needs no ROS 2 (the end-to-end test with
real rclpy is tests/bus/test_ros2_bridge.py)."""

from __future__ import annotations

import math
import threading

import pytest

from otgym.bus import messages as msg
from otgym.bus import ros2_bridge, ros2_markers
from otgym.bus.transport import Node
from tests.bus.test_nodes import free_endpoint, poll_until, wait_until

SETTINGS = ros2_bridge.Settings(
    {"devices": ["device0"], "autonomy": False, "rig": False, "twist_topics": ["/cmd_vel"], "twist_stamped_topics": [],
     "markers_period_s": 0.0}
)  # fmt: skip


class FakePublisher:
    def __init__(self):
        self.sent: list = []

    def publish(self, data) -> None:
        self.sent.append(data)


class FakeRos:
    """rclpy's node as the bridge uses it: publishers and raw subscriptions by topic name."""

    def __init__(self):
        self.publishers: dict[str, FakePublisher] = {}
        self.subscriptions: dict[str, object] = {}

    def create_publisher(self, message_class, topic, qos):
        return self.publishers.setdefault(topic, FakePublisher())

    def create_subscription(self, message_class, topic, callback, qos, raw=False):
        assert raw, "the bridge takes serialized messages"
        self.subscriptions[topic] = callback


@pytest.fixture
def bridged(monkeypatch):
    """(sim node, fake ROS node, bridge) on a loopback bus of their own."""
    monkeypatch.setattr(ros2_bridge, "message_class", lambda type_name: type_name)
    monkeypatch.setattr(ros2_bridge, "qos_profile", lambda qos: qos)
    monkeypatch.setattr(ros2_markers, "marker_array", lambda markers: markers)
    endpoint = free_endpoint()
    with Node("sim", "sim", listen=[endpoint]) as sim, Node("ros2", "ros2", connect=[endpoint]) as bus:
        ros = FakeRos()
        bridge = ros2_bridge.Bridge(bus, ros, SETTINGS)
        bridge.start()
        yield sim, ros, bridge
        bridge.close()


def twist_bytes(vx_m_s: float) -> bytes:
    zero = {"x": 0.0, "y": 0.0, "z": 0.0}
    header = {"stamp": {"sec": 1, "nanosec": 0}, "frame_id": "device0"}
    return msg.encode(
        msg.TWIST_STAMPED, {"header": header, "twist": {"linear": {**zero, "x": vx_m_s}, "angular": zero}}
    )


def test_outputs_reach_ros2_unchanged_and_inputs_reach_otgym_once(bridged):
    sim, ros, bridge = bridged
    sim.wait_for_subscribers(msg.TRAPS)
    traps = msg.pose_array([[1.0, 2.0], [3.0, 4.0]], 10.0)
    sim.publish(msg.TRAPS, traps)
    wait_until(lambda: "otgym/traps" in ros.publishers and ros.publishers["otgym/traps"].sent, 10.0)
    assert ros.publishers["otgym/traps"].sent == [traps]

    assert set(ros.subscriptions) == {
        "otgym/device/device0/twist",
        "otgym/device/device0/buttons",
        "otgym/command",
        "/cmd_vel",
    }
    got, lock = [], threading.Lock()

    def on_twist(topic, message, data):
        with lock:
            got.append(data)

    sim.subscribe(msg.twist_topic("device0"), on_twist)
    twist = twist_bytes(1e-3)
    forward = ros.subscriptions["otgym/device/device0/twist"]
    for _ in range(1000):  # the first may go before the bus has routed the bridge's new publisher
        forward(twist)
        if poll_until(lambda: len(got) > 0, 0.01):
            break
    assert got and got[0] == twist
    assert "otgym/device/device0/twist" not in ros.publishers  # an input is never sent back to ROS 2
    assert poll_until(lambda: bridge.to_otgym >= 1, 5.0)  # counted after the bus has it: the sim may be first


def test_a_bad_message_from_ros2_is_dropped_and_counted(bridged):
    sim, ros, bridge = bridged
    ros.subscriptions["otgym/device/device0/twist"](twist_bytes(math.nan))
    ros.subscriptions["otgym/command"](msg.string('{"command": "explode"}'))
    expected = {"/otgym/device/device0/twist": 1, "/otgym/command": 1}
    assert poll_until(lambda: bridge.dropped == expected, 10.0), bridge.dropped  # checked on the sending thread
    assert bridge.to_otgym == 0


def test_nothing_goes_to_ros2_once_closed(bridged):
    sim, ros, bridge = bridged
    sim.wait_for_subscribers(msg.PHASE)
    sim.publish(msg.PHASE, msg.string("approach"))
    wait_until(lambda: "otgym/phase" in ros.publishers and ros.publishers["otgym/phase"].sent, 10.0)
    bridge.close()
    for _ in range(20):
        sim.publish(msg.PHASE, msg.string("carry"))
    assert not poll_until(lambda: len(ros.publishers["otgym/phase"].sent) > 1, 1.0)
