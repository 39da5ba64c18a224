"""otgym's ROS 2 messages (``otgym.bus.messages``): every type's bytes decode under
another distribution's definitions (rosbags' Humble type store; otgym encodes with its
Jazzy store, ``otgym.bus.schemas``; an independent CDR implementation, mcap-ros2-support,
reads otgym's recordings in ``tests/record/test_mcap_file.py``), round trips give back
what was sent, and malformed messages are refused with a reason."""

from __future__ import annotations

import io
import json
import types

import numpy as np
import pytest
from PIL import Image
from rosbags.typesys import Stores, get_typestore

from otgym.bus import messages as m
from otgym.bus import schemas, task_messages
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
    assert [(p.position.x, p.position.y, p.position.z, p.orientation.w) for p in theirs.poses] == [
        (1.5, -2.25, 0.0, 1.0),
        (300.0, 40.125, 0.0, 1.0),
    ]
    assert (theirs.header.stamp.sec, theirs.header.stamp.nanosec, theirs.header.frame_id) == (
        1_700_000_000,
        250_000_000,
        "chip",
    )
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
    """The schema text's own fields (first block, as rosbags generates it from Jazzy's
    definitions) are ROS 2 Humble's, in order: recordings read the same in both."""
    for type_name, text in schemas.SCHEMAS.items():
        ours = [line.split()[1] for line in text.split("=" * 80)[0].strip().splitlines()]
        theirs = [name for name, _ in TYPESTORE.fielddefs[type_name][1]]
        assert ours == theirs, type_name


def stand_in_task():
    """What ``session_messages`` reads of a task: two robot spheres (the first a handle), a cell."""
    from otgym.physics.bodies import BodyKind
    from otgym.sim.chip import load_chip

    model = types.SimpleNamespace(
        sphere_body=[0, 0, 1], body_kinds=[BodyKind.ROBOT, BodyKind.CELL], sphere_radius_um=[1.5, 1.5, 4.0]
    )
    return types.SimpleNamespace(
        chip=load_chip("default"),
        scene=types.SimpleNamespace(model=model),
        trap_sphere=np.array([0]),
        route_um=np.array([[15.0, 40.0], [60.0, 40.5]]),
        config=types.SimpleNamespace(goal_tolerance_um=3.0, tick_s=0.02),
    )


def test_the_session_description_chip_and_route_decode_with_rosbags():
    from otgym.sim.chip import load_chip

    task = stand_in_task()
    messages = dict(task_messages.session_messages(task, ["device0"], STAMP_S))
    assert list(messages) == [m.SESSION, m.CHIP, m.ROUTE] and set(m.LATCHED) == {
        m.SESSION,
        m.CHIP,
        m.ROUTE,
        m.MODE,
        m.TRIAL,
        m.RIG_START,
    }
    description = json.loads(rosbags(messages[m.SESSION], m.STRING).data)
    assert description["sphere_body"] == [0, 0, 1]
    assert description["chip"]["content_hash"] == load_chip("default").content_hash
    assert description["sphere_kind"] == ["robot", "robot", "cell"] and description["handle_spheres"] == [0]
    assert (description["tick_s"], description["goal_tolerance_um"], description["devices"]) == (0.02, 3.0, ["device0"])
    image = rosbags(messages[m.CHIP], m.COMPRESSED_IMAGE)
    assert image.format == "png" and image.header.frame_id == "chip"
    with Image.open(io.BytesIO(image.data.tobytes())) as picture:
        np.testing.assert_array_equal(np.asarray(picture, np.float32) / np.float32(255), load_chip("default").image)
    route = rosbags(messages[m.ROUTE], m.PATH)
    assert [(p.pose.position.x, p.pose.position.y) for p in route.poses] == [(15.0, 40.0), (60.0, 40.5)]
    assert route.header.frame_id == "chip" and route.poses[1].header.stamp.nanosec == 250_000_000
    for topic, data in messages.items():
        m.decode(topic, data)  # our checks pass them


