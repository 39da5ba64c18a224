"""Recording a session to MCAP: every tick's topics as ROS 2 messages
(``otgym.bus.messages``), so ROS 2 tools and Foxglove open the file as they open a
ros2 bag.

Format (the MCAP specification, https://mcap.dev/spec): profile ``ros2``; one schema
per message type (encoding ``ros2msg``, the type's definition with its dependencies),
one channel per topic (message encoding ``cdr``); chunks compressed with zstd and
indexed. Log times are the simulation's time in nanoseconds from the session's start
(trials follow each other on one time line); publish times are the wall clock.

Crash safety: the writer finishes the chunk in progress and flushes the file at
least every ``flush_interval_s`` (0.5 s of wall time by default), so a recorder that is
killed loses at most the messages since its last flush; the file stays readable up to
that chunk (MCAP readers fall back to scanning the chunks when the summary at the end
is missing). A clean ``close`` writes the summary and index.

Per tick (``record_tick``): ``/otgym/traps``, ``/otgym/bodies``, ``/otgym/shared/alpha``,
and per device its ``twist`` and ``buttons`` (when it gave a sample) and its
``/otgym/feedback/<name>``; ``/otgym/mode`` whenever the mode changes; ``/otgym/events``
for trial starts and ends (``event``).
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np
from mcap.writer import CompressionType, Writer

from otgym.bus import messages as msg

PROFILE = "ros2"


class SessionRecorder:
    """One MCAP file; ``device_names`` name the devices in the order of the loop's bindings."""

    def __init__(self, path, device_names: list[str], flush_interval_s: float = 0.5):
        if not flush_interval_s > 0:
            raise ValueError(f"flush_interval_s must be positive, got {flush_interval_s!r}")
        self.path = Path(path)
        self.device_names = [msg.check_device_name(name) for name in device_names]
        self.flush_interval_s = float(flush_interval_s)
        self._file = open(self.path, "wb")
        self._writer = Writer(self._file, compression=CompressionType.ZSTD)
        self._writer.start(profile=PROFILE, library="otgym")
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, int] = {}
        self._sequence: dict[str, int] = {}
        self.counts: dict[str, int] = {}
        """Messages written per topic."""
        self._offset_s = 0.0
        self._last_flush_s = time.monotonic()
        self._mode: str | None = None
        self._closed = False

    def _channel(self, topic: str) -> int:
        if topic not in self._channels:
            type_name = msg.topic_type(topic)
            if type_name not in self._schemas:
                self._schemas[type_name] = self._writer.register_schema(
                    name=type_name, encoding="ros2msg", data=msg.schema_text(type_name).encode())
            self._channels[topic] = self._writer.register_channel(topic=topic, message_encoding="cdr",
                                                                  schema_id=self._schemas[type_name])
            self._sequence[topic] = 0
        return self._channels[topic]

    def write(self, topic: str, data: bytes, time_s: float) -> None:
        """One message at session time ``time_s`` (s)."""
        channel = self._channel(topic)
        self._sequence[topic] += 1
        self._writer.add_message(channel_id=channel, log_time=int(round(time_s * 1e9)), data=data,
                                 publish_time=time.time_ns(), sequence=self._sequence[topic])
        self.counts[topic] = self.counts.get(topic, 0) + 1
        now = time.monotonic()
        if now - self._last_flush_s >= self.flush_interval_s:
            self._writer.flush()
            self._last_flush_s = now

    def start_trial(self, trial: int, participant: str, scenario: int, mode: str) -> None:
        """A new trial begins where the last one's time ended."""
        self.event({"kind": "trial_start", "trial": trial, "participant": participant, "scenario": scenario},
                   self._offset_s)
        self.mode(mode, 0.0)

    def end_trial(self, row: dict, trial_time_s: float) -> None:
        """The trial's result row (``TrialMetrics.rows`` plus the session's columns)."""
        clean = {key: (None if isinstance(value, float) and not np.isfinite(value) else
                       value.item() if isinstance(value, np.generic) else value) for key, value in row.items()}
        self.event({"kind": "trial_end", **clean}, self._offset_s + trial_time_s)
        self._offset_s += trial_time_s

    def mode(self, mode: str, trial_time_s: float) -> None:
        if mode != self._mode:
            self._mode = mode
            self.write(msg.MODE_TOPIC, msg.encode_text(mode), self._offset_s + trial_time_s)

    def event(self, event: dict, time_s: float) -> None:
        self.write(msg.EVENTS_TOPIC, msg.encode_event({**event, "time_s": time_s}), time_s)

    def record_tick(self, record, samples, body_pose) -> None:
        """One tick: its ``TickRecord``, the devices' samples as read (None where none
        came) and the bodies' poses (B, 3)."""
        t = self._offset_s + record.time_s
        self.write(msg.TRAPS_TOPIC, msg.encode_traps(record.trap_xy_um, t), t)
        self.write(msg.BODIES_TOPIC, msg.encode_bodies(body_pose, t), t)
        self.write(msg.ALPHA_TOPIC, msg.encode_alpha(record.alpha), t)
        for name, sample, force in zip(self.device_names, samples, record.feedback_n):
            if sample is not None and sample.finite:
                self.write(msg.device_twist_topic(name), msg.encode_twist(sample.velocity_mm_s, t), t)
                self.write(msg.device_buttons_topic(name), msg.encode_buttons(sample.buttons, 8, t), t)
            self.write(msg.feedback_topic(name), msg.encode_feedback(force, t), t)

    def close(self) -> None:
        """Write the summary and index and close the file (once)."""
        if not self._closed:
            self._closed = True
            self._writer.finish()
            self._file.close()


