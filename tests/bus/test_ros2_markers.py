"""``/otgym/markers``' content from the simulator's messages (``otgym.bus.ros2_markers``):
built from CDR messages as the bridge receives them; the ROS 2 message itself where
visualization_msgs can be imported."""

from __future__ import annotations

import io
import json

import numpy as np
import pytest
from PIL import Image

from otgym.bus import messages as msg
from otgym.bus.ros2_markers import MarkerTracker, marker_array

KINDS = ["robot", "robot", "cell", "obstacle"]
RADII_UM = [1.5, 1.5, 3.0, 2.0]
DESCRIPTION = {
    "chip": {"name": "test", "content_hash": "0" * 64, "pixel_size_um": 2.0, "channel_height_um": 10.0},
    "goal_tolerance_um": 4.0,
    "tick_s": 0.02,
    "sphere_kind": KINDS,
    "sphere_radius_um": RADII_UM,
    "handle_spheres": [0, 1],
}
BODIES_UM = np.array([[10.0, 5.0], [20.0, 5.0], [30.0, 8.0], [12.0, 14.0]])
TRAPS_UM = np.array([[10.5, 5.0], [20.5, 5.0]])
ROUTE_UM = np.array([[0.0, 0.0], [10.0, 4.0], [30.0, 4.0]])


def received(topic: str, data: bytes):
    return msg.decode_as(msg.topic_type(topic), data, topic)


def chip_png() -> bytes:
    image = np.full((12, 24), 255, np.uint8)
    image[4:8, 10:14] = 0  # one wall block inside the channel
    out = io.BytesIO()
    Image.fromarray(image).save(out, format="PNG")
    return out.getvalue()


def fed_tracker() -> MarkerTracker:
    tracker = MarkerTracker()
    assert tracker.take(msg.BODIES, received(msg.BODIES, msg.pose_array(BODIES_UM, 5.0))) is None  # no description yet
    for topic, data in (
        (msg.SESSION, msg.string(json.dumps(DESCRIPTION))),
        (msg.CHIP, msg.compressed_png(chip_png(), 1.0)),
        (msg.ROUTE, msg.path(ROUTE_UM, 1.0)),
        (msg.TRAPS, msg.pose_array(TRAPS_UM, 5.0)),
    ):
        assert tracker.take(topic, received(topic, data)) is None
    return tracker


def test_each_tick_draws_walls_route_goal_bodies_by_kind_and_traps():
    markers = fed_tracker().take(msg.BODIES, received(msg.BODIES, msg.pose_array(BODIES_UM, 5.25)))
    assert (markers.stamp_sec, markers.stamp_nanosec) == (5, 250_000_000)
    by_ns: dict[str, list] = {}
    for shape in markers.shapes:
        by_ns.setdefault(shape.namespace, []).append(shape)
    assert set(by_ns) == {"walls", "route", "goal", "robots", "cells", "obstacles", "traps"}
    assert len(by_ns["walls"]) >= 2  # the image border and the block inside it
    np.testing.assert_allclose(by_ns["route"][0].points_um, ROUTE_UM)
    assert by_ns["goal"][0].centre_um == (30.0, 4.0) and by_ns["goal"][0].size_um[:2] == (8.0, 8.0)
    for kind, namespace in (("robot", "robots"), ("cell", "cells"), ("obstacle", "obstacles")):
        index = [i for i, k in enumerate(KINDS) if k == kind]
        shapes = by_ns[namespace]
        assert [s.id for s in shapes] == list(range(len(index)))
        np.testing.assert_allclose([s.centre_um for s in shapes], BODIES_UM[index])
        np.testing.assert_allclose([s.size_um[0] for s in shapes], 2 * np.array(RADII_UM)[index])
    arms = by_ns["traps"][0].points_um
    assert arms.shape == (4 * len(TRAPS_UM), 2)
    np.testing.assert_allclose(arms.reshape(len(TRAPS_UM), 4, 2).mean(axis=1), TRAPS_UM)


def test_bodies_of_another_session_draw_nothing():
    other = msg.pose_array(BODIES_UM[:3], 5.0)
    assert fed_tracker().take(msg.BODIES, received(msg.BODIES, other)) is None


def test_the_ros2_message_clears_then_draws_every_shape():
    pytest.importorskip(
        "visualization_msgs.msg", reason="ROS 2's visualization_msgs wheel (extra [ros2]) cannot be imported here"
    )
    from visualization_msgs.msg import Marker

    markers = fed_tracker().take(msg.BODIES, received(msg.BODIES, msg.pose_array(BODIES_UM, 5.0)))
    array = marker_array(markers)
    assert array.markers[0].action == Marker.DELETEALL
    drawn = array.markers[1:]
    assert len(drawn) == len(markers.shapes)
    assert all(m.header.frame_id == "chip" and m.action == Marker.ADD for m in drawn)
    spheres = [m for m in drawn if m.type == Marker.SPHERE]
    np.testing.assert_allclose(
        sorted((m.pose.position.x, m.pose.position.y) for m in spheres), sorted(BODIES_UM.tolist())
    )
    route = next(m for m in drawn if m.ns == "route")
    assert route.type == Marker.LINE_STRIP and len(route.points) == len(ROUTE_UM)
