"""``otgym node ros2`` with real rclpy, each side its own process: the test starts
``otgym node sim`` and ``otgym node ros2`` and runs ``tests/bus/ros2_probe.py``, a ROS 2
node written with rclpy alone, which lists the graph's topics, receives PoseArrays and
MarkerArrays and drives device0 with a TwistStamped. ROS 2 traffic stays on this
machine: ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` and a ``ROS_DOMAIN_ID`` of the
test's own, set for every process. Where rclpy or the message wheels cannot be
imported, the test is skipped and says so."""

from __future__ import annotations

import json
import os
import random
import signal
import subprocess

import pytest

from tests.bus.test_nodes import ROOT, STARTUP_S, children, free_endpoint, spawn, wait_for_line  # noqa: F401  (fixture)

pytest.importorskip(
    "rclpy", reason="rclpy (ROS 2's Python wheels, otgym's extra [ros2]) cannot be imported here: no ROS 2 test"
)
pytest.importorskip(
    "visualization_msgs.msg", reason="ROS 2's visualization_msgs wheel (extra [ros2]) cannot be imported: no ROS 2 test"
)
SESSION_S = 8.0
"""The play session's simulated seconds: the probe needs 10 PoseArrays of its first
moments, and each simulated second costs every node of the session CPU."""
TICK_S = 0.02
"""The interactive session's tick (``otgym.task.task.InteractiveConfig``)."""
PLAY_END_S = 420.0
"""The bound on the play session's end after the probe: the session at a fraction of
real time under load, then the sim's end, the recorder's drain and each node's stop
(up to 10 s each before SIGKILL)."""
NODES_READY_S = 900.0
"""How long ``otgym play --distributed`` waits for its nodes to be ready."""
PROBE_DEADLINE_S = 120.0
"""The probe's bound on all its waits together (discovery, 10 PoseArrays, the traps moving)."""


@pytest.fixture
def ros_env(monkeypatch):
    """ROS 2 on loopback in a domain of this test's own (1-232, ROS 2's documented range),
    for the processes it starts."""
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    monkeypatch.setenv("ROS_DOMAIN_ID", str(random.SystemRandom().randrange(1, 233)))
    monkeypatch.delenv("RMW_IMPLEMENTATION", raising=False)  # the default: Fast DDS
    monkeypatch.delenv("ROS_LOCALHOST_ONLY", raising=False)


@pytest.mark.slow
def test_a_ros2_node_lists_receives_and_drives_otgym_through_the_bridge(ros_env, children):  # noqa: F811
    endpoint = free_endpoint()
    children.append(spawn("-m", "otgym", "node", "sim", "--mode", "manual", "--listen", endpoint, "--seed", "3"))
    children.append(spawn("-m", "otgym", "node", "ros2", "--connect", endpoint))
    sim, bridge = children
    ready = wait_for_line(bridge, "ready", STARTUP_S)
    assert "rmw_fastrtps_cpp" in ready and f"domain {os.environ['ROS_DOMAIN_ID']}" in ready, ready
    wait_for_line(sim, "ready", STARTUP_S)
    probe = spawn(str(ROOT / "tests" / "bus" / "ros2_probe.py"), str(PROBE_DEADLINE_S))
    children.append(probe)
    output, _ = probe.communicate(timeout=PROBE_DEADLINE_S + 60)
    lines = [line for line in output.splitlines() if line.startswith("result: ")]
    assert probe.returncode == 0 and lines, output[-3000:]
    result = json.loads(lines[-1].removeprefix("result: "))
    assert "failed" not in result, result

    assert result["topics"]["/otgym/traps"] == ["geometry_msgs/msg/PoseArray"]
    assert result["topics"]["/otgym/markers"] == ["visualization_msgs/msg/MarkerArray"]
    assert result["pose_arrays"] >= 10 and result["poses_per_array"] == [4], result
    assert {"walls", "route", "goal", "robots", "cells", "obstacles", "traps"} <= set(result["marker_namespaces"])
    assert result["marker_frame"] == "chip"
    assert result["moved_x_um"] >= 2.0, result

    os.kill(bridge.pid, signal.SIGINT)  # a clean exit on Ctrl-C, with its counts
    rest, _ = bridge.communicate(timeout=30)
    assert bridge.returncode == 0, rest[-2000:]
    assert "messages to ROS 2" in rest and "Traceback" not in rest, rest[-2000:]


@pytest.mark.parametrize(
    "extra, word",
    [
        (["-p", "devices:=[device0]"], "--ros-args"),
        (["--ros-args", "-p", "devices:=3"], "devices"),
        (["--ros-args", "-p", "devices:=[bad name]"], "device name"),
        (["--ros-args", "-p", "markers_period_s:=-1.0"], "markers_period_s"),
        (["--ros-args", "-p", "autonomy:=3"], "autonomy"),
        (["--ros-args", "-p", "twist_topics:=[/cmd vel]"], "cmd vel"),
    ],
    ids=["no --ros-args", "not a list", "bad device", "negative period", "not a bool", "bad topic"],
)
def test_a_bad_ros2_argument_is_one_error_line_before_the_bus_opens(ros_env, monkeypatch, capsys, extra, word):
    import zenoh

    from otgym.cli import app as cli_app

    def refuse(*args, **kwargs):
        raise AssertionError("a zenoh session was opened before the ROS 2 arguments were checked")

    monkeypatch.setattr(zenoh, "open", refuse)
    with pytest.raises(SystemExit) as exit_info:
        cli_app.main(["node", "ros2", *extra])
    lines = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert exit_info.value.code == 2 and len(lines) == 1 and lines[0].startswith("error: "), lines
    assert word in lines[0], lines[0]


