"""Frames per second of the ``otgym play`` window while the simulation runs in real time.

One session of the interactive task in shared mode, one simulated haptic stylus on
robot 0 (its 1 kHz servo process beside), the window drawing every view and cue.
Three runs of ``--seconds`` wall seconds each, in this order:

* reference: the simulation alone (its tick thread, no window, nothing drawn);
* frame: the window's frame loop runs the ticks that are due, then draws (a
  fixed-step accumulator, one thread);
* thread: the simulation ticks in its own thread while the frame loop only draws
  (what ``otgym play`` does).

For each: frames per second p50 and p5 (from frame times), frame time p99, and the
real-time factor (simulated seconds over wall seconds; 1.00 keeps real time) with the
schedule restarts (a tick more than a period late). Warm-up (compiles) is not timed.
Headless unless a display is set (``DISPLAY=:99`` with ``Xvfb :99 &`` for a real X
server).

    python benchmarks/ui_fps.py [--seconds 10] [--headless]
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np


def frame_stats(frame_times_s) -> str:
    times = np.asarray(frame_times_s)
    fps = 1.0 / times
    return (f"fps p50 {np.percentile(fps, 50):5.1f}  p5 {np.percentile(fps, 5):5.1f}  "
            f"frame p99 {np.percentile(times, 99) * 1e3:5.1f} ms")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=10.0, help="wall seconds per run")
    parser.add_argument("--headless", action="store_true", help="SDL dummy video driver even with a display")
    args = parser.parse_args()
    if args.headless or not os.environ.get("DISPLAY"):
        os.environ["SDL_VIDEODRIVER"] = "dummy"
        os.environ["SDL_AUDIODRIVER"] = "dummy"
    import pygame

    from otgym.runtime.task import InteractiveTask
    from otgym.runtime.trials import TASK_RETARGET, task_feedback
    from otgym.teleop.device import open_device
    from otgym.ui.app import PlayApp
    from otgym.ui.bindings import play_bindings
    from otgym.ui.simulation import Simulation

    pygame.display.init()
    pygame.font.init()
    print(f"video driver: {pygame.display.get_driver()}; "
          f"load average {os.getloadavg()[0]:.2f}", flush=True)
    task = InteractiveTask()
    feedback = task_feedback(task.config.scene.trap_law, TASK_RETARGET, 2)
    bindings = play_bindings([open_device("simulated"), None], keyboard=False, feedback=feedback)
    simulation = Simulation(task, bindings, "bench", "shared", seed=0)
    simulation.start()
    try:
        def measure(label, draw: bool, threaded: bool):
            simulation.reset()
            simulation.advance()
            late_before, sim_before = simulation.late_ticks, simulation.loop.time_s
            frames = []
            if draw:
                app = PlayApp(simulation, "/tmp", questionnaire=False, threaded=threaded)
                for _ in range(30):  # warm-up: fonts, first local views
                    app.draw()
                    pygame.display.flip()
                simulation.reset()
                simulation.advance()
                late_before, sim_before = simulation.late_ticks, simulation.loop.time_s
            if threaded:
                simulation.start_thread()
            begin = last = time.perf_counter()
            while time.perf_counter() - begin < args.seconds:
                if draw:
                    app.frame()
                    app.clock.tick(60)
                    now = time.perf_counter()
                    frames.append(now - last)
                    last = now
                else:
                    time.sleep(0.05)
            wall = time.perf_counter() - begin
            simulation.stop_thread()
            rtf = (simulation.loop.time_s - sim_before) / wall
            stats = frame_stats(frames) if frames else "no frames drawn" + " " * 33
            print(f"{label:<42} {stats}  RTF {rtf:.3f}  restarts {simulation.late_ticks - late_before}", flush=True)

        measure("reference: simulation alone (thread)", draw=False, threaded=True)
        measure("frame: ticks in the frame loop", draw=True, threaded=False)
        measure("thread: ticks in their own thread", draw=True, threaded=True)
    finally:
        simulation.close()
        pygame.quit()
    print(f"load average at the end {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
