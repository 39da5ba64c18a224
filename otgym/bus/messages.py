"""otgym's messages: standard ROS 2 types, their topics, CDR bytes, conversions from
and to otgym's objects, and the checks every received message passes.

Topics and their types: ``otgym.bus.topics``.

Latched topics (``LATCHED``: the session, chip and route, sent once per session; the
mode, sent at each trial's start and when it changes; the current trial, sent at each
trial's start: a window that joins mid-trial knows which trial it shows) are kept by their
publisher for subscribers that join later, as ROS 2's transient-local durability does
(``otgym.bus.transport``). ``otgym.bus.task_messages.session_messages`` builds the
first three from the task:
the description holds the chip's name, content hash (``Chip.content_hash``) and JSON
sidecar, the destination's tolerance, the tick, each sphere's kind and which spheres
are trap handles; with the chip's image and the route, a recording can draw the global
view without the chip file (``otgym.record.replay``).

Units. Lengths in the chip frame are micrometres (x right, y down, z = 0), as the issue
asks, not REP 103's metres: a trap moves by fractions of a micrometre. Velocities and
forces are SI (m/s, N), so a ROS 2 tool reads a device's twist and feedback as it would
any robot's. The trial events have no standard type: a ``std_msgs/String`` whose data
is a JSON object with at least ``"event"`` (e.g. ``{"event": "trial_start", "trial": 1,
...}``), which every ROS 2 tool can display. A command is one too: ``{"command":
NAME}`` with NAME one of ``COMMANDS`` (``mode`` also carries ``"mode"``: manual,
shared or autonomous), nothing else. Header stamps are UNIX wall time (a
``builtin_interfaces/Time``: seconds and nanoseconds); ``frame_id`` names the frame
(``"chip"`` or the device's name).

Bytes. CDR (XCDR1, little endian: the four-byte encapsulation header 00 01 00 00) as
ROS 2's rmw implementations write it, encoded and decoded by rosbags' type store of the
ROS 2 definitions (``otgym.bus.schemas``).

Checks on receipt (``decode``): the bytes must decode under the topic's schema, every
float must be finite and within ``LIMITS``, strings short, buttons 0/1, a mode one of
``otgym.shared.MODES``, an event a JSON object with an ``"event"`` string. A message
that fails raises ``MessageError`` with the reason; a subscriber drops and counts it.
"""

from __future__ import annotations

import dataclasses
import json
import math
import re

import numpy as np

from otgym.bus.schemas import (
    COMPRESSED_IMAGE,
    DECODE_ERRORS,
    DECODERS,
    ENCODERS,
    FLOAT64,
    JOY,
    PATH,
    POSE_ARRAY,
    STRING,
    TWIST,
    TWIST_STAMPED,
    WRENCH_STAMPED,
)
from otgym.bus.topics import (  # noqa: F401 (re-exported: messages.TRAPS, messages.topic_type, ...)
    ALPHA,
    AUTONOMY,
    BODIES,
    CHIP,
    COMMAND,
    COMMANDS,
    CONTACT_FORCE,
    EVENTS,
    LATCHED,
    MAX_INCREMENT_UM,
    MODE,
    PHASE,
    PHASES,
    PNG_SIGNATURE,
    RIG_POSES,
    RIG_START,
    ROUTE,
    SESSION,
    SPHERE_KINDS,
    TRAPS,
    TRIAL,
    MessageError,
    buttons_topic,
    check_name,
    feedback_topic,
    fixed_topics,
    topic_type,
    twist_topic,
)
from otgym.shared import MODES
from otgym.teleop.device import Sample


@dataclasses.dataclass(frozen=True)
class Limits:
    """Ranges a received value must lie in (generous: they catch corruption and units
    mistakes, not the task's own bounds)."""

    position_um: float = 1e6
    """Chip-frame coordinates (1 m)."""
    speed_m_s: float = 10.0
    force_n: float = 100.0
    torque_n_m: float = 10.0
    poses: int = 4096
    buttons: int = 64
    axes: int = 64
    string_chars: int = 65536
    frame_chars: int = 256
    route_poses: int = 1 << 16
    image_bytes: int = 16 << 20
    """A chip image's PNG (16 MiB)."""


LIMITS = Limits()


# --- encoding -----------------------------------------------------------------------
def _stamp(stamp_s: float) -> dict:
    if not (math.isfinite(stamp_s) and 0 <= stamp_s < 2**32):
        raise ValueError(f"stamp must be finite UNIX seconds, got {stamp_s!r}")
    sec = math.floor(stamp_s)
    return {"sec": sec, "nanosec": min(int(round((stamp_s - sec) * 1e9)), 999_999_999)}


