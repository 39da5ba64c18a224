"""otgym's ROS 2 messages (``otgym.bus.messages``): every type's bytes decode with an
independent CDR implementation and ROS 2's own definitions (rosbags' Humble type
store), round trips give back what was sent, and malformed messages are refused with
a reason."""

from __future__ import annotations

import json

import numpy as np
import pytest
from rosbags.typesys import Stores, get_typestore

from otgym.bus import messages as m
from otgym.teleop.device import Sample

TYPESTORE = get_typestore(Stores.ROS2_HUMBLE)
STAMP_S = 1_700_000_000.25
SAMPLE = Sample(10.0, 3, (1.0, 2.0, 3.0), (4.0, -5.0, 6.0), 0b101)


def rosbags(data: bytes, type_name: str):
    return TYPESTORE.deserialize_cdr(data, type_name)


def test_pose_array_decodes_with_rosbags_in_um_and_round_trips():
    xy = np.array([[1.5, -2.25], [300.0, 40.125]])
    data = m.pose_array(xy, STAMP_S)
    theirs = rosbags(data, m.POSE_ARRAY)
    assert [(p.position.x, p.position.y, p.position.z, p.orientation.w) for p in theirs.poses] == \
        [(1.5, -2.25, 0.0, 1.0), (300.0, 40.125, 0.0, 1.0)]
    assert (theirs.header.stamp.sec, theirs.header.stamp.nanosec, theirs.header.frame_id) == \
        (1_700_000_000, 250_000_000, "chip")
    ours = m.decode(m.TRAPS, data)
    np.testing.assert_array_equal(m.xy_um(ours), xy)
    assert m.stamp_s(ours) == STAMP_S


def test_twist_is_in_metres_per_second_and_round_trips_to_mm_s():
    data = m.twist(SAMPLE, STAMP_S, "left")
    theirs = rosbags(data, m.TWIST_STAMPED)
    assert (theirs.twist.linear.x, theirs.twist.linear.y, theirs.twist.linear.z) == pytest.approx((4e-3, -5e-3, 6e-3))
    assert theirs.header.frame_id == "left"
    np.testing.assert_allclose(m.velocity_mm_s(m.decode(m.twist_topic("left"), data)), SAMPLE.velocity_mm_s)


def test_joy_carries_each_button_bit_and_round_trips():
    data = m.joy(SAMPLE.buttons, STAMP_S, "left")
    assert list(rosbags(data, m.JOY).buttons) == [1, 0, 1, 0, 0, 0, 0, 0]
    assert m.button_bits(m.decode(m.buttons_topic("left"), data)) == 0b101
    assert m.button_bits(m.decode(m.buttons_topic("left"), m.joy(1 << 10, STAMP_S, "left"))) == 1 << 10


def test_wrench_in_newtons_round_trips():
    data = m.wrench((0.1, -0.2, 0.3), STAMP_S, "left")
    theirs = rosbags(data, m.WRENCH_STAMPED)
    assert (theirs.wrench.force.x, theirs.wrench.force.y, theirs.wrench.force.z) == (0.1, -0.2, 0.3)
    np.testing.assert_array_equal(m.force_n(m.decode(m.feedback_topic("left"), data)), [0.1, -0.2, 0.3])


def test_alpha_mode_and_events_decode_with_rosbags():
    assert rosbags(m.float64(0.35), m.FLOAT64).data == 0.35
    assert m.decode(m.ALPHA, m.float64(0.35)).data == 0.35
    assert rosbags(m.string("shared"), m.STRING).data == "shared"
    assert m.decode(m.MODE, m.string("shared")).data == "shared"
    data = m.event("trial_start", trial=2, scenario=20002)
    assert json.loads(rosbags(data, m.STRING).data) == {"event": "trial_start", "trial": 2, "scenario": 20002}
    assert m.event_fields(m.decode(m.EVENTS, data))["trial"] == 2


