"""The mouse dragging one robot's trap pair, as an input device.

The window tells the device where the pointer is (``drag_to``) and where the robot's
traps are now (their centre), both in chip um; while a drag lasts, ``read`` gives a
virtual stylus velocity that closes the gap in about ``1 / gain_per_s`` seconds,

    v_tip = gain_per_s * (pointer - traps) / motion_scale_um_per_mm   (device frame),

with button bit 0 held (the default retargeter's clutch), so the traps follow the
pointer as a rate command through the same retargeting path (tremor filter, dead band,
trap-speed clamp) and the same arbitration (in shared mode the drag is the person's
share alpha of the motion) as every other device.

Each robot's device is wrapped: ``MouseDragDevice(robot, primary)`` passes the
primary device's samples (keyboard, gamepad stick, Touch, simulated stylus) through
while no drag is on, and takes over for the length of a drag (the mouse is the more
deliberate input). Force commands go to the primary; without a primary it has no
haptics.
"""

from __future__ import annotations

import time

import numpy as np

from otgym.teleop.device import Device, DeviceCaps, Sample
from otgym.teleop.retarget import chip_to_device

MOUSE_CAPS = DeviceCaps("mouse drag", 2, 0.0, (160.0, 120.0, 70.0), 60.0)
DRAG_GAIN_PER_S = 2.0
"""The traps close half the gap to the pointer in about 0.35 s (then the trap-speed clamp rules)."""


class MouseDragDevice(Device):
    """The mouse dragging robot ``robot`` over ``primary`` (None: the mouse alone)."""

    def __init__(
        self,
        robot: int,
        primary: Device | None = None,
        motion_scale_um_per_mm: float = 2.0,
        gain_per_s: float = DRAG_GAIN_PER_S,
        plane: str = "xy",
    ):
        self.robot = robot
        self.primary = primary
        self.caps = primary.caps if primary is not None else MOUSE_CAPS
        self.motion_scale_um_per_mm = motion_scale_um_per_mm
        self.gain_per_s = gain_per_s
        self.plane = plane
        self._pointer_um: np.ndarray | None = None
        self._traps_um = np.zeros(2)
        self._position_mm = np.zeros(3)
        self._sequence = 0
        self._last_s: float | None = None

    @property
    def dragging(self) -> bool:
        return self._pointer_um is not None

    def drag_to(self, pointer_um, traps_um) -> None:
        """Begin or continue a drag: the pointer and the robot's trap centre (chip um)."""
        self._pointer_um = np.asarray(pointer_um, float)
        self._traps_um = np.asarray(traps_um, float)

    def release(self) -> None:
        self._pointer_um = None

    def start(self) -> None:
        if self.primary is not None:
            self.primary.start()
        self._last_s = time.monotonic()

    def stop(self) -> None:
        self.release()
        if self.primary is not None:
            self.primary.stop()

    def set_force(self, force_n) -> None:
        if self.primary is not None:
            self.primary.set_force(force_n)

    def read(self) -> Sample | None:
        if self._pointer_um is None:
            return self.primary.read() if self.primary is not None else None
        now = time.monotonic()
        chip_mm_s = self.gain_per_s * (self._pointer_um - self._traps_um) / self.motion_scale_um_per_mm
        velocity = chip_to_device(chip_mm_s, self.plane)
        self._position_mm = self._position_mm + velocity * (now - (self._last_s or now))
        self._last_s = now
        self._sequence += 1
        return Sample(now, self._sequence, self._position_mm, velocity, 1)
