"""Nodes over zenoh on loopback, each fault tested by killing a real process this test
started (by its pid): a device node killed -> the simulator's input from it is zero
at once and the traps hold; the simulator killed -> a device node zeros its force,
and finds the restarted simulator by itself; a recorder killed with SIGKILL -> its
file keeps all but the last moments; a malformed message is dropped and counted.

How fast a loss is seen (the goal: within 100 ms) is measured by ``benchmarks/bus.py``;
these tests wait for each event (a ``ready`` line, a liveliness token, a message) with
a deadline that only guards against a hang, and assert what happens, not how fast.
The task is built once (``tests.runtime.shared_task``) for the tests that tick it."""

from __future__ import annotations

import itertools
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from otgym.bus import messages as msg
from otgym.bus.nodes import RemoteDevice, run_device_node
from otgym.bus.transport import Node
from otgym.record.mcap_file import read_recording
from otgym.runtime.loop import DeviceBinding, InteractiveLoop
from otgym.teleop.device import Device, DeviceCaps, Sample
from otgym.teleop.replay import record_samples
from tests.otgym_cli import run_otgym

ROOT = Path(__file__).resolve().parents[2]
STARTUP_S = 90.0
DEADLINE_S = 60.0
"""How long a test waits for an event before it calls it lost (a guard against hangs)."""


def free_endpoint() -> str:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return f"tcp/127.0.0.1:{probe.getsockname()[1]}"


def spawn(*arguments: str) -> subprocess.Popen:
    """A child python process with this checkout on its path; stdout piped."""
    return subprocess.Popen(
        [sys.executable, *arguments],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )


def wait_for_line(child: subprocess.Popen, prefix: str, timeout_s: float = STARTUP_S) -> str:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        line = child.stdout.readline()
        if line.startswith(prefix):
            return line
        if not line and child.poll() is not None:
            raise AssertionError(f"child exited ({child.returncode}) before {prefix!r}")
    raise AssertionError(f"no {prefix!r} within {timeout_s} s")


def wait_until(condition, timeout_s: float) -> float:
    """Seconds until ``condition()`` held; AssertionError after ``timeout_s``."""
    start = time.monotonic()
    while not condition():
        if time.monotonic() - start > timeout_s:
            raise AssertionError(f"not within {timeout_s} s")
        time.sleep(0.001)
    return time.monotonic() - start


def poll_until(condition, timeout_s: float) -> bool:
    """Whether ``condition()`` held within ``timeout_s`` (polled every millisecond)."""
    deadline = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.001)
    return True


def kill(child: subprocess.Popen) -> float:
    """SIGKILL ``child`` by its pid; the monotonic time of the kill."""
    os.kill(child.pid, signal.SIGKILL)
    killed_at = time.monotonic()
    child.wait()
    return killed_at


@pytest.fixture
def children():
    started: list[subprocess.Popen] = []
    yield started
    for child in started:
        if child.poll() is None:
            os.kill(child.pid, signal.SIGKILL)
            child.wait()


def device_node(endpoint: str, csv: Path) -> subprocess.Popen:
    """``otgym node device`` replaying a stylus moving at 10 mm/s along x, clutch held."""
    record_samples([Sample(0.01 * i, i, (0.1 * i, 0.0, 0.0), (10.0, 0.0, 0.0), 1) for i in range(100)], csv)
    return spawn(
        "-m",
        "otgym",
        "node",
        "device",
        "--device",
        "replay",
        "--replay",
        str(csv),
        "--name",
        "device0",
        "--connect",
        endpoint,
    )


