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
import time

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
PLAY_END_S = 420.0
"""The bound on the play session's end after the probe: the session at a fraction of
real time under load, then the sim's end, the recorder's drain and each node's stop
(up to 10 s each before SIGKILL)."""
PROBE_DEADLINE_S = 120.0
"""The probe's bound on all its waits together (discovery, 10 PoseArrays, the traps moving)."""
PROBE_GRACE_S = 5.0
"""How long the probe may still receive after the play session has ended (messages in flight)."""


@pytest.fixture
def ros_env(monkeypatch):
    """ROS 2 on loopback in a domain of this test's own, for the processes it starts.

    The domain is drawn in 1-101: ROS 2's documentation calls 0-101 safe on Linux, where
    a higher domain's DDS ports fall in the kernel's ephemeral range. Fast DDS keeps its
    default transports (shared memory between processes of one machine, UDP), as a lab's."""
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    monkeypatch.setenv("ROS_DOMAIN_ID", str(random.SystemRandom().randrange(1, 102)))
    monkeypatch.delenv("FASTDDS_BUILTIN_TRANSPORTS", raising=False)
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
    assert result["topics"]["/otgym/trial/events"] == ["std_msgs/msg/String"]  # declared at start, none sent yet
    assert "/otgym/command" not in result["topics"]  # an input: the bridge subscribes to it
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
@pytest.mark.xdist_group("ros2_sessions")  # never beside the rig test: real-time sessions of their own
def test_play_distributed_with_ros2_puts_the_session_on_the_graph(ros_env, tmp_path):
    """``otgym play --distributed --ros2`` (headless, the simulated stylus): a ROS 2 node
    of its own process receives the session's traps and markers while it runs; the
    session then ends by its duration with exit code 0. The probe starts with the
    session, so that its discovery overlaps the nodes' start-up and a short session
    suffices."""
    play = spawn(
        "-m", "otgym", "play", "--headless", "--distributed", "--ros2", "--device", "simulated",
        "--no-questionnaire", "--mode", "manual", "--duration", str(SESSION_S), "--out", str(tmp_path),
    )  # fmt: skip
    probe_deadline_s = STARTUP_S * 2 + PROBE_DEADLINE_S
    probe = spawn(str(ROOT / "tests" / "bus" / "ros2_probe.py"), str(probe_deadline_s), "--listen-only")
    try:
        _end_probe_after(play, probe, probe_deadline_s + 60)
        output, _ = probe.communicate(timeout=60)
        lines = [line for line in output.splitlines() if line.startswith("result: ")]
        assert probe.returncode == 0 and lines, output[-3000:]
        result = json.loads(lines[-1].removeprefix("result: "))
        if "failed" in result:  # what both sides saw, to tell a silent graph from a late session
            play.send_signal(signal.SIGINT)
            rest, _ = play.communicate(timeout=PLAY_END_S)
            bridge = (tmp_path / "nodes" / "ros2.out").read_text(errors="replace")[-1500:]
            raise AssertionError(
                f"the probe {result}; otgym play (exit {play.returncode}): {rest[-2000:]}; its ros2 node: {bridge}"
            )
        assert result["pose_arrays"] >= 10 and result["poses_per_array"] == [4], result
        assert {"walls", "robots", "traps"} <= set(result["marker_namespaces"])
        try:  # the rest of the session (slower than real time under load), then the nodes' ends
            rest, _ = play.communicate(timeout=PLAY_END_S)
        except subprocess.TimeoutExpired:
            os.kill(play.pid, signal.SIGKILL)
            rest, _ = play.communicate()
            raise AssertionError(
                f"otgym play did not end within {PLAY_END_S} s of the probe:\n{rest[-3000:]}"
            ) from None
        assert play.returncode == 0, rest[-3000:]
        assert "nodes ready" in rest, rest[-3000:]
    finally:
        for child in (probe, play):
            if child.poll() is None:
                os.kill(child.pid, signal.SIGKILL)
                child.wait()


def _end_probe_after(play: subprocess.Popen, probe: subprocess.Popen, timeout_s: float) -> None:
    """Wait up to ``timeout_s`` for the probe to end; once ``play`` has ended and
    ``PROBE_GRACE_S`` passed, nothing more can reach the probe: end its waits (SIGTERM,
    it then reports what it saw)."""
    deadline, play_ended = time.monotonic() + timeout_s, None
    while probe.poll() is None and time.monotonic() < deadline:
        if play.poll() is not None:
            play_ended = play_ended or time.monotonic()
            if time.monotonic() - play_ended > PROBE_GRACE_S:
                probe.send_signal(signal.SIGTERM)
                return
        time.sleep(0.2)
