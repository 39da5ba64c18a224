"""A recording read back: its summary (duration, messages per topic, trials) and
frames of the global view drawn from its messages.

Messages are decoded with the schema text stored in the file (mcap-ros2-support's
dynamic decoder), so any ROS 2 recording with these topics reads the same way. A
frame is drawn for every ``every``-th ``/otgym/bodies`` message: each sphere (its
centre from ``/otgym/bodies``, its radius from the latest ``trial_start`` event's
``sphere_radius_um``) as a grey disc, the traps (``/otgym/traps``, the latest at that
time) as red crosses, on a white field fitted to every body of the recording, 4 px per
um by default, with the trial, the time and alpha written in the corner.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from mcap_ros2._dynamic import generate_dynamic
from PIL import Image, ImageDraw

from otgym.record.mcap_file import Recording

TRAPS, BODIES, ALPHA, EVENTS = "/otgym/traps", "/otgym/bodies", "/otgym/shared/alpha", "/otgym/trial/events"


class Decoder:
    """Decodes recorded messages by their stored schema (one decoder per type)."""

    def __init__(self):
        self._decoders = {}

    def __call__(self, message):
        decoder = self._decoders.get(message.type_name)
        if decoder is None:
            decoder = generate_dynamic(message.type_name, message.schema_text)[message.type_name]
            self._decoders[message.type_name] = decoder
        return decoder(message.data)


def events(recording: Recording) -> list[dict]:
    """The trial events' JSON objects, in order."""
    decode = Decoder()
    return [json.loads(decode(m).data) for m in recording.topic(EVENTS)]


def summary(recording: Recording) -> dict:
    """duration_s (first to last log time), counts per topic, trials started and the
    ``ended_by`` of each finished trial, and whether the file is complete."""
    times = [m.log_time_ns for m in recording.messages]
    trial_events = events(recording)
    return {
        "duration_s": (max(times) - min(times)) * 1e-9 if times else 0.0,
        "messages": len(recording.messages),
        "counts": dict(sorted(recording.counts().items())),
        "trials": sum(e["event"] == "trial_start" for e in trial_events),
        "ended_by": [e.get("ended_by") for e in trial_events if e["event"] == "trial_end"],
        "complete": recording.complete,
    }


def _xy(message) -> np.ndarray:
    return np.array([(p.position.x, p.position.y) for p in message.poses], float).reshape(-1, 2)


def render_frames(recording: Recording, out_dir: Path, every: int = 25, px_per_um: float = 4.0) -> list[Path]:
    """PNG frames ``frame_00000.png``... of the global view into ``out_dir``."""
    if every < 1:
        raise ValueError(f"every must be a positive number of ticks, got {every}")
    decode = Decoder()
    bodies = [(m, decode(m)) for m in recording.topic(BODIES)]
    if not bodies:
        return []
    all_xy = np.concatenate([_xy(b) for _, b in bodies])
    radii: np.ndarray | None = None
    margin_um = 10.0
    low, high = all_xy.min(axis=0) - margin_um, all_xy.max(axis=0) + margin_um
    size = np.maximum(((high - low) * px_per_um).astype(int), 16)
    traps = alpha = None
    trial = 0
    written, index = [], 0
    for message in recording.messages:
        if message.topic == EVENTS:
            payload = json.loads(decode(message).data)
            if payload["event"] == "trial_start":
                trial = payload["trial"]
                radii = np.asarray(payload.get("sphere_radius_um", []), float)
        elif message.topic == TRAPS:
            traps = _xy(decode(message))
        elif message.topic == ALPHA:
            alpha = decode(message).data
        elif message.topic == BODIES:
            index += 1
            if (index - 1) % every:
                continue
            image = Image.new("RGB", tuple(int(s) for s in size), "white")
            draw = ImageDraw.Draw(image)
            spheres = _xy(decode(message))
            for i, (x, y) in enumerate((spheres - low) * px_per_um):
                r = (radii[i] if radii is not None and i < len(radii) else 1.0) * px_per_um
                draw.ellipse((x - r, y - r, x + r, y + r), fill=(170, 170, 170), outline=(60, 60, 60))
            for x, y in ((traps - low) * px_per_um if traps is not None else []):
                draw.line((x - 4, y, x + 4, y), fill=(220, 0, 0), width=2)
                draw.line((x, y - 4, x, y + 4), fill=(220, 0, 0), width=2)
            elapsed_s = (message.log_time_ns - recording.messages[0].log_time_ns) * 1e-9
            label = f"trial {trial}  t {elapsed_s:6.2f} s" + (f"  alpha {alpha:.2f}" if alpha is not None else "")
            draw.text((4, 4), label, fill=(0, 0, 0))
            path = Path(out_dir) / f"frame_{len(written):05d}.png"
            image.save(path)
            written.append(path)
    return written
