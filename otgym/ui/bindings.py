"""Which device drives which robot for each ``otgym play --device``.

Every robot gets its own binding (robot 0, robot 1), each a ``MouseDragDevice`` over
that robot's primary device, so the mouse can drag either robot whatever the device:

============  ==========================================  =========================
--device      robot 0                                     robot 1
============  ==========================================  =========================
keyboard      arrows / W A S D move both robots as a      the same keys (one
              formation (no clutch: the keys are their    formation)
              own deadman, space pauses)
gamepad       left stick, left shoulder the clutch        right stick, right shoulder
touch         Touch ``TOUCH_NAMES[0]``, button 1 clutch   Touch ``TOUCH_NAMES[1]``
simulated     a simulated haptic stylus (a steady hand    the mouse only
              holding the clutch: the demo/test path)
============  ==========================================  =========================

The keyboard drives both robots through one device shared by both bindings (its
velocity is read once per robot each tick), so a person with only a keyboard can carry
the cell; the mouse drags either robot on its own (to grip). The keyboard device gets
only key events (the mouse drags through its own device), and
its retargeter has no clutch: a rate device stops when its key is released, so holding
space as a clutch would add nothing, and space pauses the trial.

Where each device lives. The keyboard and the gamepad are read by the window
(``window_devices``: only the window's SDL queue gets their events) and their samples
are forwarded to the session's process, where ``ForwardedDevice`` s stand for them;
the Touch and the simulated stylus (servo processes of their own) are opened by the
session's process itself (``robot_primaries``), so their feedback never crosses a
process boundary it need not cross.
"""

from __future__ import annotations

import dataclasses

from otgym.runtime.loop import DeviceBinding
from otgym.runtime.trials import TASK_RETARGET
from otgym.teleop.device import Device, open_device
from otgym.teleop.feedback import FeedbackConfig
from otgym.teleop.mouse_drag import MouseDragDevice
from otgym.ui.device_names import TOUCH_NAMES, check_device_name


def window_devices(name: str) -> list[Device]:
    """The devices of ``--device name`` that the window reads (constructed, not
    started): the keyboard, or the gamepad's left and right stick; none otherwise."""
    check_device_name(name)
    if name == "keyboard":
        return [open_device("keyboard", pump_events=False)]
    if name == "gamepad":
        return [
            open_device("gamepad", stick="left", pump_events=False),
            open_device("gamepad", stick="right", pump_events=False),
        ]
    return []


def robot_primaries(name: str, windowed: list[Device]) -> tuple[Device | None, Device | None]:
    """The devices of robot 0 and robot 1 (constructed, not started): the window's
    devices ``windowed`` (``window_devices(name)``, or what stands for them in another
    process), or the haptic devices opened here. The Touch raises the teleop layer's
    DeviceError at once without pyOpenHaptics and its runtime."""
    check_device_name(name)
    if name == "keyboard":
        return windowed[0], windowed[0]
    if name == "gamepad":
        return windowed[0], windowed[1]
    if name == "touch":
        return open_device("touch", device_name=TOUCH_NAMES[0]), open_device("touch", device_name=TOUCH_NAMES[1])
    return open_device("simulated"), None


def primary_devices(name: str) -> tuple[Device | None, Device | None]:
    """The devices of robot 0 and robot 1 when everything runs in one process."""
    return robot_primaries(name, window_devices(name))


def play_bindings(primaries, keyboard: bool, feedback: FeedbackConfig | None = None) -> list[DeviceBinding]:
    """One binding per robot, a ``MouseDragDevice`` over each primary (None: mouse
    only); ``feedback``: the styluses' feedback (``trials.task_feedback``, the scale at
    which the hand-trap loop is stable)."""
    retarget = dataclasses.replace(TASK_RETARGET, clutch_bit=None) if keyboard else TASK_RETARGET
    bindings = []
    for robot, primary in enumerate(primaries):
        config = retarget if primary is not None else TASK_RETARGET
        device = MouseDragDevice(robot, primary, TASK_RETARGET.motion_scale_um_per_mm, plane=config.plane)
        bindings.append(DeviceBinding(device, (robot,), retarget=config, feedback=feedback))
    return bindings