def read_messages(path):
    """(topic, log time s, data) of every message in a recording, in file order; a
    file whose writer was killed is read up to its last complete record (MCAP's record
    stream, not the summary at the end, which such a file lacks)."""
    from mcap.exceptions import EndOfFile
    from mcap.records import Channel, Message
    from mcap.stream_reader import StreamReader

    topics = {}
    with open(path, "rb") as handle:
        try:
            for record in StreamReader(handle, skip_magic=False, emit_chunks=False).records:
                if isinstance(record, Channel):
                    topics[record.id] = record.topic
                elif isinstance(record, Message):
                    yield topics[record.channel_id], record.log_time * 1e-9, record.data
        except EndOfFile:
            return


def summarize(path) -> dict:
    """What a recording holds: messages per topic, first and last log time (s), and its
    trials (from the trial-end events)."""
    counts: dict[str, int] = {}
    first = last = None
    trials = []
    for topic, t, data in read_messages(path):
        counts[topic] = counts.get(topic, 0) + 1
        first = t if first is None else min(first, t)
        last = t if last is None else max(last, t)
        if topic == msg.EVENTS_TOPIC:
            event = msg.decode(msg.EVENTS_TOPIC, data)["event"]
            if event["kind"] == "trial_end":
                trials.append(event)
    return {"messages": counts, "first_s": first, "last_s": last, "trials": trials,
            "duration_s": (last - first) if first is not None else 0.0}


def summary_lines(summary: dict) -> list[str]:
    """A human-readable summary of ``summarize``'s result."""
    lines = [f"{sum(summary['messages'].values())} messages over {summary['duration_s']:.1f} s of session time"]
    lines += [f"  {topic}: {count}" for topic, count in sorted(summary["messages"].items())]
    for trial in summary["trials"]:
        lines.append("  trial {trial}: {ended_by}, {avoided}/{encountered} obstacles avoided, time {time}".format(
            trial=trial.get("trial"), ended_by=trial.get("ended_by", "?"),
            avoided=trial.get("obstacles_avoided"), encountered=trial.get("obstacles_encountered"),
            time=json.dumps(trial.get("completion_time_s"))))
    return lines
