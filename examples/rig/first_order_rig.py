#!/usr/bin/env python3
"""A minimal optical-tweezers rig for ``otgym node sim --plant rig``, written with rclpy
alone (no otgym import): a stand-in for a real rig's driver, to show the interface.

It reads, from the ROS 2 graph (through ``otgym node ros2 --ros-args -p rig:=true``):

- ``/otgym/session`` (``std_msgs/msg/String``, JSON, transient local): which body each
  sphere belongs to (``sphere_body``), its kind (``sphere_kind``), radius
  (``sphere_radius_um``) and the sphere each trap holds (``handle_spheres``);
- ``/otgym/rig/start`` (``geometry_msgs/msg/PoseArray``, transient local): where a
  trial starts every sphere, um, chip frame; the rig puts its bodies there;
- ``/otgym/traps`` (``PoseArray``): the commanded trap centres, um, chip frame;

and publishes ``/otgym/rig/poses`` (``PoseArray``): every sphere's centre, um, chip
frame, in the order of the session's spheres, stamped with the time it was measured,
``rate_hz`` times a second.

The law (first order, time constant ``time_constant_s``): each robot, a rigid body,
turns and moves toward the pose that puts its trapped spheres on their traps (the
least-squares rotation and translation in the plane), by the fraction
1 - exp(-dt / time_constant_s) of the way each step. A cell moves with the robots'
mean motion while every robot has a sphere within ``grip_um`` of the cell's surface
(it is held between them); every other body stays where it is.

Run (ROS 2 traffic on this machine only, in a domain of its own)::

    export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST ROS_DOMAIN_ID=91
    python examples/rig/first_order_rig.py --ros-args -p time_constant_s:=0.02

Ctrl-C ends it with its counts and how late the trap commands reached it (the time
each arrived less its header stamp, both UNIX time: the controller's, the bus's, the
bridge's and this loop's delay together).
"""

from __future__ import annotations

import json
import math
import signal
import sys
import time

import numpy as np


class FirstOrderRig:
    """The rig's bodies and law, without ROS: ``start`` places the spheres, ``command``
    sets the traps, ``advance(dt_s)`` moves the bodies and returns every sphere's centre."""

    def __init__(self, sphere_body, sphere_kind, sphere_radius_um, handle_spheres, time_constant_s, grip_um=0.5):
        if not (math.isfinite(time_constant_s) and time_constant_s > 0):
            raise ValueError(f"time_constant_s must be positive, got {time_constant_s!r}")
        self.body = np.asarray(sphere_body, int)
        self.kind = list(sphere_kind)
        self.radius = np.asarray(sphere_radius_um, float)
        self.handles = np.asarray(handle_spheres, int)
        self.time_constant_s, self.grip_um = float(time_constant_s), float(grip_um)
        self.robots = sorted({int(b) for b, k in zip(self.body, self.kind) if k == "robot"})
        self.cells = sorted({int(b) for b, k in zip(self.body, self.kind) if k == "cell"})
        self.xy = None
        self.traps = None

    def start(self, sphere_xy_um) -> None:
        xy = np.asarray(sphere_xy_um, float)
        if xy.shape != (len(self.body), 2):
            raise ValueError(f"a start needs {len(self.body)} spheres, got {xy.shape}")
        self.xy, self.traps = xy.copy(), None

    def command(self, trap_xy_um) -> None:
        traps = np.asarray(trap_xy_um, float)
        if traps.shape == (len(self.handles), 2) and np.all(np.isfinite(traps)):
            self.traps = traps

    def advance(self, dt_s: float):
        if self.xy is None:
            return None
        if self.traps is None:
            return self.xy.copy()
        fraction = 1.0 - math.exp(-dt_s / self.time_constant_s)
        before = {robot: self.xy[self.body == robot].mean(axis=0) for robot in self.robots}
        for robot in self.robots:
            mine = self.body[self.handles] == robot
            if not mine.any():
                continue
            handles, traps = self.xy[self.handles[mine]], self.traps[mine]
            pivot, target = handles.mean(axis=0), traps.mean(axis=0)
            h, p = handles - pivot, traps - target
            angle = math.atan2(float(np.sum(h[:, 0] * p[:, 1] - h[:, 1] * p[:, 0])), float(np.sum(h * p)))
            turn = fraction * angle
            rotation = np.array([[math.cos(turn), -math.sin(turn)], [math.sin(turn), math.cos(turn)]])
            spheres = self.body == robot
            self.xy[spheres] = (self.xy[spheres] - pivot) @ rotation.T + pivot + fraction * (target - pivot)
        moved = np.mean([self.xy[self.body == robot].mean(axis=0) - before[robot] for robot in self.robots], axis=0)
        for cell in self.cells:
            if self._held(cell):
                self.xy[self.body == cell] += moved
        return self.xy.copy()

    def _held(self, cell: int) -> bool:
        cell_spheres = np.flatnonzero(self.body == cell)
        centre = self.xy[cell_spheres].mean(axis=0)
        surface = self.radius[cell_spheres].max()
        for robot in self.robots:
            spheres = np.flatnonzero(self.body == robot)
            gaps = np.linalg.norm(self.xy[spheres] - centre, axis=1) - self.radius[spheres] - surface
            if gaps.min() > self.grip_um:
                return False
        return True


