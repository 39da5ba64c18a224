"""Frames per second of the ``otgym play`` window while the simulation runs in real time.

One session of the interactive task in shared mode, a simulated haptic stylus on robot
0 (its 1 kHz servo process beside), the session recorded to MCAP as ``otgym play``
does, the window drawing every view and cue (1280 x 720). Runs of ``--seconds`` wall
seconds each, in this order:

* reference: the session alone in its own process (``otgym.runtime.worker``), no
  window: the real-time factor the machine allows;
* thread: the earlier design: the session ticks in a thread of the window's process,
  the window presents the whole frame every frame;
* process, whole frames: the session in its own process (what ``otgym play`` does),
  the window presents the whole frame every frame;
* process: what ``otgym play`` does: its own process, the window presents only the
  rectangles that changed.

For each: frames per second p50 and p5 (from frame times), the frames drawn in the
slowest whole second of the run (what "60 sustained" asks), frame time p99, the frames
that showed a new simulation state per second, the real-time factor (simulated seconds
over wall seconds while the window ran; 1.00 keeps real time), the schedule restarts
(a tick more than a period late), and the CPU seconds per wall second of the window's
process and of the session's (one core is 1.0). Warm-up (compiles, fonts) is not
timed. Headless unless a display is set (``DISPLAY=:99`` with ``Xvfb :99 &`` for a
real X server). The load average is printed before and after: the machine is shared.

    python benchmarks/ui_fps.py [--seconds 10] [--headless] [--runs reference,thread,process-flip,process]
"""

from __future__ import annotations

import argparse
import functools
import os
import tempfile
import time
from pathlib import Path

import numpy as np

RUNS = ("reference", "thread", "process-flip", "process")


def frame_stats(frame_times_s) -> str:
    times = np.asarray(frame_times_s)
    fps = 1.0 / times
    ends_s = np.cumsum(times)
    per_second = np.bincount(ends_s[ends_s < np.floor(ends_s[-1])].astype(int))  # frames in each whole second
    return (
        f"fps p50 {np.percentile(fps, 50):5.1f}  p5 {np.percentile(fps, 5):5.1f}  "
        f"frames in the slowest whole second {per_second.min()} of {len(per_second)} s  "
        f"frame p99 {np.percentile(times, 99) * 1e3:5.1f} ms"
    )


def process_cpu_s(pid: int) -> float:
    """User + system CPU seconds of a process so far (Linux /proc)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def load() -> str:
    return "load average " + " ".join(f"{x:.2f}" for x in os.getloadavg())


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=10.0, help="wall seconds per run")
    parser.add_argument("--headless", action="store_true", help="SDL dummy video driver even with a display")
    parser.add_argument("--runs", default=",".join(RUNS), help=f"comma-separated, of {', '.join(RUNS)}")
    args = parser.parse_args()
    runs = [r.strip() for r in args.runs.split(",")]
    if any(r not in RUNS for r in runs):
        parser.error(f"--runs takes {', '.join(RUNS)}")
    if args.headless or not os.environ.get("DISPLAY"):
        os.environ["SDL_VIDEODRIVER"] = "dummy"
        os.environ["SDL_AUDIODRIVER"] = "dummy"
    import pygame

    from otgym.runtime.session import Session
    from otgym.runtime.worker import SessionProcess, WorkerSpec
    from otgym.ui.app import PlayApp
    from otgym.ui.palette import WINDOW_SIZE
    from otgym.ui.play_worker import play_setup

    pygame.display.init()
    pygame.font.init()
    screen = pygame.display.set_mode(WINDOW_SIZE)
    print(f"video driver: {pygame.display.get_driver()}; {os.cpu_count()} CPUs; {load()}", flush=True)
    folder = Path(tempfile.mkdtemp(prefix="ui_fps_"))

    def setup(name: str):
        return functools.partial(play_setup, "default", "simulated", folder / f"{name}.mcap")

    def window_frames(app, sim_time_s, worker_pid: int | None) -> tuple[list[float], float, float, float, float]:
        for _ in range(30):  # warm-up: fonts, first local views
            app.frame()
            app.clock.tick(60)
        fresh_before = app.frames_with_new_state
        frames = []
        sim_before = sim_time_s()
        cpu_before = time.process_time()
        worker_before = process_cpu_s(worker_pid) if worker_pid else 0.0
        begin = last = time.perf_counter()
        while time.perf_counter() - begin < args.seconds:
            app.frame()
            app.clock.tick(60)
            now = time.perf_counter()
            frames.append(now - last)
            last = now
        wall = time.perf_counter() - begin
        worker_cpu = (process_cpu_s(worker_pid) - worker_before) / wall if worker_pid else float("nan")
        return (
            frames,
            (sim_time_s() - sim_before) / wall,
            (app.frames_with_new_state - fresh_before) / wall,
            (time.process_time() - cpu_before) / wall,
            worker_cpu,
        )

    def report(label, frames, rtf, fresh_per_s, window_cpu, worker_cpu, restarts):
        stats = frame_stats(frames) if frames else "no window" + " " * 44
        print(
            f"{label:<30} {stats}  new states {fresh_per_s:4.1f}/s  RTF {rtf:.3f}  restarts {restarts}  "
            f"CPU window {window_cpu:.2f} session {worker_cpu:.2f}  ({load()})",
            flush=True,
        )

    for run in runs:
        if run == "thread":
            parts = setup(run)([], None)
            session = Session(parts.task, parts.bindings, "bench", "shared", seed=0, sink=parts.sink)
            session.start()
            try:
                app = PlayApp(session, folder, questionnaire=False, screen=screen, dirty_rects=False)
                session.start_thread()
                late_before = session.late_ticks
                frames, rtf, fresh, window_cpu, _ = window_frames(app, lambda: session.loop.time_s, None)
                report(
                    "thread, whole frames",
                    frames,
                    rtf,
                    fresh,
                    window_cpu,
                    float("nan"),
                    session.late_ticks - late_before,
                )
            finally:
                session.close()
            continue
        session = SessionProcess(WorkerSpec(setup(run), "bench", "shared", seed=0))
        session.start()
        try:
            pid = session.process.pid
            if run == "reference":
                while session.snapshot is None:
                    time.sleep(0.01)
                sim_before, cpu_before = session.snapshot.time_s, process_cpu_s(pid)
                begin = time.perf_counter()
                time.sleep(args.seconds)
                wall = time.perf_counter() - begin
                rtf = (session.snapshot.time_s - sim_before) / wall
                worker_cpu = (process_cpu_s(pid) - cpu_before) / wall
                stats = session.finish()
                report("reference: session alone", [], rtf, 0.0, float("nan"), worker_cpu, stats["late_ticks"])
                continue
            app = PlayApp(session, folder, questionnaire=False, screen=screen, dirty_rects=run == "process")
            frames, rtf, fresh, window_cpu, worker_cpu = window_frames(app, lambda: session.snapshot.time_s, pid)
            stats = session.finish()
            label = "process, changed rectangles" if run == "process" else "process, whole frames"
            report(label, frames, rtf, fresh, window_cpu, worker_cpu, stats["late_ticks"])
        finally:
            session.finish()
    pygame.quit()


if __name__ == "__main__":
    main()