def test_commands_decode_with_rosbags_and_a_bad_one_is_never_sent():
    for data in (m.command("mode", "autonomous"), m.command("pause"), m.command("next_trial")):
        assert json.loads(rosbags(data, m.STRING).data) == m.event_fields(m.decode(m.COMMAND, data))
    assert m.event_fields(m.decode(m.COMMAND, m.command("mode", "manual"))) == {"command": "mode", "mode": "manual"}
    with pytest.raises(m.MessageError, match="unknown mode"):
        m.command("mode", "telepathic")


def test_sample_rebuilt_from_twist_and_buttons_on_the_receivers_clock():
    message = m.decode(m.twist_topic("left"), m.twist(SAMPLE, STAMP_S, "left"))
    sample = m.sample_from(message, 0b101, 55.0, 9)
    assert (sample.time_s, sample.sequence, sample.buttons) == (55.0, 9, 0b101) and sample.finite
    np.testing.assert_allclose(sample.velocity_mm_s, SAMPLE.velocity_mm_s)


def test_every_schema_names_the_fields_of_the_ros2_definition():
    """Our schema text's own fields (first block) are ROS 2 Humble's, in order."""
    for type_name, text in m.SCHEMAS.items():
        ours = [line.split()[1] for line in text.split("=" * 80)[0].strip().splitlines()]
        theirs = [name for name, _ in TYPESTORE.fielddefs[type_name][1]]
        assert ours == theirs, type_name


@pytest.mark.parametrize("topic, data, reason", [
    (m.TRAPS, m.pose_array([[1.0, 2.0]], STAMP_S)[:20], "does not decode"),
    (m.TRAPS, b"\x01\x00\x00\x00" + m.pose_array([[1.0, 2.0]], STAMP_S)[4:], "not little-endian CDR"),
    (m.TRAPS, b"", "not little-endian CDR"),
    (m.TRAPS, m.pose_array([[np.nan, 2.0]], STAMP_S), "not finite"),
    (m.TRAPS, m.pose_array([[2e6, 2.0]], STAMP_S), "exceeds"),
    (m.twist_topic("left"), m.twist(Sample(0, 0, np.zeros(3), (np.inf, 0, 0), 0), STAMP_S, "l"), "not finite"),
    (m.twist_topic("left"), m.twist(Sample(0, 0, np.zeros(3), (2e4, 0, 0), 0), STAMP_S, "l"), "exceeds"),
    (m.feedback_topic("left"), m.wrench((1e3, 0, 0), STAMP_S, "l"), "force (N) exceeds"),
    (m.buttons_topic("left"), m.encode(m.JOY, {"header": {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": ""},
                                                "axes": [], "buttons": [2]}), "0 or 1"),
    (m.ALPHA, m.float64(1.5), "alpha must lie in [0, 1]"),
    (m.ALPHA, m.float64(np.nan), "alpha must lie in [0, 1]"),
    (m.MODE, m.string("telepathic"), "unknown mode"),
    (m.EVENTS, m.string("not json"), "not JSON"),
    (m.EVENTS, m.string("[1, 2]"), "JSON object"),
    (m.COMMAND, m.string("pause"), "not JSON"),
    (m.COMMAND, m.string(json.dumps({"command": "selfdestruct"})), "one of mode, pause"),
    (m.COMMAND, m.string(json.dumps({"command": "mode", "mode": "telepathic"})), "unknown mode"),
    (m.COMMAND, m.string(json.dumps({"command": "mode"})), "takes the fields"),
    (m.COMMAND, m.string(json.dumps({"command": "reset", "trial": 3})), "takes the fields"),
    (m.twist_topic("left"), m.float64(0.5), "does not decode"),
    ("/otgym/elsewhere", m.float64(0.5), "unknown topic"),
    ("/otgym/device/../twist", m.float64(0.5), "unknown topic"),
])
def test_malformed_messages_are_refused_with_the_reason(topic, data, reason):
    with pytest.raises(m.MessageError, match=reason.replace("(", r"\(").replace(")", r"\)").replace("[", r"\[")):
        m.decode(topic, data)


def test_device_names_must_be_topic_tokens():
    with pytest.raises(ValueError, match="device name"):
        m.twist_topic("a/b")
    assert m.topic_type(m.feedback_topic("touch_1")) == m.WRENCH_STAMPED
