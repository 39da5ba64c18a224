"""``otgym replay`` on a real session recording: reading it, drawing frames of the
global view, PNG frames, and the MP4, against the reference of real time (the
session's own simulated duration, which the video plays in).

The recording is ``--recording FILE``, or one made here first: ``otgym play
--headless --device simulated --duration 30`` (a simulated participant in shared mode,
1500 ticks at 50 Hz) into a temporary folder.

    python benchmarks/replay.py [--recording FILE] [--frames 100]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import av
import numpy as np
from PIL import Image

from otgym.record.frames import FrameRenderer
from otgym.record.mcap_file import read_recording
from otgym.record.replay import session_scene, tick_count, ticks
from otgym.record.video import write_video

ROOT = Path(__file__).resolve().parents[1]


def record_session(folder: Path, duration_s: float) -> Path:
    subprocess.run(
        [
            sys.executable,
            "-m",
            "otgym",
            "play",
            "--headless",
            "--device",
            "simulated",
            "--mode",
            "shared",
            "--duration",
            str(duration_s),
            "--no-questionnaire",
            "--out",
            str(folder),
        ],
        check=True,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        stdout=subprocess.DEVNULL,
    )
    return folder / "session.mcap"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--recording", type=Path, help="An MCAP recording (default: record a 30 s session).")
    parser.add_argument("--frames", type=int, default=100, help="Frames timed for drawing and PNG writing.")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as scratch:
        scratch = Path(scratch)
        path = args.recording or record_session(scratch, 30.0)
        started = time.perf_counter()
        recording = read_recording(path)
        read_s = time.perf_counter() - started
        started = time.perf_counter()
        scene = session_scene(recording)
        renderer = FrameRenderer(recording, scene)
        scene_s = time.perf_counter() - started
        n_ticks = tick_count(recording)
        simulated_s = n_ticks * scene.tick_s
        print(
            f"recording {path}: {path.stat().st_size / 1e6:.2f} MB, {len(recording.messages)} messages, "
            f"{n_ticks} ticks = {simulated_s:.1f} s simulated ({path.stat().st_size / 1e3 / simulated_s:.0f} kB "
            f"per simulated second); chip {scene.chip.name if scene.chip else None}"
        )
        print(f"read {read_s:.2f} s; scene (chip rebuilt, background drawn) {scene_s:.2f} s")
        step = max(n_ticks // args.frames, 1)
        draw_s, png_s = [], []
        for tick in ticks(recording, scene.tick_s, lambda index: index % step == 0):
            t0 = time.perf_counter()
            frame = renderer.draw(tick)
            t1 = time.perf_counter()
            Image.fromarray(frame).save(scratch / "frame.png")
            png_s.append(time.perf_counter() - t1)
            draw_s.append(t1 - t0)
        print(
            f"frame {renderer.width_px}x{renderer.height_px}: draw {1e3 * np.median(draw_s):.1f} ms, PNG write "
            f"{1e3 * np.median(png_s):.1f} ms (medians of {len(draw_s)}), PNG "
            f"{(scratch / 'frame.png').stat().st_size / 1e3:.0f} kB"
        )
        started = time.perf_counter()
        made = write_video(recording, scratch / "session.mp4", fps=25.0)
        encode_s = time.perf_counter() - started
        with av.open(str(scratch / "session.mp4")) as container:
            decoded = sum(1 for _ in container.decode(video=0))
        size_mb = (scratch / "session.mp4").stat().st_size / 1e6
        print(
            f"video: {made['frames']} frames ({decoded} decoded) at 25 fps, {made['width']}x{made['height']}, "
            f"{size_mb:.2f} MB; encoded in {encode_s:.1f} s = {1e3 * encode_s / made['frames']:.1f} ms a frame, "
            f"{simulated_s / encode_s:.1f}x real time (reference: the {simulated_s:.1f} s it plays)"
        )


if __name__ == "__main__":
    main()
