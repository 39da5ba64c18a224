"""Interactive tick and haptic servo loop: does one environment keep up with a person?

* Tick: the real-time loop of ``otgym.runtime.loop`` on the interactive task (shared
  mode, 50 Hz ticks of 20 ms), one simulated haptic stylus driving both robots as a
  formation: device read, retargeting, the route navigator, arbitration, physics (80
  steps of 0.25 ms), four 48 x 48 px microscope crops at 0.1 um around the traps (the
  chip as background), the vision force sensor, the feedback law and the force sent
  back. Ticks run back to back; the real-time factor is simulated seconds per wall
  second (goal >= 10). Latency p50/p99 per stage. Reference in the same run: the
  physics alone (``InteractiveTask.step``, one environment, zero increments).
* Pacing: the same loop paced at real time (``run(realtime=True)``): simulated over
  wall time and schedule restarts.
* Servo: the stylus's 1 kHz servo loop runs in its own process
  (``otgym.teleop.servo.ServoDevice`` around ``SimulatedHapticBackend``); its measured
  loop periods (p50/p99; goal p99 <= 1.5 ms) while the simulation runs in this
  process, against the reference of the same process with the simulation idle (this
  process asleep), measured first in the same run.

* Compile: the microscope's and the sensor's numba kernels (``cache=True``) compiled
  from nothing, in CPU seconds, in a fresh interpreter with an empty temporary numba
  cache (the machine's cache is left alone), and then loaded from that cache by a
  second fresh interpreter: what a new installation pays once, and every later start.

Warm-up before timing: the task's step and the loop's jitted helpers compile on the
first ticks, which are not timed.

    python benchmarks/interactive.py [--ticks 1000] [--idle-s 5] [--paced-s 5] [--quick] [--no-compile]
"""

from __future__ import annotations

import argparse
import functools
import json
import os
import subprocess
import sys
import tempfile
import time

import jax
import numpy as np

from otgym.runtime.loop import DeviceBinding, InteractiveLoop
from otgym.task.task import InteractiveTask
from otgym.teleop.servo import SIMULATED_HAPTIC_CAPS, ServoDevice, SimulatedHapticBackend, SteadyHand

WARM_UP_TICKS = 25
SCENARIO_SEED = 7
HAND_VELOCITY_MM_S = (1.0, 0.0, 0.0)
"""A slow, steady hand (2 um/s at the trap), so retargeting passes motion."""
PERIOD_CAPACITY = 1 << 17
"""Servo periods kept (131 s at 1 kHz): the whole run, so each phase is a slice."""


def percentiles_ms(values_s):
    values = np.asarray(values_s) * 1e3
    return float(np.percentile(values, 50)), float(np.percentile(values, 99))


def servo_phase(device: ServoDevice, run):
    """Servo loop periods (s) recorded while ``run()`` runs, and what it returns."""
    before = len(device.loop_periods_s())
    result = run()
    return device.loop_periods_s()[before:], result


def physics_reference(task: InteractiveTask, scenario, ticks: int) -> float:
    """Wall seconds per ``InteractiveTask.step`` of one environment (zero increments)."""
    state = task.reset([scenario], jax.random.PRNGKey(1))
    zeros = np.zeros((1, task.n_traps, 2))
    keys = np.asarray(jax.random.split(jax.random.PRNGKey(2), ticks + WARM_UP_TICKS))
    for key in keys[:WARM_UP_TICKS]:
        task.step(state, zeros, key)
    begin = time.perf_counter()
    for key in keys[WARM_UP_TICKS:]:
        task.step(state, zeros, key)
    return (time.perf_counter() - begin) / ticks


KERNELS_FIRST_CALLS = """
import json, time
import numpy as np
begin = time.process_time()
from otgym.sim.microscope import microscope_images
from otgym.sim.sensor import VisionForceSensor
imported = time.process_time()
images = microscope_images(np.zeros((1, 1, 2)), np.ones(1), np.zeros((1, 2)), (8, 8))
rendered = time.process_time()
VisionForceSensor().measure(images, np.zeros((1, 2)), 0.1, np.zeros((1, 1, 2)))
print(json.dumps({"microscope": rendered - imported, "sensor": time.process_time() - rendered}))
"""


