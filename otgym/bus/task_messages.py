"""What the simulator publishes, built from otgym's objects: after each tick
(``tick_messages``: traps, phase, alpha, the mode when it changes, bodies, each device's
feedback) and once per session (``session_messages``: the latched description, chip
image and route). Topics, types and units: ``otgym.bus.messages``."""

from __future__ import annotations

import io
import json
from typing import TYPE_CHECKING

import numpy as np
from PIL import Image

from otgym.bus.messages import (
    ALPHA,
    BODIES,
    CHIP,
    CONTACT_FORCE,
    MODE,
    PHASE,
    PHASES,
    ROUTE,
    SESSION,
    SPHERE_KINDS,
    TRAPS,
    compressed_png,
    feedback_topic,
    float64,
    path,
    pose_array,
    string,
    wrench,
)

if TYPE_CHECKING:  # the loop imports JAX; a device node need not
    from otgym.runtime.loop import TickRecord
    from otgym.task.task import InteractiveTask


def tick_messages(
    record: TickRecord, devices: list[str], sphere_xy_um, stamp_s: float, mode: str | None = None
) -> list[tuple[str, bytes]]:
    """(topic, CDR) of what the simulator publishes after one tick: traps, phase, alpha,
    the mode only when ``mode`` is given (the caller gives it at a trial's first tick and
    when it changes: ``/otgym/mode`` is latched, not sent every tick), bodies (every
    sphere's centre; after the others, so that a subscriber that acts on it has seen the
    tick's traps and phase, or at worst the previous tick's; the contact force the vision
    sensor read, summed over the handles where valid (pN -> N), comes before it) and the
    feedback force for each device (``devices`` in the order of the record's
    ``feedback_n`` rows)."""
    messages = [
        (TRAPS, pose_array(record.trap_xy_um, stamp_s)),
        (PHASE, string(PHASES[record.phase])),
        (ALPHA, float64(record.alpha)),
    ]
    messages += [] if mode is None else [(MODE, string(mode))]
    sensed_pn = np.asarray(record.sensed_force_pn, float)[np.asarray(record.sensed_valid, bool)]
    contact_n = np.append(np.nan_to_num(sensed_pn).sum(axis=0), 0.0) * 1e-12 if len(sensed_pn) else np.zeros(3)
    messages += [(CONTACT_FORCE, wrench(contact_n, stamp_s, "chip"))]
    messages += [(BODIES, pose_array(sphere_xy_um, stamp_s))]
    messages += [
        (feedback_topic(name), wrench(force, stamp_s, name)) for name, force in zip(devices, record.feedback_n)
    ]
    return messages


def session_description(task: InteractiveTask, devices: list[str]) -> dict:
    """The JSON object of ``/otgym/session`` for ``task``: ``chip`` (the sidecar's
    fields, ``Chip.metadata``, and ``content_hash``), ``goal_tolerance_um``, ``tick_s``,
    ``sphere_kind`` (one of ``SPHERE_KINDS`` per sphere, the order of ``/otgym/bodies``),
    ``sphere_body`` (the index of each sphere's body: spheres of one body move as one),
    ``sphere_radius_um`` (each sphere's radius), ``handle_spheres`` (the spheres the
    traps hold, in trap order) and ``devices``."""
    model = task.scene.model
    return {
        "chip": {**task.chip.metadata(), "content_hash": task.chip.content_hash},
        "goal_tolerance_um": float(task.config.goal_tolerance_um),
        "tick_s": float(task.config.tick_s),
        "sphere_kind": [SPHERE_KINDS[int(model.body_kinds[b])] for b in model.sphere_body],
        "sphere_body": [int(b) for b in model.sphere_body],
        "sphere_radius_um": [float(r) for r in model.sphere_radius_um],
        "handle_spheres": [int(i) for i in task.trap_sphere],
        "devices": list(devices),
    }


def chip_png(chip) -> bytes:
    """The chip's image as an 8-bit gray PNG (``otgym.sim.chip.save_chip``'s encoding)."""
    buffer = io.BytesIO()
    Image.fromarray(np.round(np.asarray(chip.image) * 255).astype(np.uint8), mode="L").save(buffer, format="PNG")
    return buffer.getvalue()


def session_messages(task: InteractiveTask, devices: list[str], stamp_s: float) -> list[tuple[str, bytes]]:
    """(topic, CDR) of what describes a session, sent once at its start (latched):
    ``/otgym/session`` (``session_description``), ``/otgym/chip`` (``chip_png``) and
    ``/otgym/route`` (the planned route, um)."""
    return [
        (SESSION, string(json.dumps(session_description(task, devices), sort_keys=True))),
        (CHIP, compressed_png(chip_png(task.chip), stamp_s)),
        (ROUTE, path(task.route_um, stamp_s)),
    ]
