"""Each play device's binding comes from its registry entry (``play_binding``): a
device a user registers drives the robots as its entry says, with nothing else to
edit; one without a binding is opened in the session's process for robot 0."""

import pytest

from otgym import registry
from otgym.ui import bindings


class FakePad:
    """A stand-in driver that records the options it was opened with."""

    def __init__(self, **options):
        self.options = options


@pytest.fixture
def registered():
    added = []

    def add(name, **extras):
        registry.register("devices", name, f"{__name__}:FakePad", "a test pad", tags=("play", "driver"), **extras)
        added.append(name)

    yield add
    for name in added:
        registry.unregister("devices", name)


def test_a_registered_device_drives_the_robots_as_its_binding_says(registered):
    registered("test-pad", play_binding="otgym.ui.bindings:A_STICK_EACH")
    windowed = bindings.window_devices("test-pad")
    assert [d.options["stick"] for d in windowed] == ["left", "right"]
    assert bindings.robot_primaries("test-pad", windowed) == (windowed[0], windowed[1])
    registered("test-keys", play_binding="otgym.ui.bindings:ONE_WINDOW_DEVICE_FOR_BOTH")
    keys = bindings.window_devices("test-keys")
    assert len(keys) == 1 and bindings.robot_primaries("test-keys", keys) == (keys[0], keys[0])
    assert not bindings.play_binding("test-keys").clutch and bindings.play_binding("test-pad").clutch


def test_a_device_without_a_binding_is_robot_0s_in_the_session(registered):
    registered("test-stylus")
    assert bindings.window_devices("test-stylus") == []
    first, second = bindings.robot_primaries("test-stylus", [])
    assert isinstance(first, FakePad) and first.options == {} and second is None


def test_the_shipped_devices_bindings(registered):
    assert bindings.play_binding("keyboard") is bindings.ONE_WINDOW_DEVICE_FOR_BOTH
    assert bindings.play_binding("gamepad") is bindings.A_STICK_EACH
    assert bindings.play_binding("touch") is bindings.A_DEVICE_EACH_BY_NAME
    assert bindings.play_binding("simulated") is bindings.ROBOT_0_ONLY
    assert bindings.window_devices("mouse") == []  # the window's mouse alone: no device to open
    with pytest.raises(ValueError, match="unknown device 'joystick'"):
        bindings.window_devices("joystick")
