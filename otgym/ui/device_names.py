"""What ``otgym play --device`` takes, in a module that imports nothing heavy: the
command line checks it before the window opens, and the window opens before the
simulator is imported (``otgym.ui.startup``)."""

from __future__ import annotations

PLAY_DEVICES = ("keyboard", "gamepad", "touch", "simulated")
TOUCH_NAMES = ("Default Device", "Right Device")
"""The two Touches' names as set in 3D Systems' Touch Setup (robot 0, robot 1)."""


def check_device_name(name: str) -> str:
    if name not in PLAY_DEVICES:
        raise ValueError(f"unknown device {name!r}; choose one of {', '.join(PLAY_DEVICES)}")
    return name