@pytest.mark.slow
def test_device_node_killed_its_input_is_zero_at_once_and_the_traps_hold(tmp_path, children):
    from tests.task import fast_scenario, shared_task

    task = shared_task()
    endpoint = free_endpoint()
    with Node("sim", "sim", listen=[endpoint]) as node:
        remote = RemoteDevice(node, "device0")
        loop = InteractiveLoop(task, [DeviceBinding(remote, robots=(0,))], fast_scenario(7), "manual")
        loop.start()
        children.append(device_node(endpoint, tmp_path / "steady.csv"))
        wait_for_line(children[0], "ready")
        wait_until(lambda: remote.alive and remote.read() is not None, 30.0)
        driven = [loop.tick() for _ in range(30)]
        assert max(np.abs(r.human_um).max() for r in driven) > 0.01  # the device node drives robot 0
        kill(children[0])
        wait_until(lambda: remote.losses == 1, DEADLINE_S)
        assert not remote.alive and remote.read().buttons == 0
        np.testing.assert_array_equal(remote.read().velocity_mm_s, 0.0)
        after = loop.run(0.4, realtime=True)  # 20 ticks over 0.4 s of wall time: the rest sample ages into silence
        for record in after:
            np.testing.assert_array_equal(record.human_um, 0.0)
            np.testing.assert_array_equal(record.shared_um, 0.0)
            np.testing.assert_array_equal(record.trap_xy_um, after[0].trap_xy_um)
        assert not after[-1].device_live[0]


SIM_STAND_IN = """
import sys, time
from otgym.bus import messages as m
from otgym.bus.transport import Node
seen = []
with Node("sim", "sim", listen=[sys.argv[1]]) as node:
    node.subscribe(m.twist_topic("device0"), lambda topic, message, data: seen.append(1))
    print("ready", flush=True)
    reported = 0
    while True:
        node.publish(m.feedback_topic("device0"), m.wrench((0.5, 0.0, 0.0), time.time(), "device0"))
        if len(seen) >= reported + 10:
            reported = len(seen)
            print("twists", reported, flush=True)
        time.sleep(0.02)
"""


class SpyStylus(Device):
    """Fresh samples at 1 mm/s with the clutch held; records every force it is sent."""

    def __init__(self):
        self.caps = DeviceCaps("spy", 3, 0.88, (160.0, 120.0, 70.0), 1000.0)
        self.forces: list[np.ndarray] = []
        self.sequence = 0

    def start(self):
        pass

    def stop(self):
        pass

    def read(self):
        self.sequence += 1
        return Sample(time.monotonic(), self.sequence, np.zeros(3), (1.0, 0.0, 0.0), 1)

    def set_force(self, force_n):
        self.forces.append(np.array(force_n, float))


@pytest.mark.slow
def test_sim_killed_the_device_force_is_zeroed_and_the_restarted_sim_is_found(children):
    endpoint = free_endpoint()
    spy, stop = SpyStylus(), threading.Event()
    children.append(spawn("-c", SIM_STAND_IN, endpoint))
    wait_for_line(children[-1], "ready")
    with Node("device", "device0", connect=[endpoint]) as node:
        worker = threading.Thread(target=run_device_node, args=(node, spy, "device0", stop), daemon=True)
        worker.start()
        try:
            wait_for_line(children[-1], "twists")
            wait_until(lambda: spy.forces and spy.forces[-1][0] == 0.5, 10.0)
            kill(children[-1])
            wait_until(lambda: spy.forces[-1][0] == 0.0, DEADLINE_S)
            children.append(spawn("-c", SIM_STAND_IN, endpoint))  # the same endpoint, a new process
            wait_for_line(children[-1], "ready")
            wait_for_line(children[-1], "twists", 30.0)  # the device node reconnected by itself
            wait_until(lambda: spy.forces[-1][0] == 0.5, 10.0)  # and takes feedback again
        finally:
            stop.set()
            worker.join(5.0)
    assert np.all(spy.forces[-1] == 0.0)  # zero force when the node stops