@pytest.mark.slow
def test_play_distributed_with_ros2_records_its_trial_shows_it_on_the_graph_and_leaves_nothing(ros_env, tmp_path):
    """``otgym play --distributed --ros2`` (headless, the simulated stylus, shared mode,
    participant D1), one session checked from both sides.

    The ROS 2 graph: a ROS 2 node of its own process receives the session's traps and
    markers while it runs. The session: it ends by its duration with exit code 0; the
    window's trials.csv has the one trial's row (ended by its duration at its simulated
    seconds); the recorder's session.mcap is complete and tells the same trial: its
    events in order (one trial_start of trial 1, D1, shared, the row's scenario; one
    trial_end whose every field is the row's; session_end last, with every tick), and
    the streams it recorded from the bus: every tick's traps at most once (a stream may
    drop a message under load, never duplicate one), in order of their stamps, and the
    stylus's twists and the autonomy's increments present. Nothing it started is left
    running: every process carries a marker in its environment, looked for in /proc.
    Catches a recorder that misses or repeats events, rows and events that disagree, a
    session cut short, a bridge that shows nothing. The probe starts with the session,
    so that its discovery overlaps the nodes' start-up and a short session suffices.
    Where ROS 2's wheels cannot be imported this test is skipped, and says so."""
    import csv
    import uuid

    from otgym.bus import messages as msg
    from otgym.record.mcap_file import read_recording
    from otgym.record.replay import events, summary
    from tests.ui.test_play_distributed import launch, wait_gone

    marker = uuid.uuid4().hex
    play = launch(tmp_path, marker, "--ros2", "--duration", str(SESSION_S), "--mode", "shared")
    # the probe waits as long as the launcher waits for its nodes, a guard against a hang
    # only (with STARTUP_S * 2 + PROBE_DEADLINE_S, 300 s, it gave up once in a cold run of
    # the whole suite on the loaded 2 cores; what otgym play printed was not kept then)
    probe_deadline_s = NODES_READY_S + PROBE_DEADLINE_S
    probe = spawn(str(ROOT / "tests" / "bus" / "ros2_probe.py"), str(probe_deadline_s), "--listen-only")
    try:
        output, _ = probe.communicate(timeout=probe_deadline_s + 60)
        lines = [line for line in output.splitlines() if line.startswith("result: ")]
        assert probe.returncode == 0 and lines, output[-3000:]
        result = json.loads(lines[-1].removeprefix("result: "))
        if "failed" in result:  # what the session printed tells how far it came
            if play.poll() is None:
                os.kill(play.pid, signal.SIGKILL)
            rest, errors = play.communicate()
            raise AssertionError(
                f"{result}; otgym play (exit code {play.returncode}) printed:\n{(rest + errors)[-3000:]}"
            )
        assert "failed" not in result, result
        assert result["pose_arrays"] >= 10 and result["poses_per_array"] == [4], result
        assert {"walls", "robots", "traps"} <= set(result["marker_namespaces"])
        try:  # the rest of the session (slower than real time under load), then the nodes' ends
            rest, errors = play.communicate(timeout=PLAY_END_S)
        except subprocess.TimeoutExpired:
            os.kill(play.pid, signal.SIGKILL)
            rest, _ = play.communicate()
            raise AssertionError(
                f"otgym play did not end within {PLAY_END_S} s of the probe:\n{rest[-3000:]}"
            ) from None
        assert play.returncode == 0, (rest + errors)[-3000:]
        assert "nodes ready" in rest, rest[-3000:]
    finally:
        for child in (probe, play):
            if child.poll() is None:
                os.kill(child.pid, signal.SIGKILL)
                child.wait()
    assert wait_gone(marker) == []

    with open(tmp_path / "trials.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert len(rows) == 1 and rows[0]["participant"] == "D1" and rows[0]["ended_by"] == "duration"
    assert float(rows[0]["completion_time_s"]) == pytest.approx(SESSION_S, abs=0.011)
    recording = read_recording(tmp_path / "session.mcap")
    recorded = summary(recording)
    assert recorded["complete"] and recorded["trials"] == 1 and recorded["ended_by"] == ["duration"]
    trial_events = events(recording)
    names = [event["event"] for event in trial_events]
    assert names[0] == "trial_start" and names[-1] == "session_end" and names.count("trial_end") == 1, names
    start, end = trial_events[0], trial_events[names.index("trial_end")]
    assert (start["trial"], start["participant"], start["mode"]) == (1, "D1", "shared")
    assert start["scenario"] == int(rows[0]["scenario"])
    for column, value in rows[0].items():
        assert column in end, column
        if isinstance(end[column], float):
            assert float(value) == pytest.approx(end[column], rel=1e-9), column
        else:
            assert value == ("" if end[column] is None else str(end[column])), column
    ticks = round(SESSION_S / TICK_S)
    assert trial_events[-1]["ticks"] == ticks and trial_events[-1]["trials"] == 1
    traps = [msg.stamp_s(msg.decode(msg.TRAPS, message.data)) for message in recording.topic(msg.TRAPS)]
    assert 0 < len(traps) <= ticks and all(b > a for a, b in zip(traps, traps[1:]))
    counts = recorded["counts"]
    assert counts["/otgym/device/device0/twist"] > 0 and counts["/otgym/autonomy/increments"] > 0
