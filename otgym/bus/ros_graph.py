"""How a ROS 2 system using rmw_zenoh (Jazzy or newer) sees otgym's nodes: the data
key of a topic, the liveliness tokens of nodes, publishers and subscriptions, their
QoS text, the attachment every message carries, ROS 2's naming rules and the domain id.

Written from ros2/rmw_zenoh's ``docs/design.md`` and ``rmw_zenoh_cpp/src/detail``
(``liveliness_utils.cpp``, ``attachment_helpers.cpp``, ``qos.cpp``,
``rmw_publisher_data.cpp``):

- data key ``<domain>/<fully qualified topic without its leading slash>/<type>/<hash>``,
  the type as DDS names it (``std_msgs::msg::dds_::String_``), the hash RIHS01
  (rosbags' REP 2011 hashing: ``otgym.bus.schemas``);
- liveliness tokens ``@ros2_lv/<domain>/<zenoh session id>/<node id>/<entity id>/<kind>/
  <enclave>/<namespace>/<node name>`` for a node (kind ``NN``, entity id = node id), and
  for a publisher (``MP``) or subscription (``MS``) also ``/<topic>/<type>/<hash>/<qos>``;
  every ``/`` inside a part is replaced by ``%`` (the root namespace and the unset enclave
  read ``%``);
- QoS text ``<reliability>:<durability>:<history>,<depth>:<deadline s>,<ns>:<lifespan s>,
  <ns>:<liveliness>,<lease s>,<ns>`` with each value left empty where it equals rmw_zenoh's
  default (reliable, volatile, keep last, depth 42, infinite durations, automatic
  liveliness), else the number of rmw's enum (reliable 1, best effort 2; transient local
  1, volatile 2; keep last 1, keep all 2);
- attachment, 33 bytes: sequence number (int64 little endian, from 1 per publisher),
  source timestamp (int64 ns of UNIX time), then the publisher's GID as zenoh-ext
  serialises a 16-byte array: its length as one LEB128 byte (16) and the 16 bytes;
- GID: the 128-bit XXH3 of the entity's liveliness key, low 64 bits then high 64 bits,
  little endian (rmw_zenoh hashes it with its own copy of XXH3; the ``xxhash`` package's
  ``xxh3_128`` is the reference implementation of the same function).

Names (design.ros2.org, "Topic and Service name mapping"; rmw's ``validate_node_name``
and ``validate_namespace``): a node name is 1-255 letters, digits and underscores, not
starting with a digit; a namespace is ``/`` or ``/``-separated tokens of that kind, no
trailing ``/``, at most 253 characters. ``ROS_DOMAIN_ID`` (default 0) is 0-232, the
range ROS 2 documents.
"""

from __future__ import annotations

import dataclasses
import os
import re
import struct

import xxhash

ADMIN_SPACE = "@ros2_lv"
NODE, PUBLISHER, SUBSCRIPTION = "NN", "MP", "MS"
RELIABLE, BEST_EFFORT = 1, 2
TRANSIENT_LOCAL, VOLATILE = 1, 2
KEEP_LAST, KEEP_ALL = 1, 2
DEFAULT_DEPTH = 42
"""rmw_zenoh's default history depth (``qos.cpp``)."""
GID_BYTES = 16
ATTACHMENT = struct.Struct("<qqB16s")
MAX_DOMAIN_ID = 232
_TOKEN = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


class RosNameError(ValueError):
    """A name or domain id that ROS 2 would refuse; ``str()`` is one line for the user."""


def check_node_name(name: str) -> str:
    if not isinstance(name, str) or not _TOKEN.fullmatch(name) or len(name) > 255:
        raise RosNameError(
            f"ROS 2 node name must be letters, digits and '_', not starting with a digit (at most 255), got {name!r}"
        )
    return name


def check_namespace(namespace: str) -> str:
    """A namespace as given (``/`` or ``/a/b``); ``a/b`` (relative) is made absolute."""
    if not isinstance(namespace, str) or not namespace:
        raise RosNameError(f"ROS 2 namespace must be '/' or '/name/...', got {namespace!r}")
    absolute = namespace if namespace.startswith("/") else "/" + namespace
    if absolute != "/" and (
        absolute.endswith("/") or len(absolute) > 253 or not all(_TOKEN.fullmatch(t) for t in absolute[1:].split("/"))
    ):
        raise RosNameError(
            f"ROS 2 namespace must be '/' or '/'-separated names of letters, digits and '_' not starting with a "
            f"digit, without a trailing '/', got {namespace!r}"
        )
    return absolute


def domain_id(environ=os.environ) -> int:
    """``ROS_DOMAIN_ID`` (0 when unset or empty)."""
    text = environ.get("ROS_DOMAIN_ID", "").strip()
    if not text:
        return 0
    if not text.isdigit() or int(text) > MAX_DOMAIN_ID:
        raise RosNameError(f"ROS_DOMAIN_ID must be an integer in 0..{MAX_DOMAIN_ID}, got {text!r}")
    return int(text)


def resolve_topic(name: str, namespace: str = "/") -> str:
    """The fully qualified name of ``name`` in ``namespace`` (absolute names unchanged)."""
    if name.startswith("/"):
        return name
    return ("" if namespace == "/" else namespace) + "/" + name


