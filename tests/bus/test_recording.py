"""MCAP recordings of sessions (``otgym.bus.recording``): every tick's topics land in
the file with the counts sent and decode, with mcap's reader and mcap-ros2-support's
decoder, to the values sent; a writer killed with SIGKILL leaves a file readable up to
its last flush (at most about a second lost); ``otgym replay`` summarises a file and
refuses one that is not MCAP."""

import os
import signal
import subprocess
import sys
import time
from types import SimpleNamespace

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from otgym.bus import messages as msg
from otgym.bus.recording import SessionRecorder, summarize
from otgym.teleop.device import Sample

N_TICKS = 40


def fake_tick(k):
    """What a TickRecord holds for the recorder: time, traps, alpha, feedback per device."""
    return SimpleNamespace(time_s=0.02 * (k + 1), trap_xy_um=np.array([[k, 0.0], [k, 1.0], [k, 2.0], [k, 3.0]]),
                           alpha=0.1 + 0.01 * k, feedback_n=np.array([[0.01 * k, 0.0, 0.0], [0.0, 0.0, 0.0]]))


def record_session(path):
    recorder = SessionRecorder(path, ["left", "right"])
    recorder.start_trial(1, "P1", 10001, "shared")
    for k in range(N_TICKS):
        sample = Sample(float(k), k, np.zeros(3), np.array([1.0, 2.0, 0.0]), 1)
        recorder.record_tick(fake_tick(k), [sample, None], np.zeros((3, 3)))
        if k == 10:
            recorder.mode("manual", 0.2)
    recorder.end_trial({"trial": 1, "reached_goal": False, "completion_time_s": float("nan")}, 0.02 * N_TICKS)
    recorder.close()
    return recorder


def test_a_recording_holds_every_message_sent_and_decodes_independently(tmp_path):
    path = tmp_path / "session.mcap"
    recorder = record_session(path)
    with open(path, "rb") as handle:
        reader = make_reader(handle, decoder_factories=[DecoderFactory()])
        assert reader.get_header().profile == "ros2"
        counts, alphas, twist_x = {}, [], []
        for schema, channel, message, decoded in reader.iter_decoded_messages():
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
            assert schema.encoding == "ros2msg" and channel.message_encoding == "cdr"
            if channel.topic == msg.ALPHA_TOPIC:
                alphas.append(decoded.data)
            if channel.topic == "/otgym/device/left/twist":
                twist_x.append(decoded.twist.linear.x)
    assert counts == recorder.counts
    assert counts[msg.TRAPS_TOPIC] == counts["/otgym/feedback/right"] == N_TICKS
    assert counts["/otgym/device/left/twist"] == N_TICKS and "/otgym/device/right/twist" not in counts
    assert counts[msg.MODE_TOPIC] == 2 and counts[msg.EVENTS_TOPIC] == 2
    np.testing.assert_allclose(alphas, 0.1 + 0.01 * np.arange(N_TICKS))
    np.testing.assert_allclose(twist_x, 0.001)  # 1 mm/s sent as m/s
    summary = summarize(path)
    assert summary["messages"] == recorder.counts and summary["trials"][0]["completion_time_s"] is None


WRITER = """
import sys, time
import numpy as np
from types import SimpleNamespace
from otgym.bus.recording import SessionRecorder
recorder = SessionRecorder(sys.argv[1], ["left"], flush_interval_s=0.5)
k = 0
while True:
    tick = SimpleNamespace(time_s=0.02 * k, trap_xy_um=np.zeros((4, 2)), alpha=0.1, feedback_n=np.zeros((1, 3)))
    recorder.record_tick(tick, [None], np.zeros((3, 3)))
    k += 1
    print(k, flush=True)
    time.sleep(0.02)
"""


def test_a_writer_killed_with_sigkill_loses_at_most_about_a_second(tmp_path):
    """A child process records ticks at 50 Hz (4 messages each), flushing every 0.5 s;
    killed by its pid after about 2 s, its file still reads, and holds every tick
    but those of the last second (50 ticks) before the kill."""
    path = tmp_path / "killed.mcap"
    child = subprocess.Popen([sys.executable, "-c", WRITER, str(path)], stdout=subprocess.PIPE, text=True)
    try:
        written = 0
        deadline = time.monotonic() + 120  # imports and the first ticks
        while written < 100 and time.monotonic() < deadline:
            written = int(child.stdout.readline() or written)
        assert written >= 100, "the writer did not start"
    finally:
        os.kill(child.pid, signal.SIGKILL)
        child.wait()
    ticks = summarize(path)["messages"].get(msg.TRAPS_TOPIC, 0)
    assert written - 50 <= ticks <= written + 5


def test_replay_summarises_a_recording_and_refuses_a_file_that_is_not_one(tmp_path, capsys):
    from otgym.cli.app import main

    path = tmp_path / "session.mcap"
    record_session(path)
    with pytest.raises(SystemExit) as exit_info:
        main(["replay", str(path)])
    assert exit_info.value.code == 0
    out = capsys.readouterr().out
    assert f"{msg.TRAPS_TOPIC}: {N_TICKS}" in out and "trial 1" in out
    bad = tmp_path / "bad.mcap"
    bad.write_text("not a recording")
    with pytest.raises(SystemExit) as exit_info:
        main(["replay", str(bad)])
    assert exit_info.value.code == 2
    assert capsys.readouterr().err.startswith("error: ")