@pytest.mark.slow
def test_recorder_node_killed_with_sigkill_keeps_all_but_its_last_moments(tmp_path, children):
    """Messages at 50 Hz until the recorder's file on disk holds 50 of them (its chunks
    are flushed as it goes), then SIGKILL: the file reads as incomplete and holds an
    unbroken prefix of what was sent, in order. How much a kill loses is set by the
    flush rule, tested on a fake clock in tests/record/test_mcap_file.py."""
    endpoint = free_endpoint()
    children.append(spawn("-m", "otgym", "node", "recorder", "--out", str(tmp_path), "--listen", endpoint))
    wait_for_line(children[0], "ready")
    path, sent = tmp_path / "session.mcap", 0
    with Node("device", "device0", connect=[endpoint]) as node:
        node.wait_for_subscribers(msg.ALPHA)
        deadline = time.monotonic() + STARTUP_S
        while sent % 10 or not path.is_file() or len(read_recording(path).messages) < 50:
            assert time.monotonic() < deadline, "the recorder flushed nothing"
            node.publish(msg.ALPHA, msg.float64(sent / 1000))
            sent += 1
            time.sleep(0.02)  # 50 Hz, the rate of a session's ticks
        kill(children[0])
    recording = read_recording(path)
    # only this test's topic: a node of a parallel test that retries a port it knew can
    # reach a recorder that listens there now (seen once: a trial_end event)
    values = [msg.decode(msg.ALPHA, m.data).data for m in recording.messages if m.topic == msg.ALPHA]
    assert not recording.complete and 50 <= len(values) <= sent
    assert values == [i / 1000 for i in range(len(values))], values[:8]  # in order, none missing


@pytest.mark.slow
def test_recorder_node_says_when_the_session_end_is_in_its_file(tmp_path, children):
    """The recorder node prints its SESSION_END_RECORDED line (what ``otgym play
    --distributed`` waits for before stopping it) once the sim's session_end event is
    written, not for another event, and announces it on the bus (``Node.wait_for``: what
    the sim waits on before it closes the bus), also when it was stopped meanwhile; after
    SIGTERM the file holds both events. Catches a line printed for any event, or none."""
    from otgym.cli.node import SESSION_END_RECORDED

    endpoint = free_endpoint()
    children.append(spawn("-m", "otgym", "node", "recorder", "--out", str(tmp_path), "--listen", endpoint))
    wait_for_line(children[0], "ready")
    with Node("sim", "sim", connect=[endpoint]) as node:
        node.wait_for_subscribers(msg.EVENTS)
        os.kill(children[0].pid, signal.SIGSTOP)  # a recorder starved of CPU at the session's end
        try:
            node.publish(msg.EVENTS, msg.event("trial_end", trial=1))
            node.publish(msg.EVENTS, msg.event("session_end", trials=1))
            assert node.wait_for("session_end", "recorder", 1.0) == ["recorder"]  # what the sim waits on
        finally:
            os.kill(children[0].pid, signal.SIGCONT)
        lines = [wait_for_line(children[0], "recorded:", 10.0)]
        assert node.wait_for("session_end", "recorder", 10.0) == []
    children[0].send_signal(signal.SIGTERM)
    rest, _ = children[0].communicate(timeout=30)
    lines += rest.splitlines()
    assert [line.strip() for line in lines if line.startswith("recorded:")] == [SESSION_END_RECORDED]
    events = [
        msg.event_fields(msg.decode(msg.EVENTS, m.data))["event"]
        for m in read_recording(tmp_path / "session.mcap").messages
        if m.topic == msg.EVENTS
    ]
    assert events == ["trial_end", "session_end"]


def test_malformed_messages_are_dropped_and_counted_never_applied():
    endpoint = free_endpoint()
    with Node("sim", "sim", listen=[endpoint]) as sim, Node("device", "device0", connect=[endpoint]) as device:
        remote = RemoteDevice(sim, "device0")
        remote.start()
        wait_until(lambda: remote.alive, 10.0)
        good = msg.twist(Sample(0, 0, np.zeros(3), (1.0, 0.0, 0.0), 1), time.time(), "device0")
        bad = [
            msg.twist(Sample(0, 0, np.zeros(3), (np.nan, 0.0, 0.0), 1), time.time(), "device0"),
            b"\x00\x01\x00\x00garbage",
            msg.float64(0.5),
        ]

        def count(table):
            return table.get(msg.twist_topic("device0"), 0)

        wait_until(lambda: (device.publish(msg.twist_topic("device0"), good), count(sim.received))[1] > 0, 10.0)
        # one publisher's messages arrive in order: once the last one sent is in, nothing
        # sent before it is still on the way (each try is marked by its own z velocity)
        tries = 0
        while True:
            tries += 1
            marked = Sample(0, 0, np.zeros(3), (1.0, 0.0, tries / 8), 1)
            device.publish(msg.twist_topic("device0"), msg.twist(marked, time.time(), "device0"))
            if poll_until(lambda: remote.read().velocity_mm_s[2] == tries / 8, 5.0):
                break
            assert tries < 20, "no marked twist arrived"
        received = count(sim.received)
        for data in bad:
            device.publish(msg.twist_topic("device0"), data)
        wait_until(lambda: count(sim.dropped) == 3, 5.0)
        assert count(sim.received) == received
        np.testing.assert_allclose(remote.read().velocity_mm_s, [1.0, 0.0, tries / 8])  # the last good one


