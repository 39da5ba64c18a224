"""The messages of otgym's topics: standard ROS 2 types, CDR-encoded, with their
ros2msg schemas, so ROS 2 tools (ros2 bag, Foxglove, rmw_zenoh nodes) can read them.

Topics and types (issue 12; units in the ``frame_id``):

=================================  ================================  =====================
topic                              type                              content
=================================  ================================  =====================
``/otgym/traps``                   geometry_msgs/msg/PoseArray       trap positions, um
``/otgym/bodies``                  geometry_msgs/msg/PoseArray       body poses, um and
                                                                     yaw (quaternion)
``/otgym/device/<name>/twist``     geometry_msgs/msg/TwistStamped    stylus tip velocity,
                                                                     m/s (SI, REP 103)
``/otgym/device/<name>/buttons``   sensor_msgs/msg/Joy               button bits
``/otgym/feedback/<name>``         geometry_msgs/msg/WrenchStamped   force to the device, N
``/otgym/shared/alpha``            std_msgs/msg/Float64              the human's share
``/otgym/mode``                    std_msgs/msg/String               manual/shared/...
``/otgym/events``                  std_msgs/msg/String               a trial event as JSON
=================================  ================================  =====================

Encoding: the rosbags type store of ROS 2 Humble (``rosbags.typesys``; its CDR
serialiser is little-endian with the 4-byte encapsulation header, as ROS 2's
Fast-CDR). Schemas: ROS 2's message definitions, concatenated with their dependencies
in the ros2msg form MCAP uses (dependencies after a line of 80 ``=`` and ``MSG:
pkg/Type``; the MCAP specification's "ros2msg" schema encoding).

Receiving (``decode``): the bytes are deserialised against the topic's type and
checked (every number finite, alpha in [0, 1], a known mode, positions within
``MAX_POSITION_UM`` of the origin, forces at most ``MAX_FORCE_N``); anything else
raises ``MalformedMessage`` with the reason, so a receiver drops and counts it and
never applies it.
"""

from __future__ import annotations

import json
import math

import numpy as np
from rosbags.typesys import Stores, get_typestore

from otgym.shared import MODES

TRAPS_TOPIC = "/otgym/traps"
BODIES_TOPIC = "/otgym/bodies"
ALPHA_TOPIC = "/otgym/shared/alpha"
MODE_TOPIC = "/otgym/mode"
EVENTS_TOPIC = "/otgym/events"
KNOWN_MODES = (*MODES, "mpc")
MAX_POSITION_UM = 1e5
"""Positions beyond 10 cm of the chip's origin are no chip's: refused."""
MAX_FORCE_N = 10.0
"""Ten times the strongest desktop haptic device's peak force: a larger command is refused."""
MAX_SPEED_M_S = 1.0
"""A stylus tip faster than 1 m/s is no hand's: refused."""

_DEFINITIONS = {
    "builtin_interfaces/Time": "int32 sec\nuint32 nanosec",
    "std_msgs/Header": "builtin_interfaces/Time stamp\nstring frame_id",
    "geometry_msgs/Point": "float64 x\nfloat64 y\nfloat64 z",
    "geometry_msgs/Quaternion": "float64 x\nfloat64 y\nfloat64 z\nfloat64 w",
    "geometry_msgs/Pose": "geometry_msgs/Point position\ngeometry_msgs/Quaternion orientation",
    "geometry_msgs/PoseArray": "std_msgs/Header header\ngeometry_msgs/Pose[] poses",
    "geometry_msgs/Vector3": "float64 x\nfloat64 y\nfloat64 z",
    "geometry_msgs/Twist": "geometry_msgs/Vector3 linear\ngeometry_msgs/Vector3 angular",
    "geometry_msgs/TwistStamped": "std_msgs/Header header\ngeometry_msgs/Twist twist",
    "geometry_msgs/Wrench": "geometry_msgs/Vector3 force\ngeometry_msgs/Vector3 torque",
    "geometry_msgs/WrenchStamped": "std_msgs/Header header\ngeometry_msgs/Wrench wrench",
    "sensor_msgs/Joy": "std_msgs/Header header\nfloat32[] axes\nint32[] buttons",
    "std_msgs/Float64": "float64 data",
    "std_msgs/String": "string data",
}
"""ROS 2 Humble's definitions of the types used (comments and constants left out)."""

_STORE = get_typestore(Stores.ROS2_HUMBLE)


class MalformedMessage(ValueError):
    """A received message that does not decode, or decodes to values out of range."""


def schema_text(type_name: str) -> str:
    """The ros2msg schema of ``type_name`` (e.g. "geometry_msgs/msg/PoseArray"): its
    definition, then each dependency once, depth first."""
    short = type_name.replace("/msg/", "/")
    seen, order = {short}, []

    def visit(name):
        for line in _DEFINITIONS[name].splitlines():
            field_type = line.split()[0].rstrip("[]")
            if "/" in field_type and field_type not in seen:
                seen.add(field_type)
                order.append(field_type)
                visit(field_type)

    visit(short)
    sections = [_DEFINITIONS[short]] + [f"{'=' * 80}\nMSG: {name}\n{_DEFINITIONS[name]}" for name in order]
    return "\n".join(sections) + "\n"


