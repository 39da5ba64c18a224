"""MCAP recordings of ROS 2 messages: a writer whose chunks reach the disk at least
every second, and a reader that also reads a file whose writer died.

Format (the MCAP specification, https://mcap.dev/spec, profile ``ros2``): one schema
record per ROS 2 type (encoding ``ros2msg``, its concatenated ``.msg`` text), one
channel per topic (message encoding ``cdr``), messages with their CDR bytes, log time
(when recorded) and publish time (the sender's header stamp where it has one, else the
log time), in nanoseconds of UNIX time. Messages go into zstd-compressed chunks; the
summary (statistics, chunk and message indexes) is written by ``close``. A recording
also carries Foxglove's 3D scene (``write_encoded``: channel ``/otgym/scene``, schema
``foxglove.SceneUpdate`` in protobuf), which ROS 2 tools that expect CDR only skip or
refuse; Foxglove replays it.

Crash safety: a chunk is closed and written out, and the file flushed, whenever a
message arrives ``flush_period_s`` (1 s) or more after the previous flush, or the chunk
exceeds ``chunk_bytes``. The operating system keeps what was written when the process
is killed (SIGKILL included), so a killed writer loses the messages of the open chunk
only: at most ``flush_period_s`` plus one message interval. Schema and channel records
are written inside the chunk of their first message, so every closed chunk is
readable on its own; ``read_recording`` reads a file up to its last complete record.
"""

from __future__ import annotations

import dataclasses
import struct
import threading
import time
from pathlib import Path

import zstandard
from mcap.exceptions import InvalidMagic, McapError
from mcap.records import Channel, Message, Schema
from mcap.stream_reader import StreamReader
from mcap.writer import MCAP0_MAGIC, CompressionType, Writer

FLUSH_PERIOD_S = 1.0
CHUNK_BYTES = 1 << 20


def session_path(out_dir: Path) -> Path:
    """``out_dir/session.mcap``, or ``session-<n>.mcap`` with the first free n >= 2
    (a later session in the same folder never overwrites an earlier one)."""
    path, n = Path(out_dir) / "session.mcap", 1
    while path.exists():
        n += 1
        path = Path(out_dir) / f"session-{n}.mcap"
    return path


class McapRecorder:
    """Writes messages into the MCAP file ``path`` (created; its folder must exist).
    ``clock_ns`` gives log times (``time.time_ns``). Thread-safe; a context manager."""

    def __init__(
        self,
        path,
        flush_period_s: float = FLUSH_PERIOD_S,
        chunk_bytes: int = CHUNK_BYTES,
        clock_ns=time.time_ns,
        monotonic=time.monotonic,
    ):
        if not 0 < flush_period_s <= 60:
            raise ValueError(f"flush_period_s must lie in (0, 60], got {flush_period_s!r}")
        self.path = Path(path)
        self.flush_period_s = flush_period_s
        self._clock_ns = clock_ns
        self._monotonic = monotonic
        self._stream = open(self.path, "wb")
        self._writer = Writer(self._stream, chunk_size=chunk_bytes, compression=CompressionType.ZSTD)
        self._writer.start(profile="ros2", library="otgym")
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, int] = {}
        self._lock = threading.Lock()
        self._last_flush_s = monotonic()
        self.counts: dict[str, int] = {}
        """Messages written per topic."""
        self.flushes = 0
        self.closed = False

    def write(
        self,
        topic: str,
        type_name: str,
        schema_text: str,
        data: bytes,
        log_time_ns: int | None = None,
        publish_time_ns: int | None = None,
    ) -> None:
        """Record ``data`` (CDR) on ``topic`` of ROS 2 type ``type_name`` (whose
        ``ros2msg`` text is ``schema_text``, registered at its first use)."""
        with self._lock:
            if self.closed:
                raise ValueError(f"recording {self.path} is closed")
            schema_id = self._schemas.get(type_name)
            if schema_id is None:
                schema_id = self._writer.register_schema(type_name, "ros2msg", schema_text.encode())
                self._schemas[type_name] = schema_id
            channel_id = self._channels.get(topic)
            if channel_id is None:
                channel_id = self._writer.register_channel(topic, "cdr", schema_id)
                self._channels[topic] = channel_id
            log_time_ns = self._clock_ns() if log_time_ns is None else log_time_ns
            sequence = self.counts.get(topic, 0)
            self._writer.add_message(
                channel_id, log_time_ns, data, log_time_ns if publish_time_ns is None else publish_time_ns, sequence
            )
            self.counts[topic] = sequence + 1
            now_s = self._monotonic()
            if now_s - self._last_flush_s >= self.flush_period_s:
                self._flush(now_s)

    def write_encoded(
        self, topic: str, schema: tuple[str, str, bytes], message_encoding: str, data: bytes, log_time_ns: int
    ) -> None:
        """Record ``data`` on ``topic`` in another encoding than CDR: ``schema`` is
        (name, schema encoding, schema data), e.g. Foxglove's protobuf scene."""
        name, schema_encoding, schema_data = schema
        with self._lock:
            if self.closed:
                raise ValueError(f"recording {self.path} is closed")
            schema_id = self._schemas.get(name)
            if schema_id is None:
                schema_id = self._schemas[name] = self._writer.register_schema(name, schema_encoding, schema_data)
            channel_id = self._channels.get(topic)
            if channel_id is None:
                channel_id = self._channels[topic] = self._writer.register_channel(topic, message_encoding, schema_id)
            sequence = self.counts.get(topic, 0)
            self._writer.add_message(channel_id, log_time_ns, data, log_time_ns, sequence)
            self.counts[topic] = sequence + 1

    def _flush(self, now_s: float) -> None:
        self._writer.flush()
        self._last_flush_s = now_s
        self.flushes += 1

    def flush(self) -> None:
        """Close the open chunk and flush the file now."""
        with self._lock:
            if not self.closed:
                self._flush(self._monotonic())

    def close(self) -> None:
        """Write the last chunk and the summary, and close the file; idempotent."""
        with self._lock:
            if self.closed:
                return
            self.closed = True
            self._writer.finish()
            self._stream.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc_info):
        self.close()


