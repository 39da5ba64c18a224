"""A rig in place of the simulator, with real rclpy, each side its own process:
``otgym node sim --plant rig`` (the controller: autonomy, arbitration, the safety
limits), ``otgym node ros2 -p rig:=true`` (the bridge), ``otgym node recorder`` and
``examples/rig/first_order_rig.py``, a rig written with rclpy alone (no otgym import)
that moves its bodies toward the commanded traps with a first-order law and publishes
their centres. ROS 2 traffic stays on this machine: ``ROS_AUTOMATIC_DISCOVERY_RANGE=
LOCALHOST`` and a ``ROS_DOMAIN_ID`` of the test's own. Where rclpy or the message
wheels cannot be imported, the test is skipped and says so.

The route is the default chip's cut to its middle 140 um (``short_route_chip``: the same
image and ports, the start and goal sites moved onto the default route at 80 um and
220 um of its 307 um, from one branch through the central chamber into the other), so
a trial is about 30 s of simulated time instead of about 65 s; the full route is the run in docs/ros2.md.
A controller and a rig run in real time: on a machine starved of CPU (two cores at a
load average of 14-33) the simulator gets about 5 ticks a second, the traps wait for a
rig that lags, and the trial does not end within ``TRIAL_END_S`` (tried once: 105 of
140 um); quiet, it passes in about 70 s (about 120 CPU-s)."""

from __future__ import annotations

import dataclasses
import os
import re
import signal
import subprocess
import time

import pytest

from otgym.bus import messages as msg
from otgym.record.mcap_file import read_recording
from otgym.record.replay import events
from otgym.sim.chip import load_chip, save_chip
from tests.bus.test_nodes import ROOT, STARTUP_S, children, free_endpoint, spawn, wait_for_line  # noqa: F401  (fixture)
from tests.bus.test_ros2_bridge import ros_env  # noqa: F401  (fixture)

pytest.importorskip(
    "rclpy", reason="rclpy (ROS 2's Python wheels, otgym's extra [ros2]) cannot be imported here: no ROS 2 test"
)
pytest.importorskip(
    "geometry_msgs.msg", reason="ROS 2's geometry_msgs wheel (extra [ros2]) cannot be imported: no ROS 2 test"
)
TRIAL_END_S = 600.0
"""The bound on the first trial's end after the sim is ready: its 140 um of route at the
autonomy's 5 um/s cruise take about 30 s of simulated time with the grip, longer where
the traps wait for a rig that lags, and simulated time runs at a fraction of real time
under load."""
SHORT_ROUTE_SITES_UM = {"start": (92.7, 53.7), "goal": (204.8, 137.5)}
"""Points of the default chip's route at 80 um and 220 um of arc (its start is at
(15, 40) um, its goal at (285, 160) um)."""


@pytest.fixture
def short_route_chip(tmp_path):
    """The default chip with the start and goal sites of ``SHORT_ROUTE_SITES_UM``, as a PNG
    and its sidecar. Seed 3's scenarios of trials 1, 2, 4 and 5 fit its route (the third
    finds open water for 3 of its 4 obstacle crossings): the test needs the first, and
    the second, which starts while the test stops the sim."""
    chip = load_chip("default")
    short = dataclasses.replace(chip, name="default-middle", sites=tuple(SHORT_ROUTE_SITES_UM.items()))
    return save_chip(short, tmp_path / "chip")


def _stop(child: subprocess.Popen) -> str:
    """SIGINT to a child this test started (by its pid), then its output; SIGKILL after 30 s."""
    if child.poll() is None:
        os.kill(child.pid, signal.SIGINT)
    try:
        rest, _ = child.communicate(timeout=30)
    except subprocess.TimeoutExpired:
        os.kill(child.pid, signal.SIGKILL)
        rest, _ = child.communicate()
    return rest


@pytest.mark.slow
@pytest.mark.xdist_group("ros2_sessions")  # never beside the ROS 2 play test: real-time sessions of their own
def test_otgyms_autonomy_drives_an_rclpy_rig_to_the_goal_and_the_recorder_records_it(
    ros_env,  # noqa: F811
    children,  # noqa: F811
    tmp_path,
    short_route_chip,
):
    endpoint = free_endpoint()
    sim = spawn(
        "-m", "otgym", "node", "sim", "--plant", "rig", "--mode", "autonomous", "--seed", "3", "--listen", endpoint,
        "--chip", str(short_route_chip),
    )  # fmt: skip
    children.append(sim)
    bridge = spawn("-m", "otgym", "node", "ros2", "--connect", endpoint, "--ros-args", "-p", "rig:=true")
    recorder = spawn("-m", "otgym", "node", "recorder", "--out", str(tmp_path), "--connect", endpoint)
    rig = spawn(str(ROOT / "examples" / "rig" / "first_order_rig.py"))
    children.extend([bridge, recorder, rig])
    wait_for_line(rig, "ready", STARTUP_S)
    wait_for_line(bridge, "ready", STARTUP_S)
    wait_for_line(recorder, "ready", STARTUP_S)
    assert "plant rig" in wait_for_line(sim, "ready", STARTUP_S * 3)
    path = tmp_path / "session.mcap"
    deadline = time.monotonic() + TRIAL_END_S
    while not any(event["event"] == "trial_end" for event in events(read_recording(path))):
        assert time.monotonic() < deadline, f"no trial ended within {TRIAL_END_S} s"
        assert sim.poll() is None, _stop(sim)[-3000:]
        time.sleep(2.0)  # the recorder flushes every 0.25 s; a file cut short reads up to its last chunk
    sim_rest = _stop(sim)  # Ctrl-C: the trial under way ends as aborted, the session ends
    assert sim.returncode == 0, sim_rest[-3000:]
    wait_for_line(recorder, "recorded: session_end", 60.0)
    rig_rest, bridge_rest, _ = _stop(rig), _stop(bridge), _stop(recorder)
    assert rig.returncode == 0 and "Traceback" not in rig_rest, rig_rest[-3000:]
    assert bridge.returncode == 0 and "Traceback" not in bridge_rest, bridge_rest[-3000:]

    recording = read_recording(path)
    ends = [event for event in events(recording) if event["event"] == "trial_end"]
    assert ends and ends[0]["trial"] == 1, ends
    first = ends[0]
    assert first["ended_by"] == "goal" and first["reached_goal"] and first["trap_losses"] == 0, first
    counts = recording.counts()
    assert counts.get(msg.RIG_POSES, 0) > 1000 and counts.get(msg.RIG_START, 0) >= 1, counts
    # what the controller published as the bodies is what the rig measured, not a simulation
    measured = {msg.xy_um(msg.decode(m.topic, m.data)).tobytes() for m in recording.topic(msg.RIG_POSES)}
    bodies = [msg.xy_um(msg.decode(m.topic, m.data)) for m in recording.topic(msg.BODIES)]
    moved = [b for b in bodies if b.tobytes() in measured]
    assert len(moved) > 0.5 * len(bodies), (len(moved), len(bodies))
    counted = re.search(r"rig: (\d+) starts, (\d+) trap commands, (\d+) poses published", rig_rest)
    assert counted, rig_rest[-500:]
    starts, commands, published = (int(n) for n in counted.groups())
    # the trial's 1500 ticks or more each command the traps, the bridge passing on the latest it has of them
    assert starts >= 1 and commands > 500 and published > 1000, counted.group(0)
    print(rig_rest[-400:], bridge_rest[-300:])  # the counts and the commands' delay, for the log (pytest -s)
