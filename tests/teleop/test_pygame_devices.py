"""Keyboard/mouse and gamepad devices headless (SDL dummy drivers): posted events
give the expected tip velocities and buttons; a missing gamepad is a DeviceError."""

from __future__ import annotations

import os

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("SDL_AUDIODRIVER", "dummy")

import numpy as np  # noqa: E402
import pygame  # noqa: E402
import pytest  # noqa: E402

from otgym.teleop.device import DeviceError, open_device  # noqa: E402
from otgym.teleop.pygame_devices import GamepadDevice, KeyboardMouseDevice, stick_velocity_mm_s  # noqa: E402


@pytest.fixture
def keyboard():
    device = KeyboardMouseDevice(speed_mm_s=3.0, mm_per_pixel=0.05)
    device.start()
    pygame.event.clear()
    yield device
    device.stop()


def _post(kind, **attributes):
    pygame.event.post(pygame.event.Event(kind, **attributes))


def test_arrow_and_wasd_keys_give_the_configured_speed(keyboard):
    assert keyboard.read().velocity_mm_s.tolist() == [0.0, 0.0, 0.0]
    _post(pygame.KEYDOWN, key=pygame.K_RIGHT)
    np.testing.assert_allclose(keyboard.read().velocity_mm_s, [3.0, 0.0, 0.0])
    _post(pygame.KEYDOWN, key=pygame.K_s)
    np.testing.assert_allclose(keyboard.read().velocity_mm_s, [3.0 / np.sqrt(2), -3.0 / np.sqrt(2), 0.0])
    _post(pygame.KEYUP, key=pygame.K_RIGHT)
    _post(pygame.KEYUP, key=pygame.K_s)
    _post(pygame.KEYDOWN, key=pygame.K_UP)
    sample = keyboard.read()
    np.testing.assert_allclose(sample.velocity_mm_s, [0.0, 3.0, 0.0])
    later = keyboard.read()
    assert later.sequence == sample.sequence + 1 and later.position_mm[1] > sample.position_mm[1]


def test_buttons_and_focus_loss(keyboard):
    _post(pygame.KEYDOWN, key=pygame.K_SPACE)
    _post(pygame.KEYDOWN, key=pygame.K_LSHIFT)
    _post(pygame.MOUSEBUTTONDOWN, button=3, pos=(0, 0))
    assert keyboard.read().buttons == 0b1101
    _post(pygame.KEYDOWN, key=pygame.K_a)
    _post(pygame.WINDOWFOCUSLOST)
    sample = keyboard.read()
    assert sample.buttons == 0 and sample.velocity_mm_s.tolist() == [0.0, 0.0, 0.0]


def test_mouse_drag_with_left_button_moves_the_tip(keyboard):
    _post(pygame.MOUSEMOTION, rel=(40, 0), pos=(0, 0), buttons=(0, 0, 0))
    assert keyboard.read().velocity_mm_s.tolist() == [0.0, 0.0, 0.0]  # no drag without the button
    _post(pygame.MOUSEBUTTONDOWN, button=1, pos=(0, 0))
    keyboard.read()
    _post(pygame.MOUSEMOTION, rel=(20, 10), pos=(0, 0), buttons=(1, 0, 0))
    sample = keyboard.read()
    assert sample.buttons == 0b10
    vx, vy, _ = sample.velocity_mm_s
    assert vx > 0 and vy < 0 and vx == pytest.approx(-2 * vy)  # screen y down -> device y up


def test_events_fed_by_a_window_owner():
    device = KeyboardMouseDevice(speed_mm_s=3.0, pump_events=False)
    device.start()
    pygame.event.clear()
    _post(pygame.KEYDOWN, key=pygame.K_RIGHT)
    assert device.read().velocity_mm_s[0] == 0.0  # not pumped: the owner's event is left queued
    for event in pygame.event.get():
        device.handle_event(event)
    assert device.read().velocity_mm_s[0] == 3.0
    device.stop()
    assert device.read() is None


def test_missing_gamepad_lists_the_devices_found():
    with pytest.raises(DeviceError, match=r"no gamepad at index 7; found: ") as info:
        open_device("gamepad", index=7).start()
    assert "\n" not in str(info.value)
    if pygame.joystick.get_count() == 0:
        assert str(info.value).endswith("found: none")


def test_stick_mapping_dead_zone_and_flip():
    np.testing.assert_array_equal(stick_velocity_mm_s(0.1, -0.1, 0.15, 5.0), np.zeros(3))
    np.testing.assert_allclose(stick_velocity_mm_s(0.0, -1.0, 0.15, 5.0), [0.0, 5.0, 0.0])  # stick up -> device +y
    np.testing.assert_allclose(stick_velocity_mm_s(1.0, 1.0, 0.15, 5.0), [5 / np.sqrt(2), -5 / np.sqrt(2), 0.0])
    half = stick_velocity_mm_s(0.575, 0.0, 0.15, 5.0)
    np.testing.assert_allclose(half, [2.5, 0.0, 0.0])
    with pytest.raises(ValueError, match="stick"):
        GamepadDevice(stick="middle")
    with pytest.raises(ValueError, match="dead_zone"):
        GamepadDevice(dead_zone=1.0)


def test_a_device_closes_the_display_it_opened_and_leaves_a_windows_open():
    """A display left open keeps its SDL driver for the process's next window (a window
    meant for X opened with the dummy driver): what ``start`` opened, ``stop`` closes."""
    pygame.quit()
    for device in (KeyboardMouseDevice(), open_device("gamepad", index=7)):
        try:
            device.start()
        except DeviceError:  # no pad here: its start fails, and closes what it opened
            pass
        device.stop()
        assert not pygame.display.get_init(), device
    pygame.display.init()  # a window's display: the device's stop leaves it open
    try:
        device = KeyboardMouseDevice()
        device.start()
        device.stop()
        assert pygame.display.get_init()
    finally:
        pygame.quit()
