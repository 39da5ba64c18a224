"""A robot's device whose input another device takes over while that one is engaged:
the window's mouse drag over the stylus of a device node, when the window and the
device run in different processes (in one process ``mouse_drag.MouseDragDevice``
does this itself).

``read`` gives the taking-over device's sample while it is fresh (at most
``fresh_s`` old by its ``time_s``) and holds button bit 0 (a drag in progress, as
``MouseDragDevice`` sends it), else the primary's (None without one). Forces go to
the primary: the taking-over device has no haptics."""

from __future__ import annotations

import time
from collections.abc import Callable

from otgym.teleop.device import Device, Sample

TAKEOVER_FRESH_S = 0.1
"""As the retargeter's silence timeout: an older sample no longer takes over."""


class TakeoverDevice(Device):
    def __init__(
        self,
        primary: Device | None,
        over: Device,
        fresh_s: float = TAKEOVER_FRESH_S,
        clock: Callable[[], float] = time.monotonic,
    ):
        self.primary, self.over, self.fresh_s, self.clock = primary, over, fresh_s, clock
        self.caps = primary.caps if primary is not None else over.caps

    def start(self) -> None:
        if self.primary is not None:
            self.primary.start()
        self.over.start()

    def stop(self) -> None:
        self.over.stop()
        if self.primary is not None:
            self.primary.stop()

    def read(self) -> Sample | None:
        sample = self.over.read()
        if sample is not None and sample.buttons & 1 and self.clock() - sample.time_s <= self.fresh_s:
            return sample
        return self.primary.read() if self.primary is not None else None

    def set_force(self, force_n) -> None:
        if self.primary is not None:
            self.primary.set_force(force_n)
