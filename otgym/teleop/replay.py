"""Recorded device streams: save samples to a CSV file and play them back as a Device.

The file is plain CSV with a header and one sample per row, columns ``COLUMNS``
(times in seconds as recorded, positions mm, velocities mm/s, buttons as an integer
of bits). Numbers are written with 17 significant digits, so a round trip is exact.

Playback keeps the recorded timing: at ``t`` seconds after ``start()`` ``read()``
returns the last sample recorded at most ``t`` after the first, stamped with the
present clock (start + its offset), so a pause in the recording ages the sample as it
did live. Without ``loop`` the last sample stays (and ages: downstream it counts as a
silent device); with ``loop`` playback restarts after one median sample interval past
the last sample, sequences continuing to increase.
"""

from __future__ import annotations

import csv
import math
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from otgym.teleop.device import Device, DeviceCaps, DeviceError, Sample

COLUMNS = ("time_s", "sequence", "x_mm", "y_mm", "z_mm", "vx_mm_s", "vy_mm_s", "vz_mm_s", "buttons")


def record_samples(samples, path) -> None:
    """Write ``samples`` (an iterable of Sample) to the CSV file ``path``."""
    with open(path, "w", newline="") as stream:
        writer = csv.writer(stream)
        writer.writerow(COLUMNS)
        for s in samples:
            numbers = [repr(float(v)) for v in (*s.position_mm, *s.velocity_mm_s)]
            writer.writerow([repr(s.time_s), s.sequence, *numbers, s.buttons])


def load_samples(path) -> list[Sample]:
    """The samples of a CSV file written by ``record_samples``; DeviceError (one line)
    when the file is missing, empty, malformed, or its times are not finite and
    non-decreasing."""

    def fail(reason: str):
        return DeviceError(f"replay file {path}: {reason}")

    try:
        with open(path, newline="") as stream:
            rows = list(csv.reader(stream))
    except OSError as error:
        raise fail(error.strerror or type(error).__name__) from None
    except (UnicodeDecodeError, csv.Error) as error:
        raise fail(f"not a CSV text file ({type(error).__name__})") from None
    if not rows or tuple(field.strip() for field in rows[0]) != COLUMNS:
        raise fail(f"the first line must be the header {','.join(COLUMNS)}")
    samples = []
    for line, row in enumerate(rows[1:], start=2):
        if len(row) != len(COLUMNS):
            raise fail(f"line {line} has {len(row)} fields, expected {len(COLUMNS)}")
        try:
            time_s, sequence, buttons = float(row[0]), int(row[1]), int(row[8])
            vector = [float(v) for v in row[2:8]]
            sample = Sample(time_s, sequence, vector[:3], vector[3:], buttons)
        except ValueError as error:
            raise fail(f"line {line}: {error}") from None
        if not math.isfinite(time_s) or (samples and time_s < samples[-1].time_s):
            raise fail(f"line {line}: time_s must be finite and non-decreasing")
        samples.append(sample)
    if not samples:
        raise fail("no samples")
    return samples


class ReplayDevice(Device):
    """Plays the recorded stream in ``path`` by its time stamps relative to ``start()``.
    ``clock`` is the time source (``time.monotonic``; a test may pass its own).
    ``caps.workspace_mm`` is the recorded extent (at least 1 mm per axis), ``rate_hz``
    the recording's median rate."""

    def __init__(self, path, loop: bool = False, clock: Callable[[], float] = time.monotonic):
        self.path = Path(path)
        self.loop = bool(loop)
        self._clock = clock
        self._samples = load_samples(path)
        times = np.array([s.time_s for s in self._samples])
        self._offsets_s = times - times[0]
        intervals = np.diff(times)
        intervals = intervals[intervals > 0]
        interval_s = float(np.median(intervals)) if intervals.size else 1.0
        self._duration_s = self._offsets_s[-1] + interval_s
        self._sequence_span = self._samples[-1].sequence - self._samples[0].sequence + 1
        positions = np.array([s.position_mm for s in self._samples])
        positions = positions[np.isfinite(positions).all(axis=1)]
        extent = np.ptp(positions, axis=0) if len(positions) else np.zeros(3)
        self.caps = DeviceCaps(
            name=f"replay of {self.path.name}",
            dof=3,
            force_limit_n=0.0,
            workspace_mm=tuple(float(max(e, 1.0)) for e in extent),
            rate_hz=1.0 / interval_s,
        )
        self._start_s: float | None = None

    def start(self) -> None:
        self._start_s = self._clock()

    def stop(self) -> None:
        self._start_s = None

    def read(self) -> Sample | None:
        if self._start_s is None:
            return None
        elapsed = self._clock() - self._start_s
        cycle, phase = divmod(elapsed, self._duration_s) if self.loop else (0, elapsed)
        index = int(np.searchsorted(self._offsets_s, phase, side="right")) - 1
        recorded = self._samples[index]
        return Sample(
            self._start_s + cycle * self._duration_s + self._offsets_s[index],
            recorded.sequence + int(cycle) * self._sequence_span,
            recorded.position_mm,
            recorded.velocity_mm_s,
            recorded.buttons,
        )


def looped_replay(path) -> ReplayDevice:
    """A replay that starts over at its end: what ``otgym node device --device replay`` plays."""
    return ReplayDevice(path, loop=True)