def kernel_first_calls_cpu_s() -> tuple[dict, dict]:
    """CPU seconds of the first microscope and sensor calls in a fresh interpreter with
    an empty numba cache (compiling), then in another with that cache (loading). The
    first of them also pays numba's own start-up (about 0.2 s)."""
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "NUMBA_CACHE_DIR": cache}
        runs = [
            subprocess.run(
                [sys.executable, "-c", KERNELS_FIRST_CALLS], env=env, capture_output=True, text=True, check=True
            )
            for _ in range(2)
        ]
    return tuple(json.loads(run.stdout) for run in runs)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ticks", type=int, default=1000, help="ticks timed back to back")
    parser.add_argument("--idle-s", type=float, default=5.0, help="servo reference with the simulation idle")
    parser.add_argument("--paced-s", type=float, default=5.0, help="simulated seconds of the paced run")
    parser.add_argument("--quick", action="store_true", help="300 ticks, 2 s idle, 2 s paced")
    parser.add_argument("--no-compile", action="store_true", help="skip timing the numba kernels' compilation")
    parser.add_argument(
        "--normal-priority",
        action="store_true",
        help="run the servo loop at normal priority (default: it asks for SCHED_FIFO 50)",
    )
    args = parser.parse_args()
    if args.quick:
        args.ticks, args.idle_s, args.paced_s = 300, 2.0, 2.0
    print(
        f"device: {jax.devices()[0].device_kind} ({jax.default_backend()}); {os.cpu_count()} CPU cores, "
        f"load average {os.getloadavg()[0]:.2f} at start (other jobs included)"
    )
    task = InteractiveTask()
    scenario = task.scenario(SCENARIO_SEED)
    tick_s = task.config.tick_s
    hand = SteadyHand(velocity_mm_s=HAND_VELOCITY_MM_S)
    stylus = ServoDevice(
        functools.partial(SimulatedHapticBackend, hand=hand),
        SIMULATED_HAPTIC_CAPS,
        period_capacity=PERIOD_CAPACITY,
        realtime_priority=None if args.normal_priority else 50,
    )
    loop = InteractiveLoop(task, [DeviceBinding(stylus, (0, 1))], scenario, "shared", seed=0)
    with loop:
        scheduling = (
            "SCHED_FIFO 50"
            if stylus.realtime
            else "normal (" + ("asked" if args.normal_priority else "SCHED_FIFO refused") + ")"
        )
        loop.run(WARM_UP_TICKS * tick_s, realtime=False)
        idle_periods, _ = servo_phase(stylus, lambda: time.sleep(args.idle_s))
        begin = time.perf_counter()
        busy_periods, records = servo_phase(stylus, lambda: loop.run(args.ticks * tick_s, realtime=False))
        busy_wall_s = time.perf_counter() - begin
        begin = time.perf_counter()
        late_before = loop.late_ticks
        paced_periods, paced = servo_phase(stylus, lambda: loop.run(args.paced_s, realtime=True))
        paced_wall_s = time.perf_counter() - begin
        late = loop.late_ticks - late_before
    physics_s = physics_reference(task, scenario, args.ticks)

    print(
        f"interactive tick: one environment, shared mode, {tick_s * 1e3:.0f} ms ticks, one simulated stylus "
        f"(own process) driving both robots, {loop.task.n_traps} crops of {loop.crop_px}x{loop.crop_px} px at "
        f"{loop.microscope.pixel_size_um} um"
    )
    print(
        f"  ticks timed back to back: {len(records)} ({len(records) * tick_s:.1f} s simulated) "
        f"in {busy_wall_s:.2f} s wall"
    )
    factor = len(records) * tick_s / busy_wall_s
    physics_factor = tick_s / physics_s
    print(f"  real-time factor: {factor:.2f}x (goal >= 10x: {'met' if factor >= 10 else 'not met'})")
    print(
        f"  reference, physics alone (InteractiveTask.step): {physics_factor:.1f}x real time, "
        f"{physics_s * 1e3:.2f} ms per tick; full tick / physics alone = {physics_factor / factor:.1f}x the time"
    )
    print(f"  {'stage':<8} {'p50 (ms)':>9} {'p99 (ms)':>9} {'share of mean':>14}")
    stages = {
        name: np.array([getattr(r, f"{name}_s") for r in records]) for name in ("physics", "render", "sense", "rest")
    }
    total = sum(stages.values())
    for name, values in list(stages.items()) + [("total", total)]:
        p50, p99 = percentiles_ms(values)
        print(f"  {name:<8} {p50:>9.2f} {p99:>9.2f} {values.mean() / total.mean():>13.0%}")
    print(
        f"  paced at real time for {args.paced_s:g} s simulated: {len(paced)} ticks in {paced_wall_s:.2f} s wall "
        f"(simulated / wall = {len(paced) * tick_s / paced_wall_s:.3f}), schedule restarts {late}"
    )

    print(
        f"servo loop of the simulated stylus in its own process, target {SIMULATED_HAPTIC_CAPS.rate_hz:g} Hz, "
        f"scheduling {scheduling}"
    )
    print(f"  {'phase':<42} {'periods':>8} {'p50 (ms)':>9} {'p99 (ms)':>9} {'max (ms)':>9} {'p99 ratio':>10}")
    idle_p99 = percentiles_ms(idle_periods)[1]
    for name, periods in (
        ("reference: simulation idle", idle_periods),
        ("simulation running back to back", busy_periods),
        ("simulation paced at real time", paced_periods),
    ):
        p50, p99 = percentiles_ms(periods)
        print(
            f"  {name:<42} {len(periods):>8} {p50:>9.3f} {p99:>9.3f} {periods.max() * 1e3:>9.2f} "
            f"{p99 / idle_p99:>9.2f}x"
        )
    worst = max(percentiles_ms(busy_periods)[1], percentiles_ms(paced_periods)[1])
    print(
        f"  goal p99 <= 1.5 ms with the simulation running: {'met' if worst <= 1.5 else 'not met'} "
        f"(worst p99 {worst:.3f} ms)"
    )
    if not args.no_compile:
        cold, cached = kernel_first_calls_cpu_s()
        print(
            f"numba kernels, first call in a fresh interpreter (CPU s): compiled from nothing: microscope "
            f"{cold['microscope']:.2f}, sensor {cold['sensor']:.2f}; loaded from the cache: microscope "
            f"{cached['microscope']:.3f}, sensor {cached['sensor']:.3f}"
        )
    print(f"load average {os.getloadavg()[0]:.2f} at the end")


if __name__ == "__main__":
    main()
