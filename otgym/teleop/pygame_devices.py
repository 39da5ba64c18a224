"""Keyboard/mouse and gamepad devices through pygame-ce (SDL2).

Both are rate devices: their input sets a tip velocity, and the tip position is its
integral (a virtual stylus starting at the origin). They sample when read: every
``read()`` makes a new sample. Neither opens a window. The window owner (the program's
event loop) either passes each event it polls to ``handle_event`` (construct with
``pump_events=False``), or leaves ``pump_events=True`` and each ``read()`` drains the
queue of the event types this device uses, leaving all other events queued.
Keyboard and mouse events reach SDL only through a focused window; headless
(``SDL_VIDEODRIVER=dummy``) events can be posted to the queue.

Keyboard and mouse map (device frame: x right, y up):

================================  ==============================================
arrows or W A S D                 tip velocity ``speed_mm_s`` along device +y, -x,
                                  -y, +x (diagonals have the same speed)
mouse motion, left button held    tip velocity = pixel motion * ``mm_per_pixel``
                                  per elapsed time (screen y down -> device -y)
space                             button bit 0 (the clutch of the default retargeter)
left mouse button                 bit 1
right mouse button                bit 2
shift (either)                    bit 3
================================  ==============================================

Losing the window's focus releases every key and button (a key released outside the
window sends no KEYUP).

Gamepad (any SDL game controller: Xbox, PlayStation, Switch Pro...): one stick gives
the tip velocity, radial dead zone ``dead_zone`` then rescaled so full deflection is
``speed_mm_s``; buttons: bit 0 the shoulder button on the stick's side (the clutch),
bits 1-4 the face buttons A, B, X, Y (south, east, west, north). Two instances on the
same pad, ``stick="left"`` and ``stick="right"``, steer two robots.
"""

from __future__ import annotations

import math
import os
import time

import numpy as np

from otgym.teleop.device import Device, DeviceCaps, DeviceError, Sample

os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
import pygame  # noqa: E402  (after silencing its banner)
from pygame._sdl2 import controller  # noqa: E402

KEY_DIRECTIONS = {
    pygame.K_RIGHT: (1.0, 0.0),
    pygame.K_d: (1.0, 0.0),
    pygame.K_LEFT: (-1.0, 0.0),
    pygame.K_a: (-1.0, 0.0),
    pygame.K_UP: (0.0, 1.0),
    pygame.K_w: (0.0, 1.0),
    pygame.K_DOWN: (0.0, -1.0),
    pygame.K_s: (0.0, -1.0),
}
KEY_BITS = {pygame.K_SPACE: 0, pygame.K_LSHIFT: 3, pygame.K_RSHIFT: 3}
MOUSE_BITS = {1: 1, 3: 2}  # pygame mouse buttons: 1 left, 3 right
KEYBOARD_EVENTS = (
    pygame.KEYDOWN,
    pygame.KEYUP,
    pygame.MOUSEBUTTONDOWN,
    pygame.MOUSEBUTTONUP,
    pygame.MOUSEMOTION,
    pygame.WINDOWFOCUSLOST,
)
GAMEPAD_EVENTS = (
    pygame.CONTROLLERAXISMOTION,
    pygame.CONTROLLERBUTTONDOWN,
    pygame.CONTROLLERBUTTONUP,
    pygame.CONTROLLERDEVICEADDED,
    pygame.CONTROLLERDEVICEREMOVED,
    pygame.JOYAXISMOTION,
    pygame.JOYBUTTONDOWN,
    pygame.JOYBUTTONUP,
    pygame.JOYHATMOTION,
    pygame.JOYDEVICEADDED,
    pygame.JOYDEVICEREMOVED,
)
STICKS = {
    "left": (pygame.CONTROLLER_AXIS_LEFTX, pygame.CONTROLLER_AXIS_LEFTY, pygame.CONTROLLER_BUTTON_LEFTSHOULDER),
    "right": (pygame.CONTROLLER_AXIS_RIGHTX, pygame.CONTROLLER_AXIS_RIGHTY, pygame.CONTROLLER_BUTTON_RIGHTSHOULDER),
}
FACE_BUTTONS = (
    pygame.CONTROLLER_BUTTON_A,
    pygame.CONTROLLER_BUTTON_B,
    pygame.CONTROLLER_BUTTON_X,
    pygame.CONTROLLER_BUTTON_Y,
)
AXIS_FULL_SCALE = 32767.0
RATE_DEVICE_WORKSPACE_MM = (160.0, 120.0, 70.0)
"""Nominal extent of the virtual stylus (a Touch's), for consumers that normalise by it."""


