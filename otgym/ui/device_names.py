"""What ``otgym play --device`` takes, in a module that imports nothing heavy: the
command line checks it before the window opens, and the window opens before the
simulator is imported (``otgym.ui.startup``)."""

from __future__ import annotations

from otgym import registry

TOUCH_NAMES = ("Default Device", "Right Device")
"""The two Touches' names as set in 3D Systems' Touch Setup (robot 0, robot 1)."""


def check_device_name(name: str) -> str:
    """A registered device tagged ``play`` (``otgym list devices``)."""
    return registry.check("devices", name, "play")
