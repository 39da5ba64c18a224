"""A ROS 2 node written with rclpy alone (no otgym import), run as its own process by
tests/bus/test_ros2_bridge.py against ``otgym node sim`` and ``otgym node ros2``.

It waits (each wait bounded by the deadline given as its first argument, in seconds)
until the graph lists the bridge's node ``otgym_ros2`` publishing ``/otgym/traps`` and
``/otgym/markers`` (``result["topics"]``: what that node publishes, with types), then
until it has received at least ``MIN_POSE_ARRAYS`` PoseArrays on ``/otgym/traps`` and a
MarkerArray with spheres on ``/otgym/markers``; then it publishes a TwistStamped on
``/otgym/device/device0/twist`` (+x, clutch held through ``/otgym/device/device0/buttons``)
until the traps' mean has moved ``MOVE_UM`` along +x from where they were, and
releases (with ``--listen-only`` as its second argument it drives nothing). It prints
one JSON line with what it saw (``result: {...}``) and exits 0, or prints the line with
``"failed"`` naming the first wait that ran out. SIGTERM ends its waits at once (what
it saw is reported as for a deadline)."""

from __future__ import annotations

import json
import signal
import sys
import time

import rclpy
from geometry_msgs.msg import PoseArray, TwistStamped
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions
from sensor_msgs.msg import Joy
from visualization_msgs.msg import Marker, MarkerArray

MIN_POSE_ARRAYS = 10
BRIDGE_NODE = "otgym_ros2"
MOVE_UM = 2.0
SPEED_M_S = 0.005
"""A device tip speed of 5 mm/s along x (the clutch held)."""


def main(deadline_s: float, drive: bool = True) -> int:
    rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
    node = rclpy.create_node("otgym_test_probe")
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    stream = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE)
    traps, markers, traps_s = [], [], []

    def on_traps(message: PoseArray) -> None:
        traps.append(message)
        traps_s.append(round(time.monotonic() - started, 2))

    node.create_subscription(PoseArray, "/otgym/traps", on_traps, QoSProfile(depth=100))
    node.create_subscription(MarkerArray, "/otgym/markers", markers.append, stream)
    twist = node.create_publisher(TwistStamped, "/otgym/device/device0/twist", stream)
    buttons = node.create_publisher(Joy, "/otgym/device/device0/buttons", stream)
    result: dict = {}
    started = time.monotonic()
    deadline = [started + deadline_s]
    signal.signal(signal.SIGTERM, lambda *_: deadline.__setitem__(0, 0.0))  # report what it saw, now

    def spin_until(condition, what: str) -> bool:
        while not condition():
            if time.monotonic() > deadline[0]:
                result["failed"] = what
                result["seen"] = {  # what it had, to tell a silent graph from a late one
                    "pose_arrays": len(traps),
                    "pose_arrays_at_s": traps_s,
                    "marker_arrays": len(markers),
                    "traps_publishers": node.count_publishers("/otgym/traps"),
                    "markers_publishers": node.count_publishers("/otgym/markers"),
                    "nodes": sorted(node.get_node_names()),
                    "waited_s": round(time.monotonic() - started, 1),
                }
                return False
            executor.spin_once(timeout_sec=0.05)
        return True

    def listed() -> bool:
        # what the bridge's node offers (the graph lists this probe's own subscriptions too)
        if BRIDGE_NODE not in node.get_node_names():
            return False
        offered = node.get_publisher_names_and_types_by_node(BRIDGE_NODE, "/")
        result["topics"] = {name: types for name, types in offered if name.startswith("/otgym")}
        return "/otgym/traps" in result["topics"] and "/otgym/markers" in result["topics"]

    def mean_x() -> float:
        poses = traps[-1].poses
        return sum(p.position.x for p in poses) / len(poses)

    def received() -> bool:
        return len(traps) >= MIN_POSE_ARRAYS and any(
            any(m.type == Marker.SPHERE for m in array.markers) for array in markers
        )

    ok = spin_until(listed, "the graph listing otgym_ros2 publishing /otgym/traps and /otgym/markers") and spin_until(
        received, f"{MIN_POSE_ARRAYS} PoseArrays and a MarkerArray with spheres"
    )
    if ok:
        result["pose_arrays"] = len(traps)
        result["pose_arrays_at_s"] = traps_s
        result["poses_per_array"] = sorted({len(t.poses) for t in traps})
        last = markers[-1].markers
        result["marker_namespaces"] = sorted({m.ns for m in last if m.ns})
        result["marker_frame"] = last[-1].header.frame_id
        start_x = result["start_x_um"] = mean_x()
    if ok and drive:

        def moved() -> bool:
            stamp = node.get_clock().now().to_msg()
            joy = Joy(buttons=[1])
            joy.header.stamp = stamp
            buttons.publish(joy)
            command = TwistStamped()
            command.header.stamp, command.header.frame_id = stamp, "device0"
            command.twist.linear.x = SPEED_M_S
            twist.publish(command)
            return mean_x() - start_x >= MOVE_UM

        if spin_until(moved, f"the traps moving {MOVE_UM} um along +x"):
            result["moved_x_um"] = mean_x() - start_x
        release = Joy(buttons=[0])
        release.header.stamp = node.get_clock().now().to_msg()
        buttons.publish(release)
        twist.publish(TwistStamped())
        executor.spin_once(timeout_sec=0.1)
    listed()  # again: the bridge's other publishers may have been discovered since
    print("result: " + json.dumps(result), flush=True)
    executor.shutdown()
    node.destroy_node()
    rclpy.shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main(float(sys.argv[1]), drive=sys.argv[2:] != ["--listen-only"]))