def _require_pos(name: str, value: float) -> float:
    if not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
        raise ValueError(f"{name} must be positive and finite, got {value!r}")
    return float(value)


def _init_events(what: str) -> bool:
    """SDL's event queue lives in its video subsystem: initialise it when no window has.
    True when this call did, so that the device's ``stop`` closes what its ``start``
    opened (a display left open keeps its driver for the next window in the process)."""
    if pygame.display.get_init():
        return False
    try:
        pygame.display.init()
    except pygame.error as error:
        raise DeviceError(
            f"{what} needs a pygame display ({error}); set SDL_VIDEODRIVER=dummy to run without a screen"
        ) from None
    return True


def _quit_events(opened: bool) -> None:
    """Close the display ``_init_events`` opened (``opened``); leave a window's alone."""
    if opened and pygame.display.get_init():
        pygame.display.quit()


class _RateDevice(Device):
    """A virtual stylus whose velocity the subclass sets; integrates its position."""

    def __init__(self, caps: DeviceCaps, pump_events: bool):
        self.caps = caps
        self.pump_events = bool(pump_events)
        self._position_mm = np.zeros(3)
        self._sequence = 0
        self._last_s: float | None = None
        self._opened_display = False  # whether start opened SDL's display (stop closes it)

    def _sample(self, velocity_mm_s: np.ndarray, buttons: int, now_s: float) -> Sample:
        self._position_mm = self._position_mm + velocity_mm_s * (now_s - self._last_s)
        self._last_s = now_s
        self._sequence += 1
        return Sample(now_s, self._sequence, self._position_mm, velocity_mm_s, buttons)


class KeyboardMouseDevice(_RateDevice):
    """Keyboard and mouse as a velocity device (map in the module docstring).

    speed_mm_s: key speed (default 2 mm/s: 4 um/s at the trap with the default motion
    scale, the demo's transport speed); mm_per_pixel: mouse drag scale (default 0.02:
    a drag at 100 pixels/s is 2 mm/s)."""

    def __init__(self, speed_mm_s: float = 2.0, mm_per_pixel: float = 0.02, pump_events: bool = True):
        super().__init__(DeviceCaps("keyboard and mouse", 2, 0.0, RATE_DEVICE_WORKSPACE_MM, 60.0), pump_events)
        self.speed_mm_s = _require_pos("speed_mm_s", speed_mm_s)
        self.mm_per_pixel = _require_pos("mm_per_pixel", mm_per_pixel)
        self._release_all()

    def _release_all(self) -> None:
        self._keys: set[int] = set()
        self._key_bits: dict[int, int] = {}
        self._mouse_bits = 0
        self._drag_px = np.zeros(2)

    def start(self) -> None:
        self._opened_display = _init_events("keyboard and mouse input") or self._opened_display
        self._release_all()
        self._last_s = time.monotonic()

    def stop(self) -> None:
        self._last_s = None
        self._release_all()
        _quit_events(self._opened_display)
        self._opened_display = False

    def handle_event(self, event) -> None:
        """Update the key, button and drag state from one pygame event."""
        if event.type == pygame.KEYDOWN:
            if event.key in KEY_DIRECTIONS:
                self._keys.add(event.key)
            if event.key in KEY_BITS:
                self._key_bits[event.key] = KEY_BITS[event.key]
        elif event.type == pygame.KEYUP:
            self._keys.discard(event.key)
            self._key_bits.pop(event.key, None)
        elif event.type == pygame.MOUSEBUTTONDOWN and event.button in MOUSE_BITS:
            self._mouse_bits |= 1 << MOUSE_BITS[event.button]
        elif event.type == pygame.MOUSEBUTTONUP and event.button in MOUSE_BITS:
            self._mouse_bits &= ~(1 << MOUSE_BITS[event.button])
        elif event.type == pygame.MOUSEMOTION and self._mouse_bits & (1 << MOUSE_BITS[1]):
            self._drag_px += np.asarray(event.rel, dtype=float)
        elif event.type == pygame.WINDOWFOCUSLOST:
            self._release_all()

    def pump(self) -> None:
        """Drain this device's event types from pygame's queue into ``handle_event``."""
        for event in pygame.event.get(eventtype=KEYBOARD_EVENTS):
            self.handle_event(event)

    def read(self) -> Sample | None:
        if self._last_s is None:
            return None
        if self.pump_events:
            self.pump()
        now = time.monotonic()
        direction = np.sum([KEY_DIRECTIONS[key] for key in self._keys], axis=0) if self._keys else np.zeros(2)
        norm = float(np.linalg.norm(direction))
        velocity = np.zeros(3)
        if norm > 0:
            velocity[:2] = self.speed_mm_s * direction / norm
        elapsed = now - self._last_s
        if elapsed > 0:
            velocity[:2] += self.mm_per_pixel * np.array([self._drag_px[0], -self._drag_px[1]]) / elapsed
        self._drag_px = np.zeros(2)
        buttons = self._mouse_bits
        for bit in self._key_bits.values():
            buttons |= 1 << bit
        return self._sample(velocity, buttons, now)


