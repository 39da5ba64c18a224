"""otgym's topics: their names, their ROS 2 types, which are latched, and the
device names a topic may carry; ``MessageError`` for a topic otgym does not use.

Types (ROS 2 common_interfaces; their definitions from rosbags' type store of ROS 2
Jazzy, ``otgym.bus.schemas``, in MCAP's ``ros2msg`` schema encoding)::

    /otgym/traps                    geometry_msgs/msg/PoseArray   trap centres, um, chip frame
    /otgym/bodies                   geometry_msgs/msg/PoseArray   sphere centres, um, chip frame
    /otgym/device/<name>/twist      geometry_msgs/msg/TwistStamped  tip velocity, m/s, device frame
    /otgym/device/<name>/buttons    sensor_msgs/msg/Joy           raw button bits, one 0/1 each
    /otgym/feedback/<name>          geometry_msgs/msg/WrenchStamped force for the device, N
    /otgym/shared/alpha             std_msgs/msg/Float64          the arbitration weight
    /otgym/mode                     std_msgs/msg/String           manual, shared or autonomous
    /otgym/trial/events             std_msgs/msg/String           one JSON object per event
    /otgym/trial/current            std_msgs/msg/String           the trial under way: its trial_start event, latched
    /otgym/phase                    std_msgs/msg/String           approach, carry or done (every tick)
    /otgym/autonomy/increments      geometry_msgs/msg/PoseArray   the autonomy's dP_r per trap, um
    /otgym/command                  std_msgs/msg/String           a ui node's command to the sim (JSON)
    /otgym/session                  std_msgs/msg/String           the session's description (JSON), latched
    /otgym/chip                     sensor_msgs/msg/CompressedImage the chip's image (PNG), latched
    /otgym/route                    nav_msgs/msg/Path             the planned route, um, chip frame, latched
    /otgym/contact_force            geometry_msgs/msg/WrenchStamped the vision sensor's contact force on the handles, summed, N
    /otgym/rig/poses                geometry_msgs/msg/PoseArray   a rig's measured sphere centres, um, chip frame (in)
    /otgym/rig/start                geometry_msgs/msg/PoseArray   where a trial starts every sphere, um, chip frame, latched

The two rig topics are the plant's side of ``otgym node sim --plant rig``
(``otgym.task.rig``): ``/otgym/traps`` carries the trap commands out, a rig answers
with its measured poses.

A device node driven from ROS 2 (``otgym.bus.twist_source``) also reads a
``geometry_msgs/msg/Twist`` (``TWIST``) or ``TwistStamped`` from a topic of ROS 2's own
(``/cmd_vel`` by default).
"""

from __future__ import annotations

import re

from otgym.bus.schemas import (
    COMPRESSED_IMAGE,
    FLOAT64,
    JOY,
    PATH,
    POSE_ARRAY,
    STRING,
    TWIST_STAMPED,
    WRENCH_STAMPED,
)

TRAPS = "/otgym/traps"
BODIES = "/otgym/bodies"
ALPHA = "/otgym/shared/alpha"
MODE = "/otgym/mode"
EVENTS = "/otgym/trial/events"
TRIAL = "/otgym/trial/current"
PHASE = "/otgym/phase"
AUTONOMY = "/otgym/autonomy/increments"
COMMAND = "/otgym/command"
SESSION = "/otgym/session"
CHIP = "/otgym/chip"
ROUTE = "/otgym/route"
CONTACT_FORCE = "/otgym/contact_force"
RIG_POSES = "/otgym/rig/poses"
RIG_START = "/otgym/rig/start"
_FIXED_TOPICS = {
    TRAPS: POSE_ARRAY,
    BODIES: POSE_ARRAY,
    ALPHA: FLOAT64,
    MODE: STRING,
    EVENTS: STRING,
    TRIAL: STRING,
    PHASE: STRING,
    AUTONOMY: POSE_ARRAY,
    COMMAND: STRING,
    SESSION: STRING,
    CHIP: COMPRESSED_IMAGE,
    ROUTE: PATH,
    CONTACT_FORCE: WRENCH_STAMPED,
    RIG_POSES: POSE_ARRAY,
    RIG_START: POSE_ARRAY,
}
COMMANDS = ("mode", "pause", "resume", "reset", "next_trial", "quit")
"""What a ui node asks of the sim: switch the mode, pause or resume simulated time,
abandon the trial for the next (R), start the next trial after the questionnaires,
end the session (the trial under way saved as aborted)."""
LATCHED = (SESSION, CHIP, ROUTE, MODE, TRIAL, RIG_START)
"""Topics whose latest message a late subscriber still receives (see the module's docstring)."""
SPHERE_KINDS = ("robot", "cell", "obstacle", "bead")
"""Names of ``otgym.physics.bodies.BodyKind`` by value, as the session description gives them."""
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
PHASES = ("approach", "carry", "done")
"""The task's phases by their number (``otgym.task.task``'s APPROACH, CARRY, DONE)."""
MAX_INCREMENT_UM = 100.0
"""The largest trap increment an autonomy message may carry (a tick at 20 um/s moves 0.4 um)."""
_NAME = r"[A-Za-z][A-Za-z0-9_]{0,63}"
_DEVICE_TOPIC = re.compile(rf"/otgym/device/({_NAME})/(twist|buttons)")
_FEEDBACK_TOPIC = re.compile(rf"/otgym/feedback/({_NAME})")


def fixed_topics() -> tuple[str, ...]:
    """otgym's topics whose names do not depend on a device."""
    return tuple(_FIXED_TOPICS)


def twist_topic(device: str) -> str:
    return f"/otgym/device/{check_name(device)}/twist"


def buttons_topic(device: str) -> str:
    return f"/otgym/device/{check_name(device)}/buttons"


def feedback_topic(device: str) -> str:
    return f"/otgym/feedback/{check_name(device)}"


def check_name(device: str) -> str:
    """A device name usable in a topic (a ROS 2 name token: a letter, then letters,
    digits or underscores, at most 64); ValueError otherwise."""
    if not isinstance(device, str) or not re.fullmatch(_NAME, device):
        raise ValueError(f"device name must be a letter then letters, digits or '_' (at most 64), got {device!r}")
    return device


def topic_type(topic: str) -> str:
    """The ROS 2 type of an otgym topic; MessageError for a topic otgym does not use."""
    if topic in _FIXED_TOPICS:
        return _FIXED_TOPICS[topic]
    match = _DEVICE_TOPIC.fullmatch(topic)
    if match:
        return TWIST_STAMPED if match.group(2) == "twist" else JOY
    if _FEEDBACK_TOPIC.fullmatch(topic):
        return WRENCH_STAMPED
    raise MessageError(f"unknown topic {topic!r}")


class MessageError(ValueError):
    """A message that fails its checks; ``str()`` is the reason."""
