"""The ROS 2 message types otgym's topics use (``otgym.bus.messages``): their
definitions, RIHS01 type hashes and CDR encoders and decoders, all from rosbags' type
store of ROS 2 Jazzy (``STORE``: rosbags, https://ternaris.gitlab.io/rosbags/, a
maintained pure-Python implementation of ROS 2's message definitions, REP 2011 hashing
and CDR), none written here.

- ``SCHEMAS``: each type's definition as MCAP's ``ros2msg`` schema text (the type's own
  fields, then each dependency after a line of 80 ``=`` and ``MSG: pkg/Type``), as
  rosbags generates it;
- ``TYPE_HASHES``: each type's ``RIHS01_...`` hash, as rmw_zenoh puts it in its keys;
- ``ENCODERS[type](message)``: CDR bytes (XCDR1, little endian) of a message given as
  nested dicts of the type's fields (``build`` makes rosbags' message object of them) or
  as such an object;
- ``DECODERS[type](data)``: the message object of CDR bytes (fields as attributes;
  primitive arrays as numpy arrays). Malformed bytes raise ``DECODE_ERRORS``.
"""

from __future__ import annotations

import struct

import numpy as np
from rosbags.serde import SerdeError
from rosbags.typesys import Stores, get_typestore
from rosbags.typesys.base import Nodetype

STORE = get_typestore(Stores.ROS2_JAZZY)
"""rosbags' type store of ROS 2 Jazzy's message definitions (the oldest distribution
with type hashes that rmw_zenoh supports; these types' hashes are the same in later ones)."""

POSE_ARRAY = "geometry_msgs/msg/PoseArray"
TWIST_STAMPED = "geometry_msgs/msg/TwistStamped"
WRENCH_STAMPED = "geometry_msgs/msg/WrenchStamped"
JOY = "sensor_msgs/msg/Joy"
FLOAT64 = "std_msgs/msg/Float64"
STRING = "std_msgs/msg/String"
PATH = "nav_msgs/msg/Path"
TWIST = "geometry_msgs/msg/Twist"
COMPRESSED_IMAGE = "sensor_msgs/msg/CompressedImage"
TYPES = (POSE_ARRAY, TWIST_STAMPED, WRENCH_STAMPED, JOY, FLOAT64, STRING, PATH, COMPRESSED_IMAGE, TWIST)

SCHEMAS: dict[str, str] = {name: STORE.generate_msgdef(name, ros_version=2)[0] for name in TYPES}
"""ros2msg schema text per type."""
TYPE_HASHES: dict[str, str] = {name: STORE.hash_rihs01(name) for name in TYPES}
"""RIHS01 hash per type (REP 2011)."""
DECODE_ERRORS = (SerdeError, struct.error, UnicodeDecodeError, ValueError, IndexError, OverflowError, MemoryError)
"""What decoding malformed bytes may raise."""
_SEQUENCES = (Nodetype.ARRAY, Nodetype.SEQUENCE)


def build(type_name: str, value):
    """rosbags' message object of ``type_name`` from nested dicts of its fields (an
    object is returned as it is)."""
    if not isinstance(value, dict):
        return value
    fields = {}
    for name, (node, spec) in STORE.fielddefs[type_name][1]:
        field = value[name]
        if node == Nodetype.NAME:
            field = build(spec, field)
        elif node in _SEQUENCES:
            (element_node, element), _size = spec
            if element_node == Nodetype.NAME:
                field = [build(element, item) for item in field]
            elif element[0] in ("string", "wstring"):
                field = list(field)
            elif isinstance(field, (bytes, bytearray, memoryview)):
                field = np.frombuffer(field, dtype=np.uint8).copy()
            else:
                field = np.asarray(field, dtype=element[0] if element[0] != "bool" else bool)
        fields[name] = field
    return STORE.types[type_name](**fields)


def _encoder(type_name: str):
    def encode(message) -> bytes:
        return bytes(STORE.serialize_cdr(build(type_name, message), type_name))

    return encode


def _decoder(type_name: str):
    def decode(data: bytes):
        return STORE.deserialize_cdr(data, type_name)

    return decode


ENCODERS = {name: _encoder(name) for name in TYPES}
DECODERS = {name: _decoder(name) for name in TYPES}