def stick_velocity_mm_s(x: float, y: float, dead_zone: float, speed_mm_s: float) -> np.ndarray:
    """(3,) device velocity from a stick at (x right, y down) in [-1, 1]: zero within the
    radial ``dead_zone``, then rising linearly to ``speed_mm_s`` at full deflection."""
    stick = np.array([x, -y], dtype=float)
    radius = float(np.linalg.norm(stick))
    if radius <= dead_zone:
        return np.zeros(3)
    magnitude = speed_mm_s * min((radius - dead_zone) / (1.0 - dead_zone), 1.0)
    return np.array([*(stick / radius * magnitude), 0.0])


class GamepadDevice(_RateDevice):
    """One stick of the game controller at ``index`` (SDL's numbering) as a velocity
    device (map in the module docstring). speed_mm_s: tip speed at full deflection
    (default 5 mm/s: 10 um/s, the default trap speed clamp, with the default motion
    scale); dead_zone: fraction of full deflection ignored (default 0.15, covering the
    rest drift of worn sticks)."""

    def __init__(
        self,
        index: int = 0,
        stick: str = "left",
        speed_mm_s: float = 5.0,
        dead_zone: float = 0.15,
        pump_events: bool = True,
    ):
        if stick not in STICKS:
            raise ValueError(f"stick must be one of {tuple(STICKS)}, got {stick!r}")
        if not isinstance(index, int) or index < 0:
            raise ValueError(f"index must be a non-negative integer, got {index!r}")
        if not isinstance(dead_zone, (int, float)) or not 0 <= dead_zone < 1:
            raise ValueError(f"dead_zone must be within [0, 1), got {dead_zone!r}")
        super().__init__(
            DeviceCaps(f"gamepad {index} ({stick} stick)", 2, 0.0, RATE_DEVICE_WORKSPACE_MM, 60.0), pump_events
        )
        self.index = index
        self.stick = stick
        self.speed_mm_s = _require_pos("speed_mm_s", speed_mm_s)
        self.dead_zone = float(dead_zone)
        self._pad = None

    def start(self) -> None:
        """Open the controller; DeviceError naming the pads found when there is none."""
        if self._pad is not None:
            return
        self._opened_display = _init_events("gamepad input") or self._opened_display
        try:
            pygame.joystick.init()
            controller.init()
            names = [pygame.joystick.Joystick(i).get_name() for i in range(pygame.joystick.get_count())]
            found = ", ".join(f"{i}: {name}" for i, name in enumerate(names)) or "none"
            if self.index >= len(names):
                raise DeviceError(f"no gamepad at index {self.index}; found: {found}")
            if not controller.is_controller(self.index):
                raise DeviceError(
                    f"device {self.index} ({names[self.index]}) is not a game controller SDL knows; found: {found}"
                )
        except DeviceError:
            self.stop()
            raise
        self._pad = controller.Controller(self.index)
        self._last_s = time.monotonic()

    def stop(self) -> None:
        if self._pad is not None:
            self._pad.quit()
        self._pad = None
        self._last_s = None
        _quit_events(self._opened_display)
        self._opened_display = False

    def read(self) -> Sample | None:
        """The latest stick state; DeviceError when the pad was unplugged."""
        if self._pad is None:
            return None
        if self.pump_events:
            pygame.event.get(eventtype=GAMEPAD_EVENTS)
        if not self._pad.attached():
            raise DeviceError(f"gamepad {self.index} was disconnected")
        axis_x, axis_y, shoulder = STICKS[self.stick]
        x = max(-1.0, self._pad.get_axis(axis_x) / AXIS_FULL_SCALE)
        y = max(-1.0, self._pad.get_axis(axis_y) / AXIS_FULL_SCALE)
        buttons = int(self._pad.get_button(shoulder))
        for bit, button in enumerate(FACE_BUTTONS, start=1):
            buttons |= int(self._pad.get_button(button)) << bit
        return self._sample(stick_velocity_mm_s(x, y, self.dead_zone, self.speed_mm_s), buttons, time.monotonic())