@pytest.mark.slow
def test_sim_node_publishes_every_tick_and_the_trial_events():
    from otgym.bus.sim_node import run_sim_node
    from tests.task import shared_task

    endpoint = free_endpoint()
    seen: dict[str, list] = {}
    with Node("sim", "sim", listen=[endpoint]) as sim, Node("recorder", "recorder", connect=[endpoint]) as listener:
        listener.subscribe("/otgym/**", lambda topic, message, data: seen.setdefault(topic, []).append(message))
        sim.wait_for_subscribers(msg.TRAPS)  # the listener's pattern covers every topic
        ticks = run_sim_node(sim, shared_task(), ["device0"], "manual", 0, threading.Event(), duration_s=1.0)
        wait_until(lambda: len(seen.get(msg.EVENTS, [])) == 3, 30.0)  # session_end: the sim's last message
        wait_until(lambda: all(len(seen.get(t, [])) >= ticks for t in (msg.TRAPS, msg.BODIES, msg.ALPHA)), 30.0)
    assert ticks == 50
    for topic in (msg.TRAPS, msg.BODIES, msg.ALPHA):
        assert len(seen[topic]) == ticks, topic
    for topic in (msg.MODE, msg.SESSION, msg.CHIP, msg.ROUTE):  # latched: once (the mode never changed)
        assert len(seen[topic]) == 1, topic
    assert seen[msg.MODE][0].data == "manual"
    events = [msg.event_fields(e) for e in seen[msg.EVENTS]]
    assert [e["event"] for e in events] == ["trial_start", "trial_end", "session_end"]
    assert events[1]["ended_by"] == "duration" and events[1]["completion_time_s"] == pytest.approx(1.0, abs=0.011)
    assert len(msg.xy_um(seen[msg.TRAPS][-1])) == shared_task().n_traps


@pytest.mark.slow
def test_autonomy_node_drives_shared_control_and_its_death_falls_back_to_manual_with_a_cue(children):
    """The sim (in this process, shared mode, no device) takes dP_r from an autonomy node
    process: the traps move as the in-process navigator would move them. Killed by its
    pid, the sim runs as manual (mode message and an ``autonomy_lost`` event) within the
    detection bound, and with no device the traps then hold."""
    from otgym.bus.sim_node import run_sim_node
    from tests.task import shared_task

    endpoint = free_endpoint()
    seen: dict[str, list] = {}
    lock = threading.Lock()

    arrivals = itertools.count()

    def remember(topic, message, data):  # each message with its place in the order of arrival
        with lock:
            seen.setdefault(topic, []).append((next(arrivals), message))

    stop = threading.Event()
    with Node("sim", "sim", listen=[endpoint]) as sim, Node("recorder", "recorder", connect=[endpoint]) as listener:
        listener.subscribe("/otgym/**", remember)
        children.append(spawn("-m", "otgym", "node", "autonomy", "--connect", endpoint))
        wait_for_line(children[0], "ready")
        worker = threading.Thread(
            target=run_sim_node,
            args=(sim, shared_task(), ["device0"], "shared", 3, stop),
            kwargs={"remote_autonomy": True},
            daemon=True,
        )
        worker.start()
        try:
            wait_until(lambda: len(seen.get(msg.BODIES, [])) >= 100, 30.0)
            # the mode is sent at the trial's start and on change only (manual until the first dP_r), not every
            # tick: 2 messages over 100+ ticks. A latched message can reach a subscriber that starts with its
            # publisher twice, from the history query and live (a cold full run saw a repeat), hence 4 at most.
            modes = [m.data for _, m in seen[msg.MODE]]
            assert modes[-1] == "shared" and len(modes) <= 4, modes
            with lock:
                traps = [msg.xy_um(m) for _, m in seen[msg.TRAPS]]
            moved_um = np.linalg.norm(traps[-1] - traps[0], axis=-1)
            assert moved_um.min() > 0.5  # the autonomy alone (no device) moved every trap
            with lock:
                killed_at = len(seen[msg.TRAPS]) and seen[msg.TRAPS][-1][0]
            kill(children[0])
            wait_until(lambda: any(t > killed_at and m.data == "manual" for t, m in seen[msg.MODE]), DEADLINE_S)
            wait_until(lambda: sum(t > killed_at for t, _ in seen[msg.TRAPS]) >= 40, DEADLINE_S)
        finally:
            stop.set()
            worker.join(10.0)
    with lock:
        fallback = min(t for t, m in seen[msg.MODE] if t > killed_at and m.data == "manual")
        events = [msg.event_fields(m) for _, m in seen[msg.EVENTS]]
        late_traps = [msg.xy_um(m) for t, m in seen[msg.TRAPS] if t > fallback][5:]  # 0.1 s of ticks on
    lost = [e for e in events if e["event"] == "autonomy_lost"]
    assert lost and lost[-1]["mode"] == "manual"
    np.testing.assert_array_equal(late_traps[-1], late_traps[0])  # manual with no hand: the traps hold