def dds_type_name(type_name: str) -> str:
    """``pkg/msg/Name`` as rmw_zenoh writes it in keys: ``pkg::msg::dds_::Name_``."""
    package, kind, name = type_name.split("/")
    return f"{package}::{kind}::dds_::{name}_"


def ros_type_name(dds_name: str) -> str:
    """The inverse of ``dds_type_name`` (ValueError for another form)."""
    match = re.fullmatch(r"(\w+)::(\w+)::dds_::(\w+)_", dds_name)
    if match is None:
        raise ValueError(f"not a DDS type name: {dds_name!r}")
    return "/".join(match.groups())


def mangle(name: str) -> str:
    return name.replace("/", "%")


def data_key(domain: int, topic: str, type_name: str, type_hash: str) -> str:
    """The zenoh key of a fully qualified ``topic`` carrying ``type_name`` (``pkg/msg/Name``)."""
    return f"{domain}/{topic.strip('/')}/{dds_type_name(type_name)}/{type_hash}"


@dataclasses.dataclass(frozen=True)
class Qos:
    """A ROS 2 QoS profile as the liveliness token carries it (rmw enum values)."""

    reliability: int = RELIABLE
    durability: int = VOLATILE
    history: int = KEEP_LAST
    depth: int = DEFAULT_DEPTH

    def text(self) -> str:
        def part(value: int, default: int) -> str:
            return "" if value == default else str(value)

        return (
            f"{part(self.reliability, RELIABLE)}:{part(self.durability, VOLATILE)}:"
            f"{part(self.history, KEEP_LAST)},{part(self.depth, DEFAULT_DEPTH)}:,:,:,,"
        )


def entity_token(
    domain: int,
    zid: str,
    node_id: int,
    entity_id: int,
    kind: str,
    namespace: str,
    node_name: str,
    topic: str | None = None,
    type_name: str | None = None,
    type_hash: str | None = None,
    qos: Qos | None = None,
    enclave: str = "/",
) -> str:
    """The liveliness key of a node (``kind`` NN) or of a publisher or subscription."""
    parts = [ADMIN_SPACE, str(domain), zid, str(node_id), str(entity_id), kind]
    parts += [mangle(enclave), mangle(namespace), mangle(node_name)]
    if kind != NODE:
        parts += [mangle(topic), mangle(dds_type_name(type_name)), mangle(type_hash), qos.text()]
    return "/".join(parts)


def gid_of(token: str) -> bytes:
    """The 16-byte GID rmw_zenoh derives from an entity's liveliness key."""
    digest = xxhash.xxh3_128_intdigest(token.encode())
    return struct.pack("<QQ", digest & ((1 << 64) - 1), digest >> 64)


def attachment(sequence: int, timestamp_ns: int, gid: bytes) -> bytes:
    return ATTACHMENT.pack(sequence, timestamp_ns, GID_BYTES, gid)


def parse_attachment(data: bytes | None) -> tuple[int, int, bytes]:
    """(sequence, timestamp_ns, gid) of an attachment; ValueError if it is not one."""
    if data is None or len(data) != ATTACHMENT.size:
        raise ValueError(f"attachment must be {ATTACHMENT.size} bytes, got {None if data is None else len(data)}")
    sequence, timestamp_ns, length, gid = ATTACHMENT.unpack(data)
    if length != GID_BYTES:
        raise ValueError(f"attachment GID length must be {GID_BYTES}, got {length}")
    return sequence, timestamp_ns, gid


def parse_qos(text: str) -> Qos:
    """The reliability, durability, history and depth of a token's QoS text (empty = default)."""
    parts = text.split(":")
    history = parts[2].split(",") if len(parts) > 2 else ["", ""]
    if len(parts) < 6 or len(history) < 2:
        raise ValueError(f"not an rmw_zenoh QoS text: {text!r}")

    def value(part: str, default: int) -> int:
        return int(part) if part else default

    return Qos(
        value(parts[0], RELIABLE), value(parts[1], VOLATILE), value(history[0], KEEP_LAST), value(history[1], 42)
    )


@dataclasses.dataclass(frozen=True)
class Entity:
    """A publisher or subscription as its liveliness token describes it."""

    kind: str
    zid: str
    namespace: str
    node_name: str
    topic: str
    dds_type: str
    type_hash: str
    qos: Qos


def parse_entity(token: str) -> Entity | None:
    """The publisher or subscription a liveliness key declares; None for a node or another key."""
    parts = token.split("/")
    if len(parts) < 13 or parts[0] != ADMIN_SPACE or parts[5] not in (PUBLISHER, SUBSCRIPTION):
        return None
    demangle = lambda part: part.replace("%", "/")  # noqa: E731
    try:
        qos = parse_qos(parts[12])
    except ValueError:
        return None
    return Entity(
        parts[5], parts[2], demangle(parts[7]), demangle(parts[8]), demangle(parts[9]), parts[10], parts[11], qos
    )


def check_topic_name(name: str) -> str:
    """A topic name by ROS 2's rules (absolute, or relative to the namespace)."""
    tokens = name[1:].split("/") if name.startswith("/") else name.split("/")
    if not name or len(name) > 255 or not all(_TOKEN.fullmatch(t) for t in tokens):
        raise RosNameError(
            f"ROS 2 topic name must be '/'-separated names of letters, digits and '_' not starting with a digit, "
            f"got {name!r}"
        )
    return name