def test_tick_messages_carry_the_mode_only_when_given():
    record = types.SimpleNamespace(
        trap_xy_um=np.zeros((2, 2)),
        phase=0,
        alpha=0.5,
        feedback_n=np.zeros((1, 3)),
        sensed_force_pn=np.array([[1.0, -2.0], [np.nan, np.nan]]),
        sensed_valid=np.array([True, False]),
    )
    without_mode = dict(task_messages.tick_messages(record, ["device0"], np.zeros((3, 2)), STAMP_S))
    assert m.MODE not in without_mode
    # the contact force: the valid handle's reading only, pN -> N (a NaN or an invalid one would spoil it)
    contact = m.decode(m.CONTACT_FORCE, without_mode[m.CONTACT_FORCE])
    np.testing.assert_allclose(m.force_n(contact), [1e-12, -2e-12, 0.0])
    with_mode = task_messages.tick_messages(record, ["device0"], np.zeros((3, 2)), STAMP_S, "shared")
    assert m.decode(m.MODE, dict(with_mode)[m.MODE]).data == "shared"
    assert [topic for topic, _ in with_mode][-2:] == [m.BODIES, m.feedback_topic("device0")]


def _session(**changes) -> bytes:
    description = task_messages.session_description(stand_in_task(), [])
    for key, value in changes.items():
        if key.startswith("chip_"):
            description["chip"][key[5:]] = value
        else:
            description[key] = value
    return m.string(json.dumps(description))


def _image(format_: str, data: bytes) -> bytes:
    return m.encode(
        m.COMPRESSED_IMAGE,
        {"header": {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": "chip"}, "format": format_, "data": data},
    )


@pytest.mark.parametrize(
    "topic, data, reason",
    [
        (m.SESSION, m.string("{"), "not JSON"),
        (m.SESSION, _session(chip=None), '"chip" object'),
        (m.SESSION, _session(chip_content_hash="abc"), "content_hash"),
        (m.SESSION, _session(chip_pixel_size_um=-1), "pixel_size_um must be a positive number"),
        (m.SESSION, _session(tick_s="fast"), "tick_s must be a positive number"),
        (m.SESSION, _session(sphere_kind=["robot", "dragon"]), "sphere_kind"),
        (m.SESSION, _session(handle_spheres=[7]), "handle_spheres"),
        (m.CHIP, _image("jpeg", m.PNG_SIGNATURE + b"x"), "must be a PNG"),
        (m.CHIP, _image("png", b"GIF89a.."), "must be a PNG"),
        (m.ROUTE, m.path([[np.nan, 1.0]], STAMP_S), "not finite"),
        (m.TRAPS, m.pose_array([[1.0, 2.0]], STAMP_S)[:20], "does not decode"),
        (m.TRAPS, b"\x01\x00\x00\x00" + m.pose_array([[1.0, 2.0]], STAMP_S)[4:], "not little-endian CDR"),
        (m.TRAPS, b"", "not little-endian CDR"),
        (m.TRAPS, m.pose_array([[np.nan, 2.0]], STAMP_S), "not finite"),
        (m.TRAPS, m.pose_array([[2e6, 2.0]], STAMP_S), "exceeds"),
        (m.twist_topic("left"), m.twist(Sample(0, 0, np.zeros(3), (np.inf, 0, 0), 0), STAMP_S, "l"), "not finite"),
        (m.twist_topic("left"), m.twist(Sample(0, 0, np.zeros(3), (2e4, 0, 0), 0), STAMP_S, "l"), "exceeds"),
        (m.feedback_topic("left"), m.wrench((1e3, 0, 0), STAMP_S, "l"), "force (N) exceeds"),
        (
            m.buttons_topic("left"),
            m.encode(
                m.JOY, {"header": {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": ""}, "axes": [], "buttons": [2]}
            ),
            "0 or 1",
        ),
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
    ],
)
def test_malformed_messages_are_refused_with_the_reason(topic, data, reason):
    with pytest.raises(m.MessageError, match=reason.replace("(", r"\(").replace(")", r"\)").replace("[", r"\[")):
        m.decode(topic, data)


def test_device_names_must_be_topic_tokens():
    with pytest.raises(ValueError, match="device name"):
        m.twist_topic("a/b")
    assert m.topic_type(m.feedback_topic("touch_1")) == m.WRENCH_STAMPED
