"""otgym's topics as ROS 2 messages: every message's bytes decode with an independent
CDR implementation (mcap-ros2-support's decoder, built from our ros2msg schema text,
where the encoder is rosbags') to the values sent; ``decode`` round-trips them; and a
malformed or out-of-range message is refused with its reason."""

import json
import struct

import numpy as np
import pytest
from mcap.records import Schema
from mcap_ros2.decoder import DecoderFactory

from otgym.bus import messages as msg


def independent_decode(type_name: str, data: bytes):
    schema = Schema(id=1, name=type_name, encoding="ros2msg", data=msg.schema_text(type_name).encode())
    return DecoderFactory().decoder_for("cdr", schema)(data)


def test_traps_and_bodies_decode_independently_to_the_positions_and_yaws_sent():
    traps = np.array([[1.5, -2.25], [300.0, 12.5], [0.0, 0.0], [-7.0, 8.0]])
    decoded = independent_decode("geometry_msgs/msg/PoseArray", msg.encode_traps(traps, 12.75))
    assert decoded.header.stamp.sec == 12 and decoded.header.stamp.nanosec == 750_000_000
    assert decoded.header.frame_id == "chip_um"
    np.testing.assert_array_equal([[p.position.x, p.position.y] for p in decoded.poses], traps)
    pose = np.array([[10.0, 20.0, 0.3], [-5.0, 4.0, -2.0]])
    decoded = independent_decode("geometry_msgs/msg/PoseArray", msg.encode_bodies(pose, 0.0))
    yaw = [2 * np.arctan2(p.orientation.z, p.orientation.w) for p in decoded.poses]
    np.testing.assert_allclose(yaw, pose[:, 2], atol=1e-12)
    back = msg.decode(msg.BODIES_TOPIC, msg.encode_bodies(pose, 3.5))
    np.testing.assert_allclose(back["xy_um"], pose[:, :2])
    np.testing.assert_allclose(back["yaw_rad"], pose[:, 2], atol=1e-12)
    assert back["time_s"] == 3.5


def test_device_twist_buttons_and_feedback_decode_independently_in_si_units():
    twist = independent_decode("geometry_msgs/msg/TwistStamped", msg.encode_twist([12.0, -3.0, 0.5], 1.0))
    np.testing.assert_allclose([twist.twist.linear.x, twist.twist.linear.y, twist.twist.linear.z],
                               [0.012, -0.003, 0.0005])
    joy = independent_decode("sensor_msgs/msg/Joy", msg.encode_buttons(0b101, 4, 1.0))
    assert list(joy.buttons) == [1, 0, 1, 0] and len(joy.axes) == 0
    wrench = independent_decode("geometry_msgs/msg/WrenchStamped", msg.encode_feedback([0.1, -0.2, 0.0], 2.0))
    assert (wrench.wrench.force.x, wrench.wrench.force.y, wrench.wrench.torque.z) == (0.1, -0.2, 0.0)
    topic = msg.device_twist_topic("left")
    np.testing.assert_allclose(msg.decode(topic, msg.encode_twist([12.0, -3.0, 0.5], 1.0))["velocity_mm_s"],
                               [12.0, -3.0, 0.5])
    assert msg.decode(msg.device_buttons_topic("left"), msg.encode_buttons(0b101, 4, 1.0))["bits"] == 0b101
    np.testing.assert_allclose(msg.decode(msg.feedback_topic("left"), msg.encode_feedback([0.1, -0.2, 0], 2.0))
                               ["force_n"], [0.1, -0.2, 0.0])


def test_alpha_mode_and_events_decode_independently():
    assert independent_decode("std_msgs/msg/Float64", msg.encode_alpha(0.35)).data == 0.35
    assert independent_decode("std_msgs/msg/String", msg.encode_text("shared")).data == "shared"
    event = {"kind": "collision", "time_s": 41.2, "obstacle": 2}
    assert json.loads(independent_decode("std_msgs/msg/String", msg.encode_event(event)).data) == event
    assert msg.decode(msg.ALPHA_TOPIC, msg.encode_alpha(0.35)) == {"alpha": 0.35}
    assert msg.decode(msg.MODE_TOPIC, msg.encode_text("manual")) == {"mode": "manual"}
    assert msg.decode(msg.EVENTS_TOPIC, msg.encode_event(event)) == {"event": event}


def test_schema_lists_each_dependency_once_after_the_definition():
    text = msg.schema_text("geometry_msgs/msg/PoseArray")
    assert text.startswith("std_msgs/Header header\ngeometry_msgs/Pose[] poses\n")
    sections = [line[5:] for line in text.splitlines() if line.startswith("MSG: ")]
    assert sorted(sections) == sorted(["std_msgs/Header", "builtin_interfaces/Time", "geometry_msgs/Pose",
                                       "geometry_msgs/Point", "geometry_msgs/Quaternion"])


@pytest.mark.parametrize("topic, data, reason", [
    (msg.TRAPS_TOPIC, msg.encode_traps([[1.0, 2.0]], 0.0)[:-9], "does not decode"),
    (msg.TRAPS_TOPIC, msg.encode_traps([[np.nan, 2.0]], 0.0), "not finite"),
    (msg.TRAPS_TOPIC, msg.encode_traps([[1e6, 2.0]], 0.0), "beyond"),
    (msg.ALPHA_TOPIC, msg.encode_alpha(1.5), "outside [0, 1]"),
    (msg.ALPHA_TOPIC, msg.encode_alpha(float("inf")), "not finite"),
    (msg.MODE_TOPIC, msg.encode_text("telepathic"), "unknown mode"),
    ("/otgym/feedback/left", msg.encode_feedback([50.0, 0.0, 0.0], 0.0), "force above"),
    ("/otgym/device/left/twist", msg.encode_twist([5000.0, 0.0, 0.0], 0.0), "tip speed"),
    ("/otgym/device/left/buttons", msg.encode_buttons(0, 0, 0.0)[:-4] + struct.pack("<I", 1) + struct.pack("<i", 2),
     "0 or 1"),
    (msg.EVENTS_TOPIC, msg.encode_text("{not json"), "not JSON"),
    (msg.EVENTS_TOPIC, msg.encode_text("[1, 2]"), "JSON object"),
    (msg.ALPHA_TOPIC, b"\x00\x01\x00\x00", "does not decode"),
])
def test_malformed_or_out_of_range_messages_are_refused_with_the_reason(topic, data, reason):
    with pytest.raises(msg.MalformedMessage, match=reason.replace("[", r"\[").replace("]", r"\]")):
        msg.decode(topic, data)


def test_unknown_topics_and_bad_device_names_are_refused():
    with pytest.raises(ValueError, match="not an otgym topic"):
        msg.topic_type("/otgym/elsewhere")
    with pytest.raises(ValueError, match="ROS name"):
        msg.device_twist_topic("left hand")
