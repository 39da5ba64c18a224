"""Geomagic Touch (3D Systems) through pyOpenHaptics, a ctypes wrapper of the vendor's
OpenHaptics HD library (libHD).

Install with ``pip install "otgym[haptics]"`` plus 3D Systems' OpenHaptics runtime and
the Touch device driver. Importing pyOpenHaptics loads libHD at once (it raises
OSError without the runtime, ImportError without the package); both become a one-line
DeviceError.

The device is driven inside a ``ServoDevice`` process. There the HD scheduler calls our
callback at 1 kHz (within an HD frame): it reads the tip position (the translation of
HD_CURRENT_TRANSFORM, mm, device frame x right, y up, z toward the user) and the button
bits, estimates the velocity as the authors' release did (``VelocityEstimator``), and
applies the latest commanded force. The servo loop of ``ServoDevice`` only relays the
force and the sample (it sleeps rather than busy-waits, leaving the GIL to the HD
callback thread). Forces are saturated at the Touch's continuous limit, 0.88 N (3.3 N
is its peak).
"""

from __future__ import annotations

import functools
import time

import numpy as np

from otgym.teleop.device import DeviceCaps, DeviceError
from otgym.teleop.servo import ServoDevice, VelocityEstimator

TOUCH_CAPS = DeviceCaps(
    name="Geomagic Touch", dof=3, force_limit_n=0.88, workspace_mm=(160.0, 120.0, 70.0), rate_hz=1000.0
)
"""3D Systems' figures: 3 force-feedback axes (6 sensed), workspace > 160 W x 120 H x
70 D mm, 0.88 N continuous force, 1 kHz servo rate."""
STALE_CALLBACK_S = 0.1
"""The HD callback has not run for this long: the scheduler stopped, the device is lost."""


def _openhaptics():
    """The pyOpenHaptics modules (hd, hd_callback), or a DeviceError saying what is missing."""
    try:
        from pyOpenHaptics import hd, hd_callback
    except (ImportError, OSError) as error:
        reason = " ".join(str(error).split()) or type(error).__name__
        raise DeviceError(
            "Geomagic Touch needs the 'haptics' extra (pip install \"otgym[haptics]\") and "
            f"3D Systems' OpenHaptics runtime (libHD): {reason}"
        ) from None
    return hd, hd_callback


class TouchBackend:
    """The servo backend of one Touch; created inside the servo process."""

    def __init__(self, device_name: str):
        hd, hd_callback = _openhaptics()
        self._hd = hd
        self._force_n = np.zeros(3)
        self._state = None
        self._state_s = time.monotonic()
        self._estimator = VelocityEstimator(TOUCH_CAPS.rate_hz)
        self._handle = hd.init_device(device_name)
        if self._handle is None:
            raise DeviceError(
                f"no Geomagic Touch named {device_name!r} could be opened (is it plugged in and "
                "set up with Touch Setup?)"
            )

        def servo_callback():  # a plain function, the form pyOpenHaptics' decorator wraps
            self._servo_callback()

        # a ctypes callback must stay referenced as long as the scheduler may call it
        self._callback = hd_callback.hd_callback(servo_callback)
        hd.enable_force()
        hd.start_scheduler()
        hd_callback.hdAsyncSheduler(self._callback)

    def _servo_callback(self) -> None:
        transform = self._hd.get_transform()
        position_mm = np.array([transform[3][0], transform[3][1], transform[3][2]])
        now = time.monotonic()
        self._state = (position_mm, self._estimator(position_mm, now), int(self._hd.get_buttons()))
        self._state_s = now
        self._hd.set_force([float(f) for f in self._force_n])

    def servo_step(self, force_n: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
        self._force_n = np.asarray(force_n, dtype=float)
        if time.monotonic() - self._state_s > STALE_CALLBACK_S:
            raise DeviceError("the Touch stopped answering (cable, power or the HD scheduler)")
        if self._state is None:
            return np.full(3, np.nan), np.full(3, np.nan), 0
        return self._state

    def close(self) -> None:
        """Zero the force, give the callback two servo ticks to apply it, stop."""
        self._force_n = np.zeros(3)
        time.sleep(0.002)
        self._hd.stop_scheduler()
        self._hd.close_device(self._handle)


class TouchDevice(ServoDevice):
    """A Geomagic Touch named ``device_name`` (as in Touch Setup; "Default Device" is
    the first). Raises DeviceError at once when pyOpenHaptics or libHD is missing."""

    def __init__(self, device_name: str = "Default Device", **servo_options):
        _openhaptics()
        servo_options.setdefault("busy_wait_s", 0.0)
        super().__init__(functools.partial(TouchBackend, device_name), TOUCH_CAPS, **servo_options)
