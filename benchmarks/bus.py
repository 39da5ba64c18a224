"""The bus on loopback (``otgym.bus``): round trip device -> sim -> feedback while the
simulation runs, liveliness (how soon a killed node is noticed), and message rates,
against the in-process runtime measured in the same run.

* Round trip: this process is a device node (a ``Node`` of role device); a child
  process is the sim side: a ``Node`` listening on loopback that answers every twist it
  receives, in its subscriber callback, with a feedback wrench, while its main thread
  ticks ``InteractiveLoop`` back to back (the interactive task, shared mode, one
  environment: the simulation running and loading the CPU). Each twist carries its
  send time in its header stamp; the wrench echoes it, so the round trip is this
  process's receive time minus that stamp: encode, zenoh publish, TCP over loopback,
  receive, decode and check, encode, publish, back, decode and check. 50 Hz, as a
  device node sends. Reference in the same run: the in-process runtime's device path
  (``Device.read`` and ``Device.set_force`` around one tick; no bus).
* Liveliness: a light child node (no simulation) is started and SIGKILLed ``--kills``
  times; the time from the kill to this process's liveliness DELETE.
* Rates: encoding, and decoding with the checks, per message type in this process;
  and the messages per tick the simulator publishes.

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
load = sys.argv[2] == "sim"
with Node("sim", "sim", listen=[sys.argv[1]]) as node:
    def echo(topic, message, data):
        node.publish(m.feedback_topic("device0"), m.wrench((0.1, 0.0, 0.0), m.stamp_s(message), "device0"))
    node.subscribe(m.twist_topic("device0"), echo)
    if load:
        from otgym.runtime.loop import InteractiveLoop
        from otgym.runtime.task import InteractiveTask
        task = InteractiveTask()
        loop = InteractiveLoop(task, [], task.scenario(7), "shared")
        for _ in range(5):
            loop.tick()
    print("ready", flush=True)
    while True:
        if load:
            loop.tick()
        else:
            time.sleep(0.1)
"""


def free_endpoint() -> str:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return f"tcp/127.0.0.1:{probe.getsockname()[1]}"


def spawn(endpoint: str, load: str) -> subprocess.Popen:
    child = subprocess.Popen([sys.executable, "-c", SIM_SIDE, endpoint, load], stdout=subprocess.PIPE, text=True,
                             env={**os.environ, "PYTHONPATH": str(ROOT)})
    while not child.stdout.readline().startswith("ready"):
        if child.poll() is not None:
            raise RuntimeError("the sim side died")
    return child


def percentiles_ms(values_s) -> str:
    values = np.asarray(values_s) * 1e3
    return f"p50 {np.percentile(values, 50):.3f} ms, p99 {np.percentile(values, 99):.3f} ms (n={len(values)})"


def round_trip(n: int) -> None:
    endpoint = free_endpoint()
    child = spawn(endpoint, "sim")
    rtts, arrived = [], threading.Event()
    try:
        with Node("device", "device0", connect=[endpoint]) as node:
            def on_feedback(topic, message, data):
                rtts.append(time.time() - msg.stamp_s(message))
                arrived.set()

            node.subscribe(msg.feedback_topic("device0"), on_feedback)
            sample = Sample(0.0, 0, np.zeros(3), (1.0, 0.0, 0.0), 1)
            while not rtts:  # the link is up
                node.publish(msg.twist_topic("device0"), msg.twist(sample, time.time(), "device0"))
                time.sleep(0.05)
            time.sleep(0.5)
            rtts.clear()
            for _ in range(n):
                arrived.clear()
                node.publish(msg.twist_topic("device0"), msg.twist(sample, time.time(), "device0"))
                arrived.wait(1.0)
                time.sleep(0.02)
    finally:
        os.kill(child.pid, signal.SIGKILL)
        child.wait()
    print(f"bus round trip device -> sim -> feedback, simulation running: {percentiles_ms(rtts)}; "
          f"{n - len(rtts)} lost")


def in_process_reference(n: int) -> None:
    from otgym.runtime.loop import DeviceBinding, InteractiveLoop
    from otgym.runtime.task import InteractiveTask
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
    print(f"in-process device path (read + set_force): {percentiles_ms(path)}; "
          f"in-process tick: {percentiles_ms(ticks)}")


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
    print(f"liveliness: a SIGKILLed node noticed after {', '.join(f'{d * 1e3:.1f}' for d in delays)} ms "
          f"(max {max(delays) * 1e3:.1f} ms)")


def rates() -> None:
    sample = Sample(0.0, 0, np.zeros(3), (1.0, 0.0, 0.0), 1)
    cases = {
        "TwistStamped": (msg.twist_topic("d"), lambda: msg.twist(sample, 1.0, "d")),
        "Joy": (msg.buttons_topic("d"), lambda: msg.joy(1, 1.0, "d")),
        "WrenchStamped": (msg.feedback_topic("d"), lambda: msg.wrench((0.1, 0, 0), 1.0, "d")),
        "PoseArray, 4 traps": (msg.TRAPS, lambda: msg.pose_array(np.zeros((4, 2)), 1.0)),
        "PoseArray, 19 spheres": (msg.BODIES, lambda: msg.pose_array(np.zeros((19, 2)), 1.0)),
    }
    for name, (topic, make) in cases.items():
        data = make()
        n = 2000
        encode_s = timeit.timeit(make, number=n) / n
        decode_s = timeit.timeit(lambda: msg.decode(topic, data), number=n) / n
        print(f"{name}: {len(data)} B, encode {1 / encode_s:,.0f}/s, decode+check {1 / decode_s:,.0f}/s")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--round-trips", type=int, default=1000)
    parser.add_argument("--kills", type=int, default=5)
    args = parser.parse_args()
    print(f"machine: {os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f}")
    rates()
    liveliness(args.kills)
    round_trip(args.round_trips)
    in_process_reference(args.round_trips)


if __name__ == "__main__":
    main()
