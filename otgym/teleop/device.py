"""The one protocol every input device speaks (after Isaac Lab's and robosuite's
``devices``): ``start()``, ``stop()``, ``read() -> Sample``, ``set_force(newtons)`` and
``caps``. Drivers run at their own rate and keep the latest sample; ``read`` never
blocks. Buttons are raw bits: what they mean (clutch, grip, mode) is decided by the
retargeting layer, not by drivers.

Device frame (the OpenHaptics convention): x to the user's right, y up, z toward the
user; millimetres, seconds, newtons.
"""

from __future__ import annotations

import abc
import dataclasses
import math

import numpy as np

from otgym import registry


class DeviceError(RuntimeError):
    """A device cannot be opened or was lost; ``str()`` is one line for the user."""


@dataclasses.dataclass(frozen=True, eq=False)
class Sample:
    """One reading of a device's tip (arrays are read-only (3,) float64; NaN allowed,
    consumers must check)."""

    time_s: float
    """``time.monotonic()`` when sampled."""
    sequence: int
    """Increments with every new sample."""
    position_mm: np.ndarray
    velocity_mm_s: np.ndarray
    buttons: int
    """Raw button bits (bit 0 = first button)."""

    def __post_init__(self):
        for name in ("position_mm", "velocity_mm_s"):
            array = np.array(getattr(self, name), dtype=np.float64)
            if array.shape != (3,):
                raise ValueError(f"{name} must have shape (3,), got {array.shape}")
            array.setflags(write=False)
            object.__setattr__(self, name, array)
        if int(self.buttons) < 0:
            raise ValueError(f"buttons must be non-negative bits, got {self.buttons!r}")
        object.__setattr__(self, "buttons", int(self.buttons))
        object.__setattr__(self, "sequence", int(self.sequence))
        object.__setattr__(self, "time_s", float(self.time_s))

    @property
    def finite(self) -> bool:
        """True when time, position and velocity are all finite."""
        return bool(
            math.isfinite(self.time_s) and np.isfinite(self.position_mm).all() and np.isfinite(self.velocity_mm_s).all()
        )


@dataclasses.dataclass(frozen=True)
class DeviceCaps:
    """What a device offers: ``dof`` tracked tip axes, continuous force limit (0 without
    haptics), workspace extent per device axis and sampling rate."""

    name: str
    dof: int
    force_limit_n: float
    workspace_mm: tuple[float, float, float]
    rate_hz: float

    def __post_init__(self):
        if not isinstance(self.dof, int) or not 1 <= self.dof <= 6:
            raise ValueError(f"dof must be an integer within 1..6, got {self.dof!r}")
        if not math.isfinite(self.force_limit_n) or self.force_limit_n < 0:
            raise ValueError(f"force_limit_n must be finite and >= 0, got {self.force_limit_n!r}")
        workspace = tuple(float(w) for w in self.workspace_mm)
        if len(workspace) != 3 or not all(math.isfinite(w) and w > 0 for w in workspace):
            raise ValueError(f"workspace_mm must be three positive finite extents, got {self.workspace_mm!r}")
        object.__setattr__(self, "workspace_mm", workspace)
        if not math.isfinite(self.rate_hz) or self.rate_hz <= 0:
            raise ValueError(f"rate_hz must be positive and finite, got {self.rate_hz!r}")


def saturate_force(force_n, limit_n: float) -> np.ndarray:
    """(3,) force with its norm clipped to ``limit_n``; a non-finite force becomes zero
    (a bad command must never reach the motors)."""
    force = np.asarray(force_n, dtype=np.float64).reshape(3)
    if not np.isfinite(force).all():
        return np.zeros(3)
    norm = float(np.linalg.norm(force))
    return force * (limit_n / norm) if norm > limit_n else force.copy()


class Device(abc.ABC):
    """Base of every input device; a context manager (``with`` starts and stops it)."""

    caps: DeviceCaps

    @abc.abstractmethod
    def start(self) -> None:
        """Open the device and begin sampling; raises DeviceError when it cannot."""

    @abc.abstractmethod
    def stop(self) -> None:
        """Zero any force first, then release the device; idempotent."""

    @abc.abstractmethod
    def read(self) -> Sample | None:
        """The latest sample without blocking; None before the first."""

    def set_force(self, force_n) -> None:  # noqa: B027 (a no-op default, overridden by haptic devices)
        """Command a (3,) tip force in newtons, saturated to ``caps.force_limit_n``;
        a no-op for devices without haptics (this default)."""

    def __enter__(self):
        self.start()
        return self

    def __exit__(self, *exc_info):
        self.stop()


def start_devices(devices) -> None:
    """Start every device in order; if one fails, zero the force of and stop those
    already started, then re-raise (nothing is left running half-started)."""
    started = []
    try:
        for device in devices:
            device.start()
            started.append(device)
    except BaseException:
        for device in started:
            device.set_force(np.zeros(3))
            device.stop()
        raise


def driver(name: str):
    """The class (or factory) of device ``name`` (a registered device tagged ``driver``:
    ``otgym list devices``), imported now, so pygame or OpenHaptics are needed only by
    their users; ValueError for an unknown name."""
    return registry.entry("devices", name, "driver").load()


def open_device(name: str, **options) -> Device:
    """A device by name (``driver``), constructed (not started) with ``options`` passed
    to its driver."""
    return driver(name)(**options)