def device_twist_topic(device: str) -> str:
    return f"/otgym/device/{_check_name(device)}/twist"


def device_buttons_topic(device: str) -> str:
    return f"/otgym/device/{_check_name(device)}/buttons"


def feedback_topic(device: str) -> str:
    return f"/otgym/feedback/{_check_name(device)}"


def _check_name(name: str) -> str:
    if not name or not all(c.isalnum() or c == "_" for c in name) or name[0].isdigit():
        raise ValueError(f"device name {name!r} must be letters, digits and _ (a ROS name), not starting with a digit")
    return name


def topic_type(topic: str) -> str:
    """The ROS 2 type of one of otgym's topics."""
    fixed = {TRAPS_TOPIC: "geometry_msgs/msg/PoseArray", BODIES_TOPIC: "geometry_msgs/msg/PoseArray",
             ALPHA_TOPIC: "std_msgs/msg/Float64", MODE_TOPIC: "std_msgs/msg/String",
             EVENTS_TOPIC: "std_msgs/msg/String"}
    if topic in fixed:
        return fixed[topic]
    parts = topic.split("/")
    if len(parts) == 5 and parts[1:3] == ["otgym", "device"] and parts[4] == "twist":
        return "geometry_msgs/msg/TwistStamped"
    if len(parts) == 5 and parts[1:3] == ["otgym", "device"] and parts[4] == "buttons":
        return "sensor_msgs/msg/Joy"
    if len(parts) == 4 and parts[1:3] == ["otgym", "feedback"]:
        return "geometry_msgs/msg/WrenchStamped"
    raise ValueError(f"{topic!r} is not an otgym topic")


def _types(*names):
    return [_STORE.types[name] for name in names]


def _header(time_s: float, frame_id: str):
    Header, Time = _types("std_msgs/msg/Header", "builtin_interfaces/msg/Time")
    sec = math.floor(time_s)
    return Header(stamp=Time(sec=int(sec), nanosec=int(round((time_s - sec) * 1e9)) % 1_000_000_000),
                  frame_id=frame_id)


def _vector(values):
    (Vector3,) = _types("geometry_msgs/msg/Vector3")
    x, y, z = (float(v) for v in values)
    return Vector3(x=x, y=y, z=z)


def _serialize(message, type_name: str) -> bytes:
    return bytes(_STORE.serialize_cdr(message, type_name))


def encode_traps(trap_xy_um, time_s: float) -> bytes:
    """PoseArray of trap positions (T, 2) um in the chip frame (z 0, identity orientation)."""
    return _encode_poses(np.asarray(trap_xy_um, float), np.zeros(len(trap_xy_um)), time_s, "chip_um")


def encode_bodies(pose, time_s: float) -> bytes:
    """PoseArray of body poses (B, 3): x, y um and yaw rad (a rotation about z)."""
    pose = np.asarray(pose, float)
    return _encode_poses(pose[:, :2], pose[:, 2], time_s, "chip_um")


def _encode_poses(xy_um, yaw_rad, time_s, frame_id) -> bytes:
    PoseArray, Pose, Point, Quaternion = _types("geometry_msgs/msg/PoseArray", "geometry_msgs/msg/Pose",
                                                "geometry_msgs/msg/Point", "geometry_msgs/msg/Quaternion")
    poses = [Pose(position=Point(x=float(x), y=float(y), z=0.0),
                  orientation=Quaternion(x=0.0, y=0.0, z=float(np.sin(yaw / 2)), w=float(np.cos(yaw / 2))))
             for (x, y), yaw in zip(xy_um, yaw_rad)]
    return _serialize(PoseArray(header=_header(time_s, frame_id), poses=poses), "geometry_msgs/msg/PoseArray")


def encode_twist(velocity_mm_s, time_s: float, frame_id: str = "stylus") -> bytes:
    """TwistStamped of a stylus tip velocity (3,) given in mm/s, sent in m/s."""
    TwistStamped, Twist = _types("geometry_msgs/msg/TwistStamped", "geometry_msgs/msg/Twist")
    twist = Twist(linear=_vector(np.asarray(velocity_mm_s, float) * 1e-3), angular=_vector(np.zeros(3)))
    return _serialize(TwistStamped(header=_header(time_s, frame_id), twist=twist), "geometry_msgs/msg/TwistStamped")


def encode_buttons(bits: int, n_buttons: int, time_s: float) -> bytes:
    """Joy with no axes and ``n_buttons`` buttons, button i = bit i of ``bits``."""
    (Joy,) = _types("sensor_msgs/msg/Joy")
    buttons = np.array([(int(bits) >> i) & 1 for i in range(n_buttons)], np.int32)
    return _serialize(Joy(header=_header(time_s, "stylus"), axes=np.zeros(0, np.float32), buttons=buttons),
                      "sensor_msgs/msg/Joy")


