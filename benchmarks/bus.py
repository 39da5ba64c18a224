"""The bus on loopback (``otgym.bus``): round trip device -> sim -> feedback while the
simulation runs, liveliness (how soon a killed node is noticed), and message rates,
against the in-process runtime measured in the same run.

* Round trip: this process is a device node (a ``Node`` of role device) sending a
  twist at 50 Hz; each twist carries its send time in its header stamp, the answering
  wrench echoes it, so the round trip is this process's receive time minus that
  stamp: encode, zenoh publish, TCP over loopback, receive, decode and check, encode,
  publish, back, decode and check. Three sim sides, each a child process:
  - ``node``: ``otgym node sim`` as it runs (``otgym.bus.sim_node.serve_sim_node``):
    the session ticks in its worker process at 50 Hz, the node's own process answers
    every twist at once with the latest force;
  - ``same-process``: the earlier design, a ``Node`` whose subscriber callback answers
    while the same process's main thread ticks ``InteractiveLoop`` back to back (worst
    case: the tick holds the interpreter lock the callback waits for);
  - ``same-process, paced``: as above, ticks paced at 50 Hz (the earlier sim node);
  - ``idle``: a ``Node`` of role sim that only answers (the bus alone, no simulation).
  Reference in the same run: the in-process runtime's device path (``Device.read`` and
  ``Device.set_force`` around one tick; no bus).
* Liveliness: a light child node (no simulation) is started and SIGKILLed ``--kills``
  times; the time from the kill to this process's liveliness DELETE.
* Rates: encoding, and decoding with the checks, per message type in this process,
  and the same with the ROS 2 layer's per-message work (rmw_zenoh's attachment built,
  then ``otgym.bus.intake``'s checks of type, hash, attachment, sequence and size).

    python benchmarks/bus.py [--round-trips 1000] [--kills 5]
"""

from __future__ import annotations

import argparse
import os
import signal
import socket
import subprocess
import sys
import threading
import time
import timeit
from pathlib import Path

import numpy as np

from otgym.bus import messages as msg
from otgym.bus.transport import Node
from otgym.teleop.device import Sample

ROOT = Path(__file__).resolve().parents[1]
SIM_SIDE = """
import sys, threading, time
from otgym.bus import messages as m
from otgym.bus.transport import Node
load = sys.argv[2] in ("sim", "paced")
with Node("sim", "sim", listen=[sys.argv[1]]) as node:
    def echo(topic, message, data):
        node.publish(m.feedback_topic("device0"), m.wrench((0.1, 0.0, 0.0), m.stamp_s(message), "device0"))
    node.subscribe(m.twist_topic("device0"), echo)
    if load:
        from otgym.runtime.loop import InteractiveLoop
        from otgym.task.task import InteractiveTask
        task = InteractiveTask()
        loop = InteractiveLoop(task, [], task.scenario(7), "shared")
        for _ in range(5):
            loop.tick()
    print("ready", flush=True)
    deadline = time.monotonic()
    while True:
        if load:
            loop.tick()
        else:
            time.sleep(0.1)
        if sys.argv[2] == "paced":
            deadline += loop.tick_s
            time.sleep(max(deadline - time.monotonic(), 0.0))
"""


def free_endpoint() -> str:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return f"tcp/127.0.0.1:{probe.getsockname()[1]}"


def spawn(endpoint: str, load: str) -> subprocess.Popen:
    """A sim side (see the module's docstring): ``node``, ``sim`` (same process, back to
    back), ``paced`` (same process, 50 Hz) or ``idle`` (an echo only)."""
    if load == "node":
        command = ["-m", "otgym", "node", "sim", "--name", "device0", "--listen", endpoint]
    else:
        command = ["-c", SIM_SIDE, endpoint, load]
    child = subprocess.Popen(
        [sys.executable, *command], stdout=subprocess.PIPE, text=True, env={**os.environ, "PYTHONPATH": str(ROOT)}
    )
    while not child.stdout.readline().startswith("ready"):
        if child.poll() is not None:
            raise RuntimeError("the sim side died")
    return child


def percentiles_ms(values_s) -> str:
    values = np.asarray(values_s) * 1e3
    return f"p50 {np.percentile(values, 50):.3f} ms, p99 {np.percentile(values, 99):.3f} ms (n={len(values)})"


def round_trip(n: int, side: str) -> None:
    endpoint = free_endpoint()
    child = spawn(endpoint, side)
    rtts, arrived = [], threading.Event()
    sent: set[float] = set()
    try:
        with Node("device", "device0", connect=[endpoint]) as node:

            def on_feedback(topic, message, data):
                stamp = msg.stamp_s(message)
                if stamp in sent:  # an answer to a twist (the node also publishes each tick's force)
                    rtts.append(time.time() - stamp)
                    arrived.set()

            def send() -> None:
                data = msg.twist(sample, time.time(), "device0")
                sent.add(msg.stamp_s(msg.decode(topic, data)))  # the stamp as it travels (nanoseconds)
                node.publish(topic, data)

            topic = msg.twist_topic("device0")

            node.subscribe(msg.feedback_topic("device0"), on_feedback)
            sample = Sample(0.0, 0, np.zeros(3), (1.0, 0.0, 0.0), 1)
            while not rtts:  # the link is up
                send()
                time.sleep(0.05)
            time.sleep(0.5)
            rtts.clear()
            for _ in range(n):
                arrived.clear()
                send()
                arrived.wait(1.0)
                time.sleep(0.02)
    finally:
        os.kill(child.pid, signal.SIGTERM if side == "node" else signal.SIGKILL)
        child.wait()
    label = {
        "node": "otgym node sim (ticks in its worker)",
        "sim": "same process, ticks back to back",
        "paced": "same process, ticks at 50 Hz",
        "idle": "an echo only, no simulation",
    }[side]
    print(
        f"bus round trip device -> sim -> feedback, {label}: {percentiles_ms(rtts)}; {n - len(rtts)} lost; "
        f"load average {os.getloadavg()[0]:.2f}",
        flush=True,
    )