def test_remote_autonomy_gives_only_fresh_increments_from_a_live_node():
    from otgym.bus.nodes import AUTONOMY_TIMEOUT_S, RemoteAutonomy

    class Wiring:  # stands in for a Node: keeps the callbacks
        def __init__(self):
            self.callbacks = {}

        def subscribe(self, topic, callback):
            self.callbacks[topic] = callback

        def watch(self, role, callback):
            self.callbacks[role] = callback

    now = [100.0]
    wiring = Wiring()
    autonomy = RemoteAutonomy(wiring, n_traps=4, clock=lambda: now[0])
    increments = np.arange(8.0).reshape(4, 2) * 0.01

    def send(points):
        wiring.callbacks[msg.AUTONOMY](msg.AUTONOMY, msg.decode(msg.AUTONOMY, msg.pose_array(points, 1.0)), b"")

    send(increments)
    assert autonomy(None) is None  # no liveliness token seen yet
    wiring.callbacks["autonomy"]("autonomy", True)
    np.testing.assert_allclose(autonomy(None), increments[None])
    now[0] += AUTONOMY_TIMEOUT_S * 1.01
    assert autonomy(None) is None  # stale
    send(increments[:3])
    assert autonomy.rejected == 1 and autonomy(None) is None  # another task's traps
    send(increments)
    np.testing.assert_allclose(autonomy(None), increments[None])
    wiring.callbacks["autonomy"]("autonomy", False)
    assert autonomy(None) is None and autonomy.losses == 1


def test_a_remote_device_answers_each_twist_at_once_with_the_latest_force_and_its_stamp():
    """With ``answer_twists`` (the sim node's bus side) every twist is answered with the
    force last set, stamped with the twist's own stamp; each sample, and the rest sample
    of a device node that went away, goes to ``on_sample`` (the sim's worker)."""
    endpoint = free_endpoint()
    answers, samples = [], []
    with Node("sim", "sim", listen=[endpoint]) as sim:
        with Node("device", "device0", connect=[endpoint]) as device:
            remote = RemoteDevice(sim, "device0", answer_twists=True, on_sample=samples.append)
            remote.start()
            device.subscribe(msg.feedback_topic("device0"), lambda topic, message, data: answers.append(message))
            wait_until(lambda: remote.alive, 10.0)
            wait_until(lambda: (remote.set_force([0.25, 0.0, 0.0]), answers)[1], 10.0)  # the subscription is up
            stamp = 1_700_000_123.5
            twist = msg.twist(Sample(0, 0, np.zeros(3), (1.0, 0, 0), 1), stamp, "device0")
            wait_until(
                lambda: (
                    device.publish(msg.twist_topic("device0"), twist),
                    [a for a in answers if msg.stamp_s(a) == stamp],
                )[1],
                5.0,
            )
            answer = next(a for a in answers if msg.stamp_s(a) == stamp)
        # the device node closed while the sim still listens: its rest sample arrives
        wait_until(lambda: not samples[-1].velocity_mm_s.any(), DEADLINE_S)
    assert msg.force_n(answer)[0] == 0.25
    assert samples[0].velocity_mm_s[0] == pytest.approx(1.0)


