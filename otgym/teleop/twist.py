"""A velocity command from elsewhere as a device: a ROS 2 ``geometry_msgs/Twist`` (as
teleop_twist_keyboard and teleop_twist_joy publish on ``/cmd_vel``) fed by
``otgym.bus.twist_source``, read like any other rate device.

Mapping: ``linear.x`` and ``linear.y`` (m/s) become the tip velocity's x and y in the
device frame, times ``mm_s_per_m_s`` (default 4: teleop_twist_keyboard's default speed,
0.5 m/s, gives 2 mm/s, the keyboard device's speed, 4 um/s at the trap with the default
motion scale); z and the angular part are not used. The speed is clamped to
``max_speed_mm_s`` (its norm, direction kept).

Safety (as for every device, DESIGN.md "safety first"):
- a command with a non-finite value is dropped and counted (``dropped_nonfinite``),
  never applied; the last good command stays in force until it ages out;
- silence: ``timeout_s`` (0.5 s) after the last command, ``read`` gives a sample at
  rest with the clutch released (zero input: the retargeter's clutch zeroes dP_h, the
  traps hold); while commands are fresh the clutch bit (bit 0) is held;
- samples are stamped with ``clock`` (``time.monotonic``) and renewed at ``rate_hz``
  (50 Hz), so the retargeter sees a held command as fresh input, not as a stale one.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable

import numpy as np

from otgym.teleop.device import Device, DeviceCaps, Sample

TWIST_WORKSPACE_MM = (160.0, 120.0, 70.0)
CLUTCH = 1


class TwistDevice(Device):
    """Velocity commands (m/s) fed by ``feed``; see the module's docstring."""

    def __init__(
        self,
        mm_s_per_m_s: float = 4.0,
        max_speed_mm_s: float = 10.0,
        timeout_s: float = 0.5,
        rate_hz: float = 50.0,
        clock: Callable[[], float] = time.monotonic,
    ):
        for name, value in (
            ("mm_s_per_m_s", mm_s_per_m_s),
            ("max_speed_mm_s", max_speed_mm_s),
            ("timeout_s", timeout_s),
            ("rate_hz", rate_hz),
        ):
            if not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
                raise ValueError(f"{name} must be positive and finite, got {value!r}")
        self.caps = DeviceCaps("ROS 2 twist", 2, 0.0, TWIST_WORKSPACE_MM, rate_hz)
        self.mm_s_per_m_s, self.max_speed_mm_s = float(mm_s_per_m_s), float(max_speed_mm_s)
        self.timeout_s, self.period_s, self.clock = float(timeout_s), 1.0 / rate_hz, clock
        self.received = 0
        """Commands applied."""
        self.dropped_nonfinite = 0
        """Commands dropped for a non-finite value."""
        self.clamped = 0
        """Commands whose speed was clamped."""
        self._command: tuple[float, np.ndarray] | None = None
        self._sample: Sample | None = None
        self._sequence = 0
        self._position_mm = np.zeros(3)
        self._lock = threading.Lock()

    def feed(self, linear_m_s) -> bool:
        """Take a command's linear velocity (x, y, z) in m/s; False if it was dropped."""
        linear = np.asarray(linear_m_s, float).reshape(3)
        with self._lock:
            if not np.isfinite(linear).all():
                self.dropped_nonfinite += 1
                return False
            velocity = np.array([linear[0], linear[1], 0.0]) * self.mm_s_per_m_s
            speed = float(np.linalg.norm(velocity))
            if speed > self.max_speed_mm_s:
                velocity *= self.max_speed_mm_s / speed
                self.clamped += 1
            self._command = (self.clock(), velocity)
            self.received += 1
            self._sample = None  # the next read shows it at once
            return True

    def start(self) -> None:
        pass

    def stop(self) -> None:
        with self._lock:
            self._command = None

    def read(self) -> Sample | None:
        now = self.clock()
        with self._lock:
            fresh = self._command is not None and now - self._command[0] <= self.timeout_s
            cached = self._sample
            if (
                cached is not None
                and now - cached.time_s < self.period_s
                and cached.buttons == (CLUTCH if fresh else 0)
            ):
                return cached  # silence shows at once, not a period later
            velocity = self._command[1] if fresh else np.zeros(3)
            if self._sample is not None:
                self._position_mm = self._position_mm + self._sample.velocity_mm_s * (now - self._sample.time_s)
            self._sequence += 1
            self._sample = Sample(now, self._sequence, self._position_mm, velocity, CLUTCH if fresh else 0)
            return self._sample
