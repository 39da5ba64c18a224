"""MCAP recordings (``otgym.record``): what was written reads back with the mcap
library's own (indexed) reader, per topic and byte for byte; chunks reach the file by
the recorder's clock (a fake one here: counted, not timed), so a writer killed with
SIGKILL leaves a file readable up to its last flush (``otgym replay``: test_replay.py)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from otgym.bus import messages as m
from otgym.bus import schemas
from otgym.record.mcap_file import McapRecorder, read_recording

ROOT = Path(__file__).resolve().parents[2]


def write(recorder: McapRecorder, topic: str, data: bytes, **times) -> None:
    type_name = m.topic_type(topic)
    recorder.write(topic, type_name, schemas.SCHEMAS[type_name], data, **times)


def session(recorder: McapRecorder, ticks: int) -> dict[str, list[bytes]]:
    """A small session: a trial start, ``ticks`` ticks of traps, bodies, alpha and feedback."""
    sent: dict[str, list[bytes]] = {}

    def send(topic, data, t_ns):
        write(recorder, topic, data, log_time_ns=t_ns)
        sent.setdefault(topic, []).append(data)

    send(
        m.EVENTS,
        m.event("trial_start", trial=1, scenario=10001, mode="shared", sphere_radius_um=[2.0, 2.0, 5.0]),
        10**9,
    )
    for i in range(ticks):
        t_ns = 10**9 + (i + 1) * 20_000_000
        send(m.TRAPS, m.pose_array([[10.0 + i, 20.0], [30.0, 40.0]], t_ns * 1e-9), t_ns)
        send(m.BODIES, m.pose_array([[10.0 + i, 20.0], [30.0, 40.0], [50.0, 60.0]], t_ns * 1e-9), t_ns)
        send(m.ALPHA, m.float64(i / ticks), t_ns)
        send(m.feedback_topic("device0"), m.wrench((0.01 * i, 0.0, 0.0), t_ns * 1e-9, "device0"), t_ns)
    send(m.EVENTS, m.event("trial_end", trial=1, ended_by="goal"), 10**9 + (ticks + 1) * 20_000_000)
    return sent


def test_recording_reads_back_with_the_mcap_reader_per_topic_and_byte_for_byte(tmp_path):
    path = tmp_path / "s.mcap"
    with McapRecorder(path) as recorder:
        sent = session(recorder, 120)
    with open(path, "rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        statistics = reader.get_summary().statistics
        assert {reader.get_summary().channels[c].topic: n for c, n in statistics.channel_message_counts.items()} == {
            topic: len(data) for topic, data in sent.items()
        }
        got: dict[str, list[bytes]] = {}
        alphas = []
        for schema, channel, message, decoded in reader.iter_decoded_messages(log_time_order=False):
            assert schema.encoding == "ros2msg" and channel.message_encoding == "cdr"
            got.setdefault(channel.topic, []).append(bytes(message.data))
            if channel.topic == m.ALPHA:
                alphas.append(decoded.data)
    assert got == sent
    assert alphas == [i / 120 for i in range(120)]
    assert read_recording(path).complete


def test_a_channel_of_another_encoding_is_counted_not_read(tmp_path):
    """The Foxglove scene (protobuf) beside the CDR topics: ``read_recording`` reads the
    CDR messages only and counts the others per topic, so ``otgym replay`` lists them."""
    path = tmp_path / "s.mcap"
    with McapRecorder(path) as recorder:
        sent = session(recorder, 3)
        for t_ns in (1, 2):
            recorder.write_encoded("/otgym/scene", ("foxglove.SceneUpdate", "protobuf", b"x"), "protobuf", b"", t_ns)
    recording = read_recording(path)
    assert {message.topic for message in recording.messages} == set(sent)
    assert recording.counts() == {**{topic: len(data) for topic, data in sent.items()}, "/otgym/scene": 2}


def test_chunks_reach_the_file_once_a_second_has_passed(tmp_path):
    """Messages within the flush period stay in the open chunk; the first message a
    period after the last flush writes them all out (a fake monotonic clock)."""
    now = [0.0]
    path = tmp_path / "s.mcap"
    recorder = McapRecorder(path, flush_period_s=1.0, monotonic=lambda: now[0])
    for i in range(49):
        now[0] = 0.02 * i
        write(recorder, m.ALPHA, m.float64(0.5))
    assert read_recording(path).messages == [] and recorder.flushes == 0
    now[0] = 1.0
    write(recorder, m.ALPHA, m.float64(0.5))
    recording = read_recording(path)
    assert len(recording.messages) == 50 and not recording.complete and recorder.flushes == 1
    recorder.close()


WRITER = """
import sys
from otgym.bus import messages as m
from otgym.bus import schemas
from otgym.record.mcap_file import McapRecorder
now_s = [0.0]
recorder = McapRecorder(sys.argv[1], monotonic=lambda: now_s[0])
for i in range(int(sys.argv[2])):
    now_s[0] = i / 64  # the recorder's clock: 64 messages a second, exact in binary
    data = m.float64(i / 1000)
    recorder.write(m.ALPHA, m.FLOAT64, schemas.SCHEMAS[m.FLOAT64], data, log_time_ns=10**9 + i * 15_625_000)
    print(i, recorder.flushes, data.hex(), flush=True)
print("written", flush=True)
sys.stdin.read()  # the recording stays open until the process is killed
"""
MESSAGES = 200


def test_a_writer_killed_with_sigkill_keeps_every_message_up_to_its_last_flush(tmp_path):
    """A writer in its own process, on a fake clock of 64 messages a second, writes 200
    messages, says so, and is killed with SIGKILL while its recording is open. Counted,
    not timed: it flushes exactly when a message arrives a whole period (1 s) after the
    previous flush, at messages 64, 128 and 192; the file it leaves is incomplete (no
    summary) and holds exactly messages 0-192 (those up to its last flush, whose chunks
    the operating system kept), in order, with their log times and bytes, and none of the
    7 messages of the chunk still open. Catches a writer that flushes by another rule,
    loses a flushed chunk when killed, writes a chunk torn, or claims a complete file."""
    path = tmp_path / "killed.mcap"
    child = subprocess.Popen(
        [sys.executable, "-c", WRITER, str(path), str(MESSAGES)],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
    try:
        lines = []
        for line in child.stdout:  # the writer's own report, message by message; EOF if it died
            if line.strip() == "written":
                break
            lines.append(line.split())
        assert len(lines) == MESSAGES, f"the writer stopped after {len(lines)} messages (exit {child.poll()})"
        os.kill(child.pid, signal.SIGKILL)
        assert child.wait(timeout=60) == -signal.SIGKILL
    finally:
        child.kill()
        child.wait()
    flushes = [int(flushes) for _, flushes, _ in lines]
    assert [i for i in range(1, MESSAGES) if flushes[i] != flushes[i - 1]] == [64, 128, 192] and flushes[0] == 0
    assert flushes[-1] == 3
    recording = read_recording(path)
    assert not recording.complete
    kept = 193  # messages 0-192
    assert [(msg.topic, msg.log_time_ns, msg.data.hex()) for msg in recording.messages] == [
        (m.ALPHA, 10**9 + int(i) * 15_625_000, data) for i, _, data in lines[:kept]
    ]
