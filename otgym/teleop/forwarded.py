"""A device whose samples are fed from elsewhere: another process's device (the
window reads the keyboard and the gamepad, whose events only its SDL queue gets, and
forwards their samples to the simulation's process), or a bus subscription.

``feed(sample)`` replaces the latest sample, ``read`` returns it (never blocks; the
retargeter judges its age by ``Sample.time_s``, ``time.monotonic``, one clock for
every process of a machine), ``lose(reason)`` marks the link lost (``read`` then
raises ``DeviceError``, as a driver whose hardware went away does), and
``set_force`` hands the force to ``on_force`` (None: a device without haptics)."""

from __future__ import annotations

import threading
from collections.abc import Callable

import numpy as np

from otgym.teleop.device import Device, DeviceCaps, DeviceError, Sample


class ForwardedDevice(Device):
    """Samples fed by ``feed``; ``caps`` those of the device they come from."""

    def __init__(self, caps: DeviceCaps, on_force: Callable[[np.ndarray], None] | None = None):
        self.caps = caps
        self.on_force = on_force
        self._sample: Sample | None = None
        self._lost: str | None = None
        self._lock = threading.Lock()

    def feed(self, sample: Sample | None) -> None:
        with self._lock:
            self._sample = sample

    def lose(self, reason: str) -> None:
        with self._lock:
            self._lost = reason

    def start(self) -> None:
        pass

    def stop(self) -> None:
        pass

    def read(self) -> Sample | None:
        with self._lock:
            if self._lost is not None:
                raise DeviceError(f"{self.caps.name}: {self._lost}")
            return self._sample

    def set_force(self, force_n) -> None:
        if self.on_force is not None:
            self.on_force(np.asarray(force_n, float))