def _header(stamp_s: float, frame_id: str) -> dict:
    return {"stamp": _stamp(stamp_s), "frame_id": frame_id}


def _vector(values) -> dict:
    x, y, z = (float(v) for v in values)
    return {"x": x, "y": y, "z": z}


def encode(type_name: str, message) -> bytes:
    """CDR bytes of ``message`` (a dict or object with the type's fields)."""
    return bytes(ENCODERS[type_name](message))


def pose_array(xy_um, stamp_s: float, frame_id: str = "chip") -> bytes:
    """PoseArray of points (N, 2) in um (z = 0, identity orientation)."""
    xy = np.asarray(xy_um, float).reshape(-1, 2)
    poses = [
        {"position": {"x": float(x), "y": float(y), "z": 0.0}, "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}
        for x, y in xy
    ]
    return encode(POSE_ARRAY, {"header": _header(stamp_s, frame_id), "poses": poses})


def path(xy_um, stamp_s: float, frame_id: str = "chip") -> bytes:
    """nav_msgs Path of points (N, 2) in um (each pose stamped alike, z = 0, identity orientation)."""
    header = _header(stamp_s, frame_id)
    poses = [
        {
            "header": header,
            "pose": {
                "position": {"x": float(x), "y": float(y), "z": 0.0},
                "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0},
            },
        }
        for x, y in np.asarray(xy_um, float).reshape(-1, 2)
    ]
    return encode(PATH, {"header": header, "poses": poses})


def compressed_png(png: bytes, stamp_s: float, frame_id: str = "chip") -> bytes:
    """sensor_msgs CompressedImage holding the PNG file ``png`` (format ``png``)."""
    return encode(COMPRESSED_IMAGE, {"header": _header(stamp_s, frame_id), "format": "png", "data": bytes(png)})


def twist(sample: Sample, stamp_s: float, device: str) -> bytes:
    """TwistStamped of a device sample's tip velocity (mm/s -> m/s; no angular part)."""
    return encode(
        TWIST_STAMPED,
        {
            "header": _header(stamp_s, device),
            "twist": {"linear": _vector(np.asarray(sample.velocity_mm_s) * 1e-3), "angular": _vector((0.0, 0.0, 0.0))},
        },
    )


def joy(buttons: int, stamp_s: float, device: str, n_buttons: int = 8) -> bytes:
    """Joy with a sample's raw button bits as ``n_buttons`` 0/1 entries (bit 0 first)."""
    if buttons >> n_buttons:
        n_buttons = buttons.bit_length()
    return encode(
        JOY,
        {"header": _header(stamp_s, device), "axes": [], "buttons": [(buttons >> bit) & 1 for bit in range(n_buttons)]},
    )


def wrench(force_n, stamp_s: float, device: str) -> bytes:
    """WrenchStamped of a (3,) force in N for a device (no torque)."""
    return encode(
        WRENCH_STAMPED,
        {"header": _header(stamp_s, device), "wrench": {"force": _vector(force_n), "torque": _vector((0.0, 0.0, 0.0))}},
    )


def float64(value: float) -> bytes:
    return encode(FLOAT64, {"data": float(value)})


def string(text: str) -> bytes:
    return encode(STRING, {"data": text})


def event(name: str, **fields) -> bytes:
    """A trial event: String with the JSON object ``{"event": name, **fields}``."""
    return string(json.dumps({"event": name, **fields}, sort_keys=True))


def command(name: str, mode: str | None = None) -> bytes:
    """A command to the sim: String with ``{"command": name}`` (and ``"mode"`` for ``mode``)."""
    fields = {"command": name} if mode is None else {"command": name, "mode": mode}
    data = string(json.dumps(fields, sort_keys=True))
    decode(COMMAND, data)  # the sender's own check: never send what a receiver drops
    return data


# --- decoding and checks ----------------------------------------------------------------
def decode(topic: str, data: bytes):
    """The checked message on ``topic`` (an object with the type's fields, as
    rosbags decodes it); MessageError with the reason otherwise."""
    return decode_as(topic_type(topic), data, topic)


def decode_as(type_name: str, data: bytes, topic: str):
    """``data`` decoded as ``type_name`` and checked as a message on ``topic``."""
    if len(data) < 4 or data[:2] != b"\x00\x01":
        raise MessageError(f"{topic}: not little-endian CDR (encapsulation {bytes(data[:4]).hex() or 'missing'})")
    try:
        message = DECODERS[type_name](bytes(data))
    except DECODE_ERRORS as error:
        raise MessageError(f"{topic}: does not decode as {type_name} ({type(error).__name__})") from None
    _CHECKS[type_name](message, topic)
    return message


def _fail(topic: str, reason: str):
    raise MessageError(f"{topic}: {reason}")


def _check_finite_within(topic: str, what: str, values, bound: float) -> None:
    array = np.asarray(values, float)
    if not np.isfinite(array).all():
        _fail(topic, f"{what} is not finite")
    if np.abs(array).max(initial=0.0) > bound:
        _fail(topic, f"{what} exceeds {bound:g} in magnitude")


def _check_header(message, topic: str) -> None:
    if message.header.stamp.nanosec >= 1_000_000_000:
        _fail(topic, "stamp nanoseconds out of range")
    if len(message.header.frame_id) > LIMITS.frame_chars:
        _fail(topic, "frame_id too long")


def _xyz(v) -> tuple[float, float, float]:
    return (v.x, v.y, v.z)


def _check_poses(poses, topic: str, bound_um: float) -> None:
    _check_finite_within(topic, "position_um", [_xyz(p.position) for p in poses], bound_um)
    quaternions = np.array([(*_xyz(p.orientation), p.orientation.w) for p in poses], float).reshape(-1, 4)
    if not np.isfinite(quaternions).all() or np.any(np.abs(np.linalg.norm(quaternions, axis=1) - 1) > 1e-6):
        _fail(topic, "orientation is not a unit quaternion")


def _check_pose_array(message, topic: str) -> None:
    _check_header(message, topic)
    if len(message.poses) > LIMITS.poses:
        _fail(topic, f"more than {LIMITS.poses} poses")
    _check_poses(message.poses, topic, MAX_INCREMENT_UM if topic == AUTONOMY else LIMITS.position_um)


def _check_path(message, topic: str) -> None:
    _check_header(message, topic)
    if len(message.poses) > LIMITS.route_poses:
        _fail(topic, f"more than {LIMITS.route_poses} poses")
    for pose in message.poses:
        _check_header(pose, topic)
    _check_poses([pose.pose for pose in message.poses], topic, LIMITS.position_um)


def _check_compressed_image(message, topic: str) -> None:
    _check_header(message, topic)
    if message.format != "png" or bytes(message.data[:8]) != PNG_SIGNATURE:
        _fail(topic, 'the chip\'s image must be a PNG (format "png")')
    if len(message.data) > LIMITS.image_bytes:
        _fail(topic, f"image larger than {LIMITS.image_bytes} bytes")


def _check_twist(message, topic: str) -> None:
    _check_header(message, topic)
    _check_finite_within(topic, "linear velocity (m/s)", _xyz(message.twist.linear), LIMITS.speed_m_s)
    _check_finite_within(topic, "angular velocity (rad/s)", _xyz(message.twist.angular), 1e3)


def _check_plain_twist(message, topic: str) -> None:
    _check_finite_within(topic, "linear velocity (m/s)", _xyz(message.linear), LIMITS.speed_m_s)
    _check_finite_within(topic, "angular velocity (rad/s)", _xyz(message.angular), 1e3)


def _check_wrench(message, topic: str) -> None:
    _check_header(message, topic)
    _check_finite_within(topic, "force (N)", _xyz(message.wrench.force), LIMITS.force_n)
    _check_finite_within(topic, "torque (N m)", _xyz(message.wrench.torque), LIMITS.torque_n_m)


def _check_joy(message, topic: str) -> None:
    _check_header(message, topic)
    if len(message.buttons) > LIMITS.buttons or len(message.axes) > LIMITS.axes:
        _fail(topic, "too many buttons or axes")
    if any(b not in (0, 1) for b in message.buttons):
        _fail(topic, "buttons must be 0 or 1")
    _check_finite_within(topic, "axes", list(message.axes), 1.0)


def _check_float64(message, topic: str) -> None:
    if topic == ALPHA and not (math.isfinite(message.data) and 0.0 <= message.data <= 1.0):
        _fail(topic, f"alpha must lie in [0, 1], got {message.data!r}")


def _check_string(message, topic: str) -> None:
    if len(message.data) > LIMITS.string_chars:
        _fail(topic, "string too long")
    if topic == MODE and message.data not in MODES:
        _fail(topic, f"unknown mode {message.data[:40]!r}")
    if topic == PHASE and message.data not in PHASES:
        _fail(topic, f"unknown phase {message.data[:40]!r}")
    if topic in (EVENTS, SESSION, TRIAL):
        try:
            payload = json.loads(message.data)
        except ValueError:
            _fail(topic, "not JSON")
        if topic == EVENTS and (not isinstance(payload, dict) or not isinstance(payload.get("event"), str)):
            _fail(topic, 'event must be a JSON object with an "event" string')
        if topic == TRIAL and (
            not isinstance(payload, dict)
            or payload.get("event") != "trial_start"
            or not isinstance(payload.get("trial"), int)
        ):
            _fail(topic, 'the current trial must be a trial_start event with an integer "trial"')
        if topic == SESSION:
            _check_session(payload, topic)
    if topic == COMMAND:
        _check_command(message.data, topic)


def _check_command(text: str, topic: str) -> None:
    try:
        payload = json.loads(text)
    except ValueError:
        _fail(topic, "command is not JSON")
    if not isinstance(payload, dict) or payload.get("command") not in COMMANDS:
        _fail(topic, f'command must be a JSON object with "command" one of {", ".join(COMMANDS)}')
    expected = {"command", "mode"} if payload["command"] == "mode" else {"command"}
    if set(payload) != expected:
        _fail(topic, f"command {payload['command']!r} takes the fields {sorted(expected)}, got {sorted(payload)}")
    if payload["command"] == "mode" and payload["mode"] not in MODES:
        _fail(topic, f"unknown mode {str(payload['mode'])[:40]!r}")


def _check_session(payload, topic: str) -> None:
    """The session description's fields that a reader relies on (``session_description``)."""
    chip = payload.get("chip") if isinstance(payload, dict) else None
    if not isinstance(chip, dict) or not isinstance(chip.get("name"), str):
        _fail(topic, 'session must be a JSON object with a "chip" object naming the chip')
    if not re.fullmatch(r"[0-9a-f]{64}", str(chip.get("content_hash", ""))):
        _fail(topic, "chip content_hash must be 64 hex digits (SHA-256)")
    for key, where in (
        ("pixel_size_um", chip),
        ("channel_height_um", chip),
        ("goal_tolerance_um", payload),
        ("tick_s", payload),
    ):
        value = where.get(key)
        if not isinstance(value, (int, float)) or not (0 < value < LIMITS.position_um):
            _fail(topic, f"{key} must be a positive number, got {str(value)[:40]}")
    kinds, handles = payload.get("sphere_kind"), payload.get("handle_spheres")
    if not isinstance(kinds, list) or len(kinds) > LIMITS.poses or any(k not in SPHERE_KINDS for k in kinds):
        _fail(topic, f"sphere_kind must list one of {SPHERE_KINDS} per sphere")
    if not isinstance(handles, list) or any(not isinstance(i, int) or not 0 <= i < len(kinds) for i in handles):
        _fail(topic, "handle_spheres must list sphere indices")


_CHECKS = {
    POSE_ARRAY: _check_pose_array,
    TWIST_STAMPED: _check_twist,
    WRENCH_STAMPED: _check_wrench,
    JOY: _check_joy,
    FLOAT64: _check_float64,
    STRING: _check_string,
    PATH: _check_path,
    COMPRESSED_IMAGE: _check_compressed_image,
    TWIST: _check_plain_twist,
}


# --- back to otgym's objects -----------------------------------------------------------
def stamp_s(message) -> float:
    """A stamped message's header time in UNIX seconds."""
    return message.header.stamp.sec + 1e-9 * message.header.stamp.nanosec


def xy_um(message) -> np.ndarray:
    """(N, 2) points in um of a PoseArray."""
    return np.array([(p.position.x, p.position.y) for p in message.poses], float).reshape(-1, 2)


def velocity_mm_s(message) -> np.ndarray:
    """(3,) tip velocity in mm/s of a TwistStamped."""
    return np.array(_xyz(message.twist.linear), float) * 1e3


def button_bits(message) -> int:
    """A Joy's buttons as raw bits (entry i -> bit i)."""
    return sum(int(b) << i for i, b in enumerate(message.buttons))


def force_n(message) -> np.ndarray:
    """(3,) force in N of a WrenchStamped."""
    return np.array(_xyz(message.wrench.force), float)


def event_fields(message) -> dict:
    """The JSON object of a trial event (or of a command)."""
    return json.loads(message.data)


def sample_from(twist_message, buttons: int, time_s: float, sequence: int) -> Sample:
    """The device Sample a receiver rebuilds from a twist (and the latest buttons),
    stamped with the receiver's own clock ``time_s`` (the sender's clock may be another
    machine's). The position is not sent (retargeting uses only velocity and buttons):
    it reads as zeros."""
    return Sample(time_s, sequence, np.zeros(3), velocity_mm_s(twist_message), buttons)