def in_process_reference(n: int) -> None:
    from otgym.runtime.loop import DeviceBinding, InteractiveLoop
    from otgym.task.task import InteractiveTask
    from otgym.teleop.device import Device, DeviceCaps

    class Stylus(Device):
        caps = DeviceCaps("stylus", 3, 0.88, (160.0, 120.0, 70.0), 1000.0)

        def start(self):
            self.sequence = 0

        def stop(self):
            pass

        def read(self):
            self.sequence += 1
            return Sample(time.monotonic(), self.sequence, np.zeros(3), (1.0, 0.0, 0.0), 1)

    task = InteractiveTask()
    device = Stylus()
    loop = InteractiveLoop(task, [DeviceBinding(device, robots=(0,))], task.scenario(7), "shared")
    loop.start()
    for _ in range(5):
        loop.tick()
    path = []
    for _ in range(n):
        begin = time.perf_counter()
        device.read()
        device.set_force(np.zeros(3))
        path.append(time.perf_counter() - begin)
    ticks = [loop.tick().wall_s for _ in range(200)]
    print(
        f"in-process device path (read + set_force): {percentiles_ms(path)}; in-process tick: {percentiles_ms(ticks)}"
    )


def liveliness(kills: int) -> None:
    delays = []
    for _ in range(kills):
        endpoint = free_endpoint()
        gone = threading.Event()
        with Node("device", "watcher", connect=[endpoint]) as node:
            node.watch("sim", lambda name, alive: None if alive else gone.set())
            child = spawn(endpoint, "idle")
            time.sleep(1.0)
            os.kill(child.pid, signal.SIGKILL)
            killed_at = time.monotonic()
            gone.wait(5.0)
            delays.append(time.monotonic() - killed_at if gone.is_set() else float("inf"))
            child.wait()
    print(
        f"liveliness: a SIGKILLed node noticed after {', '.join(f'{d * 1e3:.1f}' for d in delays)} ms "
        f"(max {max(delays) * 1e3:.1f} ms)"
    )


def rates() -> None:
    sample = Sample(0.0, 0, np.zeros(3), (1.0, 0.0, 0.0), 1)
    cases = {
        "TwistStamped": (msg.twist_topic("d"), lambda: msg.twist(sample, 1.0, "d")),
        "Joy": (msg.buttons_topic("d"), lambda: msg.joy(1, 1.0, "d")),
        "WrenchStamped": (msg.feedback_topic("d"), lambda: msg.wrench((0.1, 0, 0), 1.0, "d")),
        "PoseArray, 4 traps": (msg.TRAPS, lambda: msg.pose_array(np.zeros((4, 2)), 1.0)),
        "PoseArray, 19 spheres": (msg.BODIES, lambda: msg.pose_array(np.zeros((19, 2)), 1.0)),
    }
    from otgym.bus import ros_graph
    from otgym.bus.intake import DDS_NAME, TYPE_HASH, Counts, Intake

    for name, (topic, make) in cases.items():
        data = make()
        n = 2000
        encode_s = timeit.timeit(make, number=n) / n
        decode_s = timeit.timeit(lambda: msg.decode(topic, data), number=n) / n
        type_name = msg.topic_type(topic)
        intake, sequence, gid = Intake(Counts()), iter(range(1, 10**9)), bytes(16)

        def receive():
            attachment = ros_graph.attachment(next(sequence), time.time_ns(), gid)  # the sender's part
            intake.check(topic, DDS_NAME[type_name], TYPE_HASH[type_name], attachment, data)

        receive_s = timeit.timeit(receive, number=n) / n
        print(
            f"{name}: {len(data)} B, encode {1 / encode_s:,.0f}/s, decode+check {1 / decode_s:,.0f}/s, "
            f"with rmw_zenoh's attachment and the intake checks {1 / receive_s:,.0f}/s "
            f"({(receive_s - decode_s) * 1e6:.1f} us more)"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--round-trips", type=int, default=1000)
    parser.add_argument("--kills", type=int, default=5)
    parser.add_argument("--sides", default="node,sim,paced", help="sim sides to measure the round trip against")
    args = parser.parse_args()
    print(f"machine: {os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f}")
    rates()
    liveliness(args.kills)
    for side in args.sides.split(","):
        round_trip(args.round_trips, side.strip())
    in_process_reference(args.round_trips)
    print(f"load average at the end {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
