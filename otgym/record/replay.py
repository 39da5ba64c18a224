"""A recording read back: its summary (duration, messages per topic, trials), the
scene it shows (``SessionScene``: chip, route, what each sphere is) and its ticks
(``ticks``: the state after each tick, for frames and video, ``otgym.record.frames``).

Messages are decoded with the schema text stored in the file (read by rosbags into a
type store of its own), so any ROS 2 recording with these topics reads the same way.

The scene comes from the latched messages a session starts with (``otgym.bus.messages``:
``/otgym/session``, ``/otgym/chip``, ``/otgym/route``). The chip is rebuilt from its
recorded PNG and sidecar fields and checked against the recorded content hash; a
recording that names a shipped chip but lacks its image falls back to the shipped chip
when the hashes agree. A recording made before chips were recorded has none of these
messages: its scene has no chip, no route and unknown sphere kinds, and ``chip_note``
says so in one line.

A tick is one ``/otgym/bodies`` message (every sphere's centre) with the latest traps,
alpha and mode before it, the trial of the latest ``trial_start`` event (which also
gives the spheres' radii) and the time in the trial: ticks since that event times the
tick (``tick_s`` of the description; else the median interval between bodies messages).
"""

from __future__ import annotations

import dataclasses
import io
import json
from collections.abc import Callable, Iterator

import numpy as np
from PIL import Image, UnidentifiedImageError
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from otgym.record.mcap_file import RecordedMessage, Recording

TRAPS, BODIES, ALPHA, MODE, EVENTS = (
    "/otgym/traps",
    "/otgym/bodies",
    "/otgym/shared/alpha",
    "/otgym/mode",
    "/otgym/trial/events",
)
SESSION, CHIP, ROUTE = "/otgym/session", "/otgym/chip", "/otgym/route"
DEFAULT_TICK_S = 0.02
"""The interactive task's tick, for a recording with a single tick to measure."""


class Decoder:
    """Decodes recorded messages by the schema stored with them (``ros2msg`` text, read
    by rosbags into a type store of its own, once per type)."""

    def __init__(self):
        self._stores = {}

    def __call__(self, message: RecordedMessage):
        store = self._stores.get(message.type_name)
        if store is None:
            store = get_typestore(Stores.EMPTY)
            store.register(get_types_from_msg(message.schema_text, message.type_name))
            self._stores[message.type_name] = store
        return store.deserialize_cdr(message.data, message.type_name)


def events(recording: Recording) -> list[dict]:
    """The trial events' JSON objects, in order."""
    decode = Decoder()
    return [json.loads(decode(m).data) for m in recording.topic(EVENTS)]


def task_episodes(trial_events: list[dict]) -> dict | None:
    """For a recording of ``otgym play --task`` (its ``task`` event,
    ``otgym.ui.task_recording``): the task, preset and seed; episodes finished, by how
    they ended; successes; the mean time to success (s); and the mean of each of the
    task's own metrics over the episodes that ended on their own (terminated or
    truncated). None for other recordings."""
    described = next((e for e in trial_events if e["event"] == "task"), None)
    if described is None:
        return None
    ends = [e for e in trial_events if e["event"] == "trial_end"]
    own = [e for e in ends if e.get("ended_by") in ("terminated", "truncated")]
    times = [float(e["time_s"]) for e in ends if e.get("success")]
    names = sorted({name for e in own for name in e.get("metrics", {})})
    metrics = {}
    for name in names:
        values = [float(e["metrics"][name]) for e in own if name in e.get("metrics", {})]
        metrics[name] = float(np.mean(values))
    ended_by: dict[str, int] = {}
    for e in ends:
        ended_by[str(e.get("ended_by"))] = ended_by.get(str(e.get("ended_by")), 0) + 1
    return {
        "task": described.get("task"),
        "preset": described.get("preset"),
        "seed": described.get("seed"),
        "episodes": len(ends),
        "ended_by": ended_by,
        "successes": sum(bool(e.get("success")) for e in ends),
        "mean_time_to_success_s": float(np.mean(times)) if times else None,
        "metrics": metrics,
        "metrics_over": len(own),
    }


def summary(recording: Recording) -> dict:
    """duration_s (first to last log time), counts per topic, trials started and the
    ``ended_by`` of each finished trial, whether the file is complete, and for a
    recording of ``otgym play --task`` its ``task_episodes`` (else None)."""
    times = [m.log_time_ns for m in recording.messages]
    trial_events = events(recording)
    return {
        "task": task_episodes(trial_events),
        "duration_s": (max(times) - min(times)) * 1e-9 if times else 0.0,
        "messages": len(recording.messages),
        "counts": dict(sorted(recording.counts().items())),
        "trials": sum(e["event"] == "trial_start" for e in trial_events),
        "ended_by": [e.get("ended_by") for e in trial_events if e["event"] == "trial_end"],
        "complete": recording.complete,
    }


def xy_um(poses) -> np.ndarray:
    """(N, 2) positions in um of a list of poses."""
    return np.array([(p.position.x, p.position.y) for p in poses], float).reshape(-1, 2)


