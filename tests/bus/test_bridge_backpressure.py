"""The ROS 2 bridge's back-pressure (``otgym.bus.ros2_bridge``, ``otgym.bus.handover``),
without ROS 2: the bridge between a stand-in bus and a stand-in rclpy node whose sending
side is stuck. A receiving callback (zenoh's for the bus, rclpy's executor for ROS 2)
must return at once whatever the other side does, a stream must cross as its latest
message only, and trial events and commands must all cross, in order."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from otgym.bus import messages as msg
from otgym.bus import ros2_bridge
from otgym.bus.ros2_bridge import PARAMETERS, Bridge, Settings

FEED_S = 10.0
"""Bound on handing over the whole feed: every callback returns at once unless it waits
on the stuck side, which never lets go before this."""


class _Gate:
    """Records what is sent through it; each send waits until ``open`` is set."""

    def __init__(self):
        self.open = threading.Event()
        self.sent: list[tuple[str, bytes]] = []

    def send(self, topic: str, data: bytes) -> None:
        self.open.wait()
        self.sent.append((topic, bytes(data)))

    def topic(self, topic: str) -> list[bytes]:
        return [data for name, data in self.sent if name == topic]

    def settle(self, last: bytes) -> None:
        """Wait (within FEED_S) until ``last`` has been sent."""
        deadline = time.monotonic() + FEED_S
        while all(data != last for _, data in self.sent) and time.monotonic() < deadline:
            time.sleep(0.01)


class _Token:
    def undeclare(self) -> None:
        pass


class _Bus:
    """Stands in for ``transport.Node``: ``subscribe`` keeps the callback, publishing goes through the gate."""

    name = "ros2"

    def __init__(self, gate: _Gate):
        self.gate, self.callbacks = gate, {}
        self.session = self
        self.publish = gate.send

    def liveliness(self):
        return self

    def declare_token(self, key: str) -> _Token:
        return _Token()

    def subscribe(self, pattern: str, callback) -> None:
        self.callbacks[pattern] = callback

    def publish_ros(self, topic: str, type_name: str, data: bytes) -> str:
        self.gate.send(topic, data)
        return topic


class _Publisher:
    def __init__(self, gate: _Gate, topic: str):
        self.gate, self.topic = gate, "/" + topic

    def publish(self, data) -> None:
        self.gate.send(self.topic, data)


class _Ros:
    """Stands in for an rclpy node: subscriptions kept by topic, publishing through the gate."""

    def __init__(self, gate: _Gate):
        self.gate, self.callbacks = gate, {}

    def create_publisher(self, message_type, topic: str, qos) -> _Publisher:
        return _Publisher(self.gate, topic)

    def create_subscription(self, message_type, topic: str, callback, qos, raw: bool = False) -> None:
        self.callbacks["/" + topic.lstrip("/")] = callback


@pytest.fixture
def bridge_parts(monkeypatch):
    """A started bridge (device0, a rig) between a stand-in bus and ROS 2 node, each with its own gate."""
    monkeypatch.setattr(ros2_bridge, "message_class", lambda type_name: type_name)
    monkeypatch.setattr(ros2_bridge, "qos_profile", lambda qos: qos)
    values = {name: default for name, (default, _) in PARAMETERS.items()}
    values["rig"] = True
    bus_gate, ros_gate = _Gate(), _Gate()
    bus, ros = _Bus(bus_gate), _Ros(ros_gate)
    bridge = Bridge(bus, ros, Settings(values))
    bridge.start()
    yield bridge, bus, ros
    bus_gate.open.set()
    ros_gate.open.set()
    bridge.close()


def _feed(calls) -> threading.Thread:
    """Run ``calls`` (callables) in order on a thread of their own, as zenoh or rclpy would; joined within FEED_S."""
    feeder = threading.Thread(target=lambda: [call() for call in calls], daemon=True)
    feeder.start()
    feeder.join(FEED_S)
    return feeder


def _poses(count: int) -> list[bytes]:
    return [msg.pose_array(np.full((4, 2), float(i)), 1000.0 + i) for i in range(count)]


def test_a_bridge_slower_than_the_bus_sends_the_latest_trap_command_and_every_event(bridge_parts):
    """200 trap commands and 5 trial events from the bus while ROS 2 publishing is stuck:
    every bus callback returns, then the traps cross as at most the one in flight and the
    latest, the events all and in order. Fails if the bus's callback publishes itself."""
    bridge, bus, ros = bridge_parts
    on_bus = bus.callbacks["/otgym/**"]
    traps = _poses(200)
    events = [msg.event("trial_start", trial=k) for k in range(5)]
    calls = []
    for i, data in enumerate(traps):
        calls.append(lambda data=data: on_bus(msg.TRAPS, msg.decode(msg.TRAPS, data), data))
        if i % 40 == 39:
            event = events[i // 40]
            calls.append(lambda data=event: on_bus(msg.EVENTS, msg.decode(msg.EVENTS, data), data))
    feeder = _feed(calls)
    ros.gate.open.set()
    assert not feeder.is_alive(), "the bus's callback waited on ROS 2 publishing"
    ros.gate.settle(events[-1])
    ros.gate.settle(traps[-1])
    sent = ros.gate.topic(msg.TRAPS)  # the one the sending thread had taken when the gate closed, and the latest
    assert sent[-1] == traps[-1] and len(sent) <= 2, len(sent)
    assert ros.gate.topic(msg.EVENTS) == events
    assert bridge.superseded >= len(traps) - 2


def test_a_bus_slower_than_ros2_sends_the_rigs_latest_poses_and_every_command(bridge_parts):
    """200 rig measurements and 3 commands from ROS 2 while publishing on the bus is
    stuck: every rclpy callback returns, then the poses cross as at most the one in
    flight and the latest, the commands all and in order. Fails if the rclpy callback
    publishes on the bus itself."""
    bridge, bus, ros = bridge_parts
    on_poses, on_command = ros.callbacks[msg.RIG_POSES], ros.callbacks[msg.COMMAND]
    poses = _poses(200)
    commands = [msg.command(name) for name in ("pause", "resume", "next_trial")]
    calls = [lambda data=data: on_poses(data) for data in poses]
    for k, command in enumerate(commands):
        calls.insert(60 * k + 30, lambda data=command: on_command(data))
    feeder = _feed(calls)
    bus.gate.open.set()
    assert not feeder.is_alive(), "the rclpy callback waited on the bus"
    bus.gate.settle(commands[-1])
    bus.gate.settle(poses[-1])
    sent = bus.gate.topic(msg.RIG_POSES)
    assert sent[-1] == poses[-1] and len(sent) <= 2, len(sent)
    assert bus.gate.topic(msg.COMMAND) == commands
    assert bridge.to_otgym == len(sent) + len(commands)
