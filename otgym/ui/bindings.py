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

from otgym import registry
from otgym.runtime.loop import DeviceBinding
from otgym.runtime.trials import TASK_RETARGET
from otgym.teleop.device import Device, open_device
from otgym.teleop.feedback import FeedbackConfig
from otgym.teleop.mouse_drag import MouseDragDevice
from otgym.ui.device_names import TOUCH_NAMES


@dataclasses.dataclass(frozen=True)
class PlayBinding:
    """How one ``--device`` drives the two robots; a device's registry entry names its
    binding in the extra ``play_binding`` (``"module:attribute"``), and a device without
    one is ``ROBOT_0_ONLY``."""

    window: tuple[dict, ...] = ()
    """``open_device`` options of each device the window reads (its SDL events)."""
    robots: tuple[int | None, int | None] = (None, None)
    """Robot 0's and robot 1's window device: an index into ``window`` (None: none)."""
    session: tuple[dict | None, dict | None] = (None, None)
    """``open_device`` options of each robot's device opened in the session's process,
    where ``window`` is empty (None: that robot has the mouse only)."""
    clutch: bool = True
    """False for a rate device that stops when its key is released: no clutch."""


ONE_WINDOW_DEVICE_FOR_BOTH = PlayBinding(window=({"pump_events": False},), robots=(0, 0), clutch=False)
"""The keyboard: one window device moves both robots as a formation."""
A_STICK_EACH = PlayBinding(
    window=({"stick": "left", "pump_events": False}, {"stick": "right", "pump_events": False}), robots=(0, 1)
)
"""The gamepad: the left stick drives robot 0, the right stick robot 1."""
A_DEVICE_EACH_BY_NAME = PlayBinding(session=({"device_name": TOUCH_NAMES[0]}, {"device_name": TOUCH_NAMES[1]}))
"""The Touch: one stylus per robot, found by its name in Touch Setup."""
ROBOT_0_ONLY = PlayBinding(session=({}, None))
"""One device opened in the session's process for robot 0 (the simulated stylus)."""


def play_binding(name: str) -> PlayBinding:
    """The binding of registered device ``name`` (ValueError for an unknown one)."""
    found = registry.entry("devices", name)
    if "play_binding" not in found.extras:
        return ROBOT_0_ONLY if "play" in found.tags else PlayBinding()
    return found.load_extra("play_binding")


def takeover_device() -> str:
    """The registered window device that takes over the robots' device nodes while it
    drags (extra ``window_takeover``: the mouse)."""
    return next(
        name
        for name in registry.names("devices", "window")
        if registry.entry("devices", name).extras.get("window_takeover")
    )


def takes_over(name: str) -> bool:
    """Whether window device ``name`` takes over device nodes (``takeover_device``)."""
    return bool(registry.entry("devices", name).extras.get("window_takeover"))


def window_devices(name: str) -> list[Device]:
    """The devices of ``--device name`` that the window reads (constructed, not
    started): the keyboard, or the gamepad's left and right stick; none otherwise."""
    return [open_device(name, **options) for options in play_binding(name).window]


def robot_primaries(name: str, windowed: list[Device]) -> tuple[Device | None, Device | None]:
    """The devices of robot 0 and robot 1 (constructed, not started): the window's
    devices ``windowed`` (``window_devices(name)``, or what stands for them in another
    process), or the haptic devices opened here. The Touch raises the teleop layer's
    DeviceError at once without pyOpenHaptics and its runtime."""
    binding = play_binding(registry.check("devices", name, "play"))
    if binding.window:
        return tuple(None if index is None else windowed[index] for index in binding.robots)
    return tuple(None if options is None else open_device(name, **options) for options in binding.session)


def primary_devices(name: str) -> tuple[Device | None, Device | None]:
    """The devices of robot 0 and robot 1 when everything runs in one process."""
    return robot_primaries(name, window_devices(name))


def play_bindings(primaries, clutch: bool = True, feedback: FeedbackConfig | None = None) -> list[DeviceBinding]:
    """One binding per robot, a ``MouseDragDevice`` over each primary (None: mouse
    only); ``clutch``: the device's ``PlayBinding.clutch``; ``feedback``: the styluses'
    feedback (``trials.task_feedback``, the scale at which the hand-trap loop is
    stable)."""
    retarget = TASK_RETARGET if clutch else dataclasses.replace(TASK_RETARGET, clutch_bit=None)
    bindings = []
    for robot, primary in enumerate(primaries):
        config = retarget if primary is not None else TASK_RETARGET
        device = MouseDragDevice(robot, primary, TASK_RETARGET.motion_scale_um_per_mm, plane=config.plane)
        bindings.append(DeviceBinding(device, (robot,), retarget=config, feedback=feedback))
    return bindings