def main(argv: list[str]) -> int:
    import rclpy
    from geometry_msgs.msg import Pose, PoseArray
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from rclpy.signals import SignalHandlerOptions
    from std_msgs.msg import String

    # Ctrl-C (and SIGTERM) is Python's KeyboardInterrupt, raised between callbacks, even
    # where the rig was started with SIGINT ignored. rclpy's own handler would shut the
    # context down from the signal, and a spin that was building its wait set at that
    # moment raises RCLError ("the given context is not valid") instead.
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.signal(signal.SIGTERM, signal.default_int_handler)
    rclpy.init(args=argv, signal_handler_options=SignalHandlerOptions.NO)
    node = rclpy.create_node("first_order_rig")
    time_constant_s = node.declare_parameter("time_constant_s", 0.02).value
    rate_hz = node.declare_parameter("rate_hz", 100.0).value
    grip_um = node.declare_parameter("grip_um", 0.5).value
    latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    stream = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
    state = {"rig": None, "start": None, "starts": 0, "commands": 0, "published": 0}
    delays_s: list[float] = []

    def xy_of(message) -> np.ndarray:
        return np.array([[pose.position.x, pose.position.y] for pose in message.poses], float).reshape(-1, 2)

    def on_session(message) -> None:
        description = json.loads(message.data)
        state["rig"] = FirstOrderRig(
            description["sphere_body"],
            description["sphere_kind"],
            description["sphere_radius_um"],
            description["handle_spheres"],
            time_constant_s,
            grip_um,
        )
        if state["start"] is not None:
            state["rig"].start(state["start"])

    def on_start(message) -> None:
        state["start"] = xy_of(message)
        state["starts"] += 1
        if state["rig"] is not None:
            state["rig"].start(state["start"])

    def on_traps(message) -> None:
        stamp = message.header.stamp
        delays_s.append(time.time() - (stamp.sec + 1e-9 * stamp.nanosec))
        if state["rig"] is not None:
            state["rig"].command(xy_of(message))
            state["commands"] += 1

    publisher = node.create_publisher(PoseArray, "otgym/rig/poses", stream)
    last = [time.monotonic()]

    def on_timer() -> None:
        now = time.monotonic()
        dt_s, last[0] = now - last[0], now
        rig = state["rig"]
        xy = rig.advance(dt_s) if rig is not None else None
        if xy is None:
            return
        message = PoseArray()
        message.header.stamp = node.get_clock().now().to_msg()
        message.header.frame_id = "chip"
        for x, y in xy:
            pose = Pose()
            pose.position.x, pose.position.y = float(x), float(y)
            message.poses.append(pose)
        publisher.publish(message)
        state["published"] += 1

    node.create_subscription(String, "otgym/session", on_session, latched)
    node.create_subscription(PoseArray, "otgym/rig/start", on_start, latched)
    node.create_subscription(PoseArray, "otgym/traps", on_traps, stream)
    node.create_timer(1.0 / rate_hz, on_timer)
    print(f"ready: first-order rig, time constant {time_constant_s} s, {rate_hz} Hz", flush=True)
    try:
        rclpy.spin(node)
    except KeyboardInterrupt:
        pass
    finally:
        print(
            f"rig: {state['starts']} starts, {state['commands']} trap commands, {state['published']} poses published",
            flush=True,
        )
        if delays_s:
            p50, p99 = np.percentile(delays_s, [50, 99]) * 1e3
            print(
                f"rig: trap commands arrived {p50:.0f} ms (median), {p99:.0f} ms (99th percentile), "
                f"{max(delays_s) * 1e3:.0f} ms (most) after their stamp, n = {len(delays_s)}",
                flush=True,
            )
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