@dataclasses.dataclass(frozen=True)
class RecordedMessage:
    topic: str
    type_name: str
    schema_text: str
    data: bytes
    log_time_ns: int
    publish_time_ns: int


@dataclasses.dataclass(frozen=True)
class Recording:
    """The messages of an MCAP file in file order; ``complete`` False when the file
    ends early (its writer died): then ``messages`` are those of its whole chunks.
    ``other_counts``: messages per topic of the channels in other encodings than CDR
    (the Foxglove scene's protobuf), counted, not read."""

    messages: list[RecordedMessage]
    complete: bool
    other_counts: dict[str, int] = dataclasses.field(default_factory=dict)

    def counts(self) -> dict[str, int]:
        """Messages per topic, those of other encodings (``other_counts``) included."""
        counts: dict[str, int] = dict(self.other_counts)
        for message in self.messages:
            counts[message.topic] = counts.get(message.topic, 0) + 1
        return counts

    def topic(self, name: str) -> list[RecordedMessage]:
        return [message for message in self.messages if message.topic == name]


def check_mcap(path) -> None:
    """ValueError unless the file ``path`` begins with MCAP's 8-byte magic (the MCAP
    specification: ``0x89 M C A P 0 \\r \\n``). A file cut short after its magic is
    still MCAP (``read_recording`` reads it as truncated); an empty or shorter file, or
    one that begins otherwise, is not."""
    with open(path, "rb") as stream:
        head = stream.read(len(MCAP0_MAGIC))
    if head != MCAP0_MAGIC:
        raise ValueError(f"{path} is not an MCAP file" + (" (it is empty)" if not head else ""))


def read_recording(path) -> Recording:
    """Every ROS 2 (CDR) message of the MCAP file ``path`` (read sequentially, so a file
    without its summary reads too; channels of other encodings, such as the Foxglove
    scene, are counted only); ValueError for a file that is not MCAP."""
    schemas: dict[int, Schema] = {}
    channels: dict[int, Channel] = {}
    messages: list[RecordedMessage] = []
    other_counts: dict[str, int] = {}
    complete = False
    with open(path, "rb") as stream:
        reader = StreamReader(stream)
        try:
            for record in reader.records:
                if isinstance(record, Schema):
                    schemas[record.id] = record
                elif isinstance(record, Channel):
                    channels[record.id] = record
                elif isinstance(record, Message):
                    channel = channels.get(record.channel_id)
                    schema = schemas.get(channel.schema_id) if channel else None
                    if schema is None:
                        raise ValueError(f"{path}: a message refers to an unknown channel or schema")
                    if channel.message_encoding != "cdr":
                        other_counts[channel.topic] = other_counts.get(channel.topic, 0) + 1
                        continue
                    messages.append(
                        RecordedMessage(
                            channel.topic,
                            schema.name,
                            schema.data.decode(),
                            bytes(record.data),
                            record.log_time,
                            record.publish_time,
                        )
                    )
            complete = True
        except InvalidMagic:
            raise ValueError(f"{path} is not an MCAP file") from None
        except (McapError, struct.error, zstandard.ZstdError):  # a record cut short by the writer's death
            pass
    return Recording(messages, complete, other_counts)
