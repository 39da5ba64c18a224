"""A recording as an MP4 video of its global view (``otgym.record.frames``), encoded
in-process with PyAV (FFmpeg's libraries; its wheels carry libx264): H.264, 4:2:0,
constant frame rate.

Timing: the video runs at ``speed`` times simulated time, real time by default: frame
k shows the latest tick at or before simulated time ``k * speed / fps`` (counted in
ticks of ``tick_s`` over the whole recording, trial after trial), so at 25 fps and
50 Hz ticks every second tick is shown. Time between trials (questionnaires, pauses)
has no ticks and takes no video time.

The file is written under a temporary name beside its target and renamed when
complete: an interrupted encode leaves nothing half-written behind.
"""

from __future__ import annotations

import math
import os
from fractions import Fraction
from pathlib import Path

import av
import numpy as np

from otgym.record.frames import DEFAULT_WIDTH_PX, FrameRenderer
from otgym.record.mcap_file import Recording
from otgym.record.replay import tick_count, ticks

DEFAULT_FPS = 25.0
H264_ENCODERS = ("libx264", "libopenh264")
"""H.264 encoders in order of preference (PyAV's wheels carry libx264)."""
CRF = 23
"""libx264's constant-rate factor (its default quality)."""


def frame_ticks(n_ticks: int, tick_s: float, fps: float, speed: float = 1.0) -> np.ndarray:
    """The tick shown by each frame (see the module's docstring)."""
    if not (math.isfinite(fps) and 1 <= fps <= 240):
        raise ValueError(f"fps must lie in [1, 240], got {fps}")
    if not (math.isfinite(speed) and 0.01 <= speed <= 100):
        raise ValueError(f"speed must lie in [0.01, 100], got {speed}")
    ticks_per_frame = speed / (fps * tick_s)
    n_frames = math.ceil(n_ticks / ticks_per_frame - 1e-9)
    return np.minimum(np.floor(np.arange(n_frames) * ticks_per_frame + 1e-9).astype(int), n_ticks - 1)


def write_video(
    recording: Recording,
    path: Path,
    fps: float = DEFAULT_FPS,
    speed: float = 1.0,
    width_px: int = DEFAULT_WIDTH_PX,
    progress=None,
) -> dict:
    """Encode the recording into the MP4 ``path``; ``progress(done, total)`` after each
    frame. Returns frames, fps, width, height and the simulated seconds shown."""
    encoder = next((name for name in H264_ENCODERS if name in av.codecs_available), None)
    if encoder is None:
        raise ValueError(f"this PyAV build has no H.264 encoder ({' or '.join(H264_ENCODERS)})")
    renderer = FrameRenderer(recording, width_px=width_px)
    tick_s = renderer.scene.tick_s
    shown = frame_ticks(tick_count(recording), tick_s, fps, speed)
    if not len(shown):
        raise ValueError("the recording has no ticks (no /otgym/bodies messages) to make a video of")
    repeats = np.bincount(shown, minlength=shown[-1] + 1)
    path = Path(path)
    partial = path.with_name(f".{path.name}.part")
    done = 0
    try:
        with av.open(str(partial), mode="w", format="mp4") as container:
            rate = Fraction(fps).limit_denominator(1001)
            stream = container.add_stream(encoder, rate=rate)
            stream.time_base = 1 / rate
            stream.width, stream.height = renderer.width_px, renderer.height_px
            stream.pix_fmt = "yuv420p"
            stream.options = {"crf": str(CRF)} if encoder == "libx264" else {}
            for tick in ticks(recording, tick_s, lambda index: index < len(repeats) and repeats[index] > 0):
                image = av.VideoFrame.from_ndarray(renderer.draw(tick), format="rgb24")
                for _ in range(repeats[tick.index]):
                    image.pts = done  # in frames: the stream's time base is 1/fps
                    container.mux(stream.encode(image))
                    done += 1
                    if progress is not None:
                        progress(done, len(shown))
            container.mux(stream.encode(None))
        os.replace(partial, path)
    finally:
        partial.unlink(missing_ok=True)
    return {
        "frames": done,
        "fps": fps,
        "width": renderer.width_px,
        "height": renderer.height_px,
        "simulated_s": len(shown) * speed / fps,
    }
