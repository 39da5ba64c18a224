"""The MCAP recording of one ``otgym play`` session (``DIR/session.mcap``; a later
session in the same folder writes ``session-2.mcap`` and so on): every tick's
messages as the distributed simulator publishes them (``otgym.bus.messages``: traps,
bodies, alpha, each device's feedback; the mode at a trial's first tick and when it
changes), the session's description, chip image and route once at its start
(``describe``), every new device sample as the device node publishes it (twist and
buttons), and the trial events, written by
``otgym.record.McapRecorder`` (zstd chunks flushed at least every second).

Device samples are taken where the loop reads them: each binding's device is wrapped
in a ``RecordedDevice`` that passes every call through and records each new sample
(by sequence number) on the device's topics. Device ``i`` is named ``device<i>``."""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path

from otgym.bus import messages as msg
from otgym.bus import task_messages
from otgym.bus.foxglove_scene import SceneRecording
from otgym.bus.schemas import SCHEMAS
from otgym.record.mcap_file import McapRecorder
from otgym.runtime.loop import DeviceBinding, TickRecord
from otgym.task.task import InteractiveTask
from otgym.teleop.device import Device, Sample

SCENE_SOURCES = (msg.SESSION, msg.CHIP, msg.ROUTE, msg.TRAPS, msg.BODIES)
"""The topics the recorded scene is drawn from."""


class SessionRecording:
    """Records a session into ``path``; ``wrap`` the bindings before the simulation
    starts, then ``tick`` after every tick and ``event`` for trial events."""

    def __init__(self, path: Path, clock_s=time.time):
        self.recorder = McapRecorder(path)
        self.path = self.recorder.path
        self.devices: list[str] = []
        self.clock_s = clock_s
        self.active = False
        """False until the first event: samples read before it (the warm-up's) are not recorded."""
        self._mode_written: str | None = None
        self.scene = SceneRecording(self.recorder.write_encoded)
        """Foxglove's 3D scene, recorded beside the messages it is drawn from."""

    def write(self, topic: str, data: bytes, stamp_s: float | None = None) -> None:
        stamp_s = self.clock_s() if stamp_s is None else stamp_s
        type_name = msg.topic_type(topic)
        self.recorder.write(topic, type_name, SCHEMAS[type_name], data, log_time_ns=int(stamp_s * 1e9))
        if topic in SCENE_SOURCES:
            self.scene.take(topic, msg.decode(topic, data))

    def wrap(self, bindings: list[DeviceBinding]) -> list[DeviceBinding]:
        """The bindings with each device wrapped so its samples are recorded."""
        wrapped = []
        for binding in bindings:
            name = f"device{len(self.devices)}"
            self.devices.append(name)
            wrapped.append(dataclasses.replace(binding, device=RecordedDevice(binding.device, name, self)))
        return wrapped

    def describe(self, task: InteractiveTask) -> None:
        """Record the session's description, chip image and route (once, at its start)."""
        for topic, data in task_messages.session_messages(task, self.devices, self.clock_s()):
            self.write(topic, data)

    def tick(self, record: TickRecord, sphere_xy_um, mode: str) -> None:
        stamp_s = self.clock_s()
        changed = mode if mode != self._mode_written else None  # the mode at a trial's first tick and on change
        self._mode_written = mode
        for topic, data in task_messages.tick_messages(record, self.devices, sphere_xy_um, stamp_s, changed):
            self.write(topic, data, stamp_s)

    def event(self, name: str, **fields) -> None:
        self.active = True
        if name == "trial_start":
            self._mode_written = None
        self.write(msg.EVENTS, msg.event(name, **fields))

    def close(self) -> None:
        self.recorder.close()


class RecordedDevice(Device):
    """``device`` unchanged, except that each new sample ``read`` returns is also
    recorded as the device's twist and buttons."""

    def __init__(self, device: Device, name: str, recording: SessionRecording):
        self.device, self.name, self.recording = device, name, recording
        self.caps = device.caps
        self._last_sequence: int | None = None

    def start(self) -> None:
        self.device.start()

    def stop(self) -> None:
        self.device.stop()

    def set_force(self, force_n) -> None:
        self.device.set_force(force_n)

    def read(self) -> Sample | None:
        sample = self.device.read()
        if self.recording.active and sample is not None and sample.sequence != self._last_sequence and sample.finite:
            self._last_sequence = sample.sequence
            stamp_s = self.recording.clock_s()
            self.recording.write(msg.twist_topic(self.name), msg.twist(sample, stamp_s, self.name), stamp_s)
            self.recording.write(msg.buttons_topic(self.name), msg.joy(sample.buttons, stamp_s, self.name), stamp_s)
        return sample