@dataclasses.dataclass(frozen=True)
class SessionScene:
    """What a recording says about its scene. ``chip`` None: not recorded (or not
    rebuilt: ``chip_note`` says why); ``route_um`` (M, 2) or None; ``sphere_kind`` one
    ``BodyKind`` value per sphere, -1 where unknown; ``tick_s`` the simulation's tick."""

    chip: object | None  # otgym.sim.chip.Chip
    chip_note: str | None
    route_um: np.ndarray | None
    goal_tolerance_um: float | None
    sphere_kind: np.ndarray
    handle_spheres: np.ndarray
    tick_s: float


_KIND_VALUES = {"robot": 0, "cell": 1, "obstacle": 2, "bead": 3}  # otgym.physics.bodies.BodyKind


def _first(recording: Recording, topic: str) -> RecordedMessage | None:
    found = recording.topic(topic)
    return found[0] if found else None


def _measured_tick_s(recording: Recording) -> float:
    times = np.array([m.log_time_ns for m in recording.topic(BODIES)], float) * 1e-9
    steps = np.diff(times)
    steps = steps[steps > 0]
    return float(np.median(steps)) if len(steps) else DEFAULT_TICK_S


def _rebuild_chip(description: dict, png_message, decode: Decoder):
    """(chip, note): the chip from its recorded image and sidecar fields, else the
    shipped chip of that name with the recorded content hash, else None and why."""
    from otgym.sim.chip import CHIP_DATA_DIR, Chip, Port, load_chip

    fields = description["chip"]
    name, recorded_hash = fields["name"], fields["content_hash"]
    if png_message is not None:
        try:
            with Image.open(io.BytesIO(bytes(decode(png_message).data))) as picture:
                image = np.asarray(picture.convert("L"), np.float32) / 255.0
            chip = Chip(
                name,
                image,
                fields["pixel_size_um"],
                fields["channel_height_um"],
                tuple(Port(**port) for port in fields.get("ports", ())),
            )
        except (UnidentifiedImageError, OSError, TypeError, ValueError) as error:
            return None, f"the recorded image of chip {name!r} does not load ({error})"
        if chip.content_hash != recorded_hash:
            return chip, (
                f"the recorded image of chip {name!r} differs from the simulated chip (content hash "
                f"{chip.content_hash[:12]} is not {recorded_hash[:12]}: an image not in 8-bit gray?)"
            )
        return chip, None
    if (CHIP_DATA_DIR / f"{name}.png").is_file():
        shipped = load_chip(name)
        if shipped.content_hash == recorded_hash:
            return shipped, None
        return None, f"chip {name!r}'s image is not recorded and the shipped chip of that name differs from it"
    return None, f"chip {name!r}'s image is not recorded and no shipped chip has that name"


def session_scene(recording: Recording) -> SessionScene:
    """The recording's scene (see the module's docstring)."""
    decode = Decoder()
    described = _first(recording, SESSION)
    if described is None:
        return SessionScene(
            None,
            "this recording holds no chip (it was made before chips were recorded): "
            "the bodies are drawn on a blank field, without walls or route",
            None,
            None,
            np.zeros(0, int),
            np.zeros(0, int),
            _measured_tick_s(recording),
        )
    description = json.loads(decode(described).data)
    chip, note = _rebuild_chip(description, _first(recording, CHIP), decode)
    route = _first(recording, ROUTE)
    return SessionScene(
        chip,
        note,
        xy_um([p.pose for p in decode(route).poses]) if route is not None else None,
        float(description["goal_tolerance_um"]),
        np.array([_KIND_VALUES[k] for k in description["sphere_kind"]], int),
        np.asarray(description["handle_spheres"], int),
        float(description["tick_s"]),
    )


@dataclasses.dataclass(frozen=True)
class Tick:
    """The state after one tick (see the module's docstring)."""

    index: int
    """Ticks before this one in the recording."""
    trial: int
    time_s: float
    """Simulated time in the trial."""
    mode: str | None
    alpha: float | None
    trap_xy_um: np.ndarray
    sphere_xy_um: np.ndarray
    sphere_radius_um: np.ndarray | None


def tick_count(recording: Recording) -> int:
    return len(recording.topic(BODIES))


def ticks(recording: Recording, tick_s: float, wanted: Callable[[int], bool] = lambda index: True) -> Iterator[Tick]:
    """The ticks whose index ``wanted`` accepts, in order (others are not decoded)."""
    decode = Decoder()
    trial, trial_ticks, radii = 0, 0, None
    traps = alpha = mode = None
    index = 0
    for message in recording.messages:
        if message.topic == EVENTS:
            payload = json.loads(decode(message).data)
            if payload["event"] == "trial_start":
                trial, trial_ticks = payload["trial"], 0
                radii = np.asarray(payload.get("sphere_radius_um", []), float)
                mode = payload.get("mode", mode)
            elif payload["event"] == "mode":
                mode = payload["mode"]
        elif message.topic == TRAPS:
            traps = message
        elif message.topic == ALPHA:
            alpha = message
        elif message.topic == MODE:
            mode = decode(message).data
        elif message.topic == BODIES:
            trial_ticks += 1
            if wanted(index):
                yield Tick(
                    index,
                    trial,
                    trial_ticks * tick_s,
                    mode,
                    decode(alpha).data if alpha else None,
                    xy_um(decode(traps).poses) if traps else np.zeros((0, 2)),
                    xy_um(decode(message).poses),
                    radii,
                )
            index += 1