def test_a_twist_handed_on_while_the_node_is_lost_never_follows_its_rest_sample():
    """Twists and the liveliness token arrive on different threads. A twist made before
    the device node's token went away must reach ``on_sample`` (the sim's worker) before
    the rest sample, or the traps would move on after the node died: the twist's thread is
    held inside ``on_sample`` until the token's thread has either finished or found the
    device's lock held; the rest sample must come last (handed on outside the lock, the
    rest sample overtakes the held twist and this fails)."""

    class Wiring:  # stands in for a Node
        def subscribe(self, topic, callback):
            pass

        def watch(self, role, callback):
            pass

        def publish(self, topic, data):
            pass

    class WatchedLock:  # the device's lock, saying when a thread finds it held
        def __init__(self):
            self.lock, self.contended = threading.Lock(), threading.Event()

        def __enter__(self):
            if not self.lock.acquire(blocking=False):
                self.contended.set()
                self.lock.acquire()

        def __exit__(self, *exc):
            self.lock.release()

    samples, in_twist, release = [], threading.Event(), threading.Event()

    def on_sample(sample):
        if sample.velocity_mm_s.any():
            in_twist.set()
            release.wait(DEADLINE_S)
        samples.append(sample)

    remote = RemoteDevice(Wiring(), "device0", on_sample=on_sample)
    remote._lock = lock = WatchedLock()
    remote._on_liveliness("device0", True)
    twist = msg.decode(msg.twist_topic("device0"), msg.twist(Sample(0, 0, np.zeros(3), (1.0, 0, 0), 1), 5.0, "device0"))
    moving = threading.Thread(target=remote._on_twist, args=(msg.twist_topic("device0"), twist, b""))
    moving.start()
    assert in_twist.wait(DEADLINE_S)
    lost = threading.Thread(target=remote._on_liveliness, args=("device0", False))
    lost.start()
    wait_until(lambda: lock.contended.is_set() or not lost.is_alive(), DEADLINE_S)  # blocked, or overtook
    release.set()
    moving.join(DEADLINE_S)
    lost.join(DEADLINE_S)
    assert [s.velocity_mm_s[0] for s in samples] == [1.0, 0.0]
    assert remote.read() is samples[-1] and remote.losses == 1


@pytest.mark.parametrize(
    "args, message",
    [
        (["autonomy", "--navigator", "astar"], "--navigator: unknown navigator 'astar'; choose one of route, mpc, rl"),
        (["sim", "--autonomy", "cloud"], "--autonomy must be one of local, remote, not 'cloud'"),
        (["sim", "--mode", "telepathic"], "--mode must be one of manual, shared, autonomous, not 'telepathic'"),
        (["sim", "--participant", "P1,P2"], "--participant must be a non-empty ID without commas"),
        (["sim", "--takeover", "ui0,,ui1"], "device name must be a letter"),
        (["device", "--device", "replay"], "--device replay needs --replay"),
        (["device", "--device", "simulated", "--device-name", "Left"], "--device-name needs --device touch, not"),
    ],
)
def test_bad_node_arguments_end_in_one_line_and_exit_2(args, message):
    """Run in this process (``tests.otgym_cli``): each is refused before a node starts."""
    run = run_otgym(["node", *args])
    assert run.returncode == 2 and "Traceback" not in run.stderr
    assert run.stderr.strip().splitlines() == [f"error: {run.stderr.strip().removeprefix('error: ')}"]
    assert message in run.stderr


@pytest.mark.parametrize(
    "args, message",
    [
        (["pilot"], "No such command 'pilot'"),
        (["device", "--navigator", "mpc"], "No such option: --navigator"),  # each role takes only its own options
        (["autonomy", "--out", "x"], "No such option: --out"),
        (["recorder"], "Missing option '--out'"),
    ],
)
def test_a_role_takes_only_its_own_options(args, message):
    run = run_otgym(["node", *args])
    assert run.returncode == 2 and message in run.stderr and "Traceback" not in run.stderr
