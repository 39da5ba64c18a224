"""What a subscription checks before a message is passed on: the sample's rmw_zenoh key
(type and type hash), its attachment (present, well formed, a sequence number newer than
the last one seen from that publisher), its size, and the message itself
(``messages.decode_as``: encapsulation, decoding, finite values within range).

A sample that fails is dropped and counted per topic and reason (``Counts``), never
passed on. Each kind of mismatch (a topic's wrong type or type hash, and a publisher
whose QoS cannot serve a subscription, see ``qos_problem``) is reported once per
topic and offending value (``log`` at warning level, kept in ``Counts.reports``), not
per message: a misconfigured ROS 2 node publishing at 1 kHz gives one line.

Reasons: ``type`` (another type on the topic), ``hash`` (the type's definition
differs), ``attachment`` (none, or not rmw_zenoh's 33 bytes), ``stale`` (a sequence
number not above the last one from the same publisher GID: a replay or duplicate),
``size`` (more bytes than the type can need, ``MAX_PAYLOAD_BYTES``), ``malformed``
(does not decode, or a value out of range).
"""

from __future__ import annotations

import logging
import threading

from otgym.bus import messages as msg
from otgym.bus import ros_graph
from otgym.bus.schemas import SCHEMAS, TYPE_HASHES

log = logging.getLogger(__name__)
REASONS = ("type", "hash", "attachment", "stale", "size", "malformed")
TYPE_HASH = TYPE_HASHES
"""RIHS01 of every type otgym sends or reads (rosbags' type store: ``otgym.bus.schemas``)."""
DDS_NAME = {name: ros_graph.dds_type_name(name) for name in SCHEMAS}
MAX_PAYLOAD_BYTES = {
    msg.COMPRESSED_IMAGE: msg.LIMITS.image_bytes + 4096,
    msg.PATH: msg.LIMITS.route_poses * 128 + 4096,
    msg.POSE_ARRAY: msg.LIMITS.poses * 64 + 4096,
    msg.STRING: msg.LIMITS.string_chars * 4 + 64,
    msg.JOY: 8 * (msg.LIMITS.buttons + msg.LIMITS.axes) + 4096,
}
"""The most bytes a message of a type may have (generous; a larger one is not read)."""
DEFAULT_MAX_PAYLOAD_BYTES = 4096


class Counts:
    """Drops per topic (``dropped``) and per (topic, reason) (``reasons``), messages
    passed on per topic (``received``), and the one-time reports; thread-safe."""

    def __init__(self):
        self.dropped: dict[str, int] = {}
        self.reasons: dict[tuple[str, str], int] = {}
        self.received: dict[str, int] = {}
        self.reports: list[str] = []
        self._reported: set = set()
        self._lock = threading.Lock()

    def drop(self, topic: str, reason: str, detail: str) -> None:
        with self._lock:
            self.dropped[topic] = self.dropped.get(topic, 0) + 1
            self.reasons[(topic, reason)] = self.reasons.get((topic, reason), 0) + 1
            first = self.dropped[topic] <= 3 and reason in ("attachment", "stale", "size", "malformed")
        if reason in ("type", "hash"):
            self.report((topic, reason, detail), f"{topic}: dropping messages of {detail}")
        elif first:
            log.warning("dropped a message on %s (%s): %s", topic, reason, detail)

    def accept(self, topic: str) -> None:
        with self._lock:
            self.received[topic] = self.received.get(topic, 0) + 1

    def report(self, key, text: str) -> bool:
        """Log ``text`` the first time ``key`` is seen; True then."""
        with self._lock:
            if key in self._reported:
                return False
            self._reported.add(key)
            self.reports.append(text)
        log.warning("%s", text)
        return True


class Intake:
    """The checks of one subscription: ``accepted`` maps each (DDS type name, hash) it
    takes to the type's ``pkg/msg/Name``; ``check(topic, dds_type, type_hash,
    attachment, payload)`` returns the decoded message or None (dropped, counted)."""

    def __init__(self, counts: Counts, accepted: dict[tuple[str, str], str] | None = None):
        self.counts = counts
        self.accepted = accepted
        self._last_sequence: dict[bytes, int] = {}
        self._lock = threading.Lock()

    def expected(self, topic: str) -> dict[tuple[str, str], str]:
        if self.accepted is not None:
            return self.accepted
        type_name = msg.topic_type(topic)
        return {(DDS_NAME[type_name], TYPE_HASH[type_name]): type_name}

    def check(self, topic: str, dds_type: str, type_hash: str, attachment: bytes | None, payload: bytes):
        try:
            expected = self.expected(topic)
        except msg.MessageError as error:
            self.counts.drop(topic, "type", str(error))
            return None
        type_name = expected.get((dds_type, type_hash))
        if type_name is None:
            names = {dds for dds, _ in expected}
            reason = "hash" if dds_type in names else "type"
            self.counts.drop(topic, reason, f"{dds_type} {type_hash}" if reason == "hash" else dds_type)
            return None
        try:
            sequence, _, gid = ros_graph.parse_attachment(attachment)
        except ValueError as error:
            self.counts.drop(topic, "attachment", str(error))
            return None
        with self._lock:
            last = self._last_sequence.get(gid)
            if last is not None and sequence <= last:
                stale = True
            else:
                stale = False
                self._last_sequence[gid] = sequence
        if stale:
            self.counts.drop(topic, "stale", f"sequence {sequence} after {last}")
            return None
        if len(payload) > MAX_PAYLOAD_BYTES.get(type_name, DEFAULT_MAX_PAYLOAD_BYTES):
            self.counts.drop(topic, "size", f"{len(payload)} bytes for a {type_name}")
            return None
        try:
            message = msg.decode_as(type_name, payload, topic)
        except msg.MessageError as error:
            self.counts.drop(topic, "malformed", str(error))
            return None
        self.counts.accept(topic)
        return message


def qos_problem(publisher: ros_graph.Qos, subscription: ros_graph.Qos) -> str | None:
    """Why a publisher with QoS ``publisher`` cannot serve a subscription with QoS
    ``subscription`` under ROS 2's request-offered rules (a best-effort publisher for a
    reliable subscription; a volatile one for a transient-local subscription), or None."""
    if subscription.reliability == ros_graph.RELIABLE and publisher.reliability == ros_graph.BEST_EFFORT:
        return "the subscription asks for reliable delivery, the publisher offers best effort"
    if subscription.durability == ros_graph.TRANSIENT_LOCAL and publisher.durability == ros_graph.VOLATILE:
        return "the subscription asks for transient-local durability, the publisher offers volatile"
    return None