def encode_feedback(force_n, time_s: float, frame_id: str = "stylus") -> bytes:
    """WrenchStamped of the force (3,) N sent to a device (no torque)."""
    WrenchStamped, Wrench = _types("geometry_msgs/msg/WrenchStamped", "geometry_msgs/msg/Wrench")
    wrench = Wrench(force=_vector(force_n), torque=_vector(np.zeros(3)))
    return _serialize(WrenchStamped(header=_header(time_s, frame_id), wrench=wrench),
                      "geometry_msgs/msg/WrenchStamped")


def encode_alpha(alpha: float) -> bytes:
    (Float64,) = _types("std_msgs/msg/Float64")
    return _serialize(Float64(data=float(alpha)), "std_msgs/msg/Float64")


def encode_text(text: str) -> bytes:
    """std_msgs/String (the mode, or an event's JSON)."""
    (String,) = _types("std_msgs/msg/String")
    return _serialize(String(data=str(text)), "std_msgs/msg/String")


def encode_event(event: dict) -> bytes:
    """A trial event (a JSON object: kind, time_s and its fields) as std_msgs/String."""
    return encode_text(json.dumps(event, sort_keys=True, allow_nan=False))


def _finite(values, what: str) -> np.ndarray:
    values = np.asarray(values, float)
    if not np.all(np.isfinite(values)):
        raise MalformedMessage(f"{what} is not finite")
    return values


def _stamp(header) -> float:
    if not 0 <= header.stamp.nanosec < 1_000_000_000:
        raise MalformedMessage(f"stamp nanosec {header.stamp.nanosec} out of range")
    return header.stamp.sec + header.stamp.nanosec * 1e-9


def decode(topic: str, data: bytes) -> dict:
    """The checked content of a message received on ``topic``: for PoseArray
    ``{"time_s", "xy_um" (N, 2), "yaw_rad" (N,)}``; TwistStamped ``{"time_s",
    "velocity_mm_s" (3,)}``; Joy ``{"time_s", "bits"}``; WrenchStamped ``{"time_s",
    "force_n" (3,)}``; alpha ``{"alpha"}``; mode ``{"mode"}``; events ``{"event"}``.
    Raises MalformedMessage (with the reason) for anything that does not decode or
    is out of range, ValueError for a topic that is not otgym's."""
    type_name = topic_type(topic)
    try:
        message = _STORE.deserialize_cdr(bytes(data), type_name)
    except Exception as error:  # the deserialiser raises struct, index and value errors alike
        raise MalformedMessage(f"{topic}: does not decode as {type_name} ({type(error).__name__})") from None
    if type_name == "geometry_msgs/msg/PoseArray":
        xy = _finite([[p.position.x, p.position.y] for p in message.poses], "a position").reshape(-1, 2)
        quaternion = _finite([[p.orientation.z, p.orientation.w] for p in message.poses], "an orientation")
        if np.any(np.abs(xy) > MAX_POSITION_UM):
            raise MalformedMessage(f"{topic}: a position beyond {MAX_POSITION_UM:g} um")
        yaw = 2 * np.arctan2(quaternion[:, 0], quaternion[:, 1]) if len(quaternion) else np.zeros(0)
        return {"time_s": _stamp(message.header), "xy_um": xy, "yaw_rad": yaw}
    if type_name == "geometry_msgs/msg/TwistStamped":
        velocity = _finite([message.twist.linear.x, message.twist.linear.y, message.twist.linear.z], "the twist")
        if np.linalg.norm(velocity) > MAX_SPEED_M_S:
            raise MalformedMessage(f"{topic}: a tip speed above {MAX_SPEED_M_S:g} m/s")
        return {"time_s": _stamp(message.header), "velocity_mm_s": velocity * 1e3}
    if type_name == "sensor_msgs/msg/Joy":
        buttons = np.asarray(message.buttons)
        if np.any((buttons != 0) & (buttons != 1)) or len(buttons) > 31:
            raise MalformedMessage(f"{topic}: buttons must be 0 or 1, at most 31 of them")
        return {"time_s": _stamp(message.header), "bits": int(sum(int(b) << i for i, b in enumerate(buttons)))}
    if type_name == "geometry_msgs/msg/WrenchStamped":
        force = _finite([message.wrench.force.x, message.wrench.force.y, message.wrench.force.z], "the force")
        if np.linalg.norm(force) > MAX_FORCE_N:
            raise MalformedMessage(f"{topic}: a force above {MAX_FORCE_N:g} N")
        return {"time_s": _stamp(message.header), "force_n": force}
    if topic == ALPHA_TOPIC:
        alpha = float(_finite(message.data, "alpha"))
        if not 0.0 <= alpha <= 1.0:
            raise MalformedMessage(f"{topic}: alpha {alpha} outside [0, 1]")
        return {"alpha": alpha}
    if topic == MODE_TOPIC:
        if message.data not in KNOWN_MODES:
            raise MalformedMessage(f"{topic}: unknown mode {message.data[:40]!r}")
        return {"mode": message.data}
    try:
        event = json.loads(message.data)
    except json.JSONDecodeError:
        raise MalformedMessage(f"{topic}: not JSON") from None
    if not isinstance(event, dict) or not isinstance(event.get("kind"), str):
        raise MalformedMessage(f"{topic}: an event must be a JSON object with a 'kind'")
    return {"event": event}
