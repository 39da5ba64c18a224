"""Teleoperation: input devices, retargeting to trap increments, haptic feedback
(paper sections II-D and II-E).

Modules, each with one job: ``device`` (the protocol every device speaks,
``open_device``), ``retarget`` (samples -> the human's trap increment dP_h),
``feedback`` (the vision force sensor's reading -> a stylus force), ``servo`` (a haptic
servo loop in its own process), the drivers ``touch``, ``pygame_devices`` and
``replay``, and two devices made of others: ``mouse_drag`` (the mouse dragging one
robot, over that robot's device) and ``forwarded`` (samples that another process or
a bus subscription feeds in). The simulated participants that drive the interactive task closed
loop are task-level agents and live in ``otgym.human.participants``.

Only the device protocol is imported here: this package is imported by every servo
process at its start, which must stay fast (no scipy, pygame or OpenHaptics); import
the rest from its module.
"""

from otgym.teleop.device import Device, DeviceCaps, DeviceError, Sample, open_device

__all__ = ["Device", "DeviceCaps", "DeviceError", "Sample", "open_device"]
