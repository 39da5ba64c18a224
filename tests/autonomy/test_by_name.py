"""A lab's own navigator, registered by name, is the one the autonomy node and
``otgym play`` build (``otgym.autonomy.by_name``), not the route navigator in its
place; every built-in one offers the same ``for_task``."""

from __future__ import annotations

import types

import numpy as np
import pytest

from otgym import registry
from otgym.autonomy.by_name import navigator_for


class StillNavigator:
    """Holds every trap still; remembers how it was built and whether it warmed up."""

    def __init__(self, task, max_speed_um_s):
        self.task, self.max_speed_um_s, self.warmed = task, max_speed_um_s, False

    @classmethod
    def for_task(cls, task, max_speed_um_s: float = 20.0):
        return cls(task, max_speed_um_s)

    def warm_up(self) -> None:
        self.warmed = True

    def reset(self, n_env: int) -> None:
        pass

    def increments(self, obs):
        return np.zeros((1, 4, 2))


@pytest.fixture
def still():
    registry.register("navigators", "still", f"{__name__}:StillNavigator", "holds the traps", tags=("in-process",))
    yield
    registry.unregister("navigators", "still")


def test_a_registered_navigator_is_built_on_the_task_and_warmed_up(still):
    task = types.SimpleNamespace(name="a task")
    navigator = navigator_for("still", task, max_speed_um_s=12.0)
    assert isinstance(navigator, StillNavigator)
    assert navigator.task is task and navigator.max_speed_um_s == 12.0 and navigator.warmed


def test_an_unknown_navigator_is_one_line_naming_the_choices():
    with pytest.raises(ValueError, match="route") as error:
        navigator_for("nowhere", types.SimpleNamespace())
    assert "\n" not in str(error.value)


@pytest.mark.parametrize("name", registry.names("navigators"))
def test_every_built_in_navigator_offers_for_task(name):
    assert callable(getattr(registry.entry("navigators", name).load(), "for_task", None)), name


@pytest.mark.slow
def test_play_runs_a_registered_in_process_navigator_as_the_sessions_autonomy(still, tmp_path):
    """``otgym play --navigator still``: the worker's setup gives the session the
    registered navigator (before, any navigator but the learned speed ran as the route
    navigator)."""
    from otgym.teleop.device import start_devices
    from otgym.ui.bindings import window_devices
    from otgym.ui.play_worker import play_setup

    windowed = window_devices("keyboard")
    start_devices(windowed)
    parts = play_setup(
        "default", "keyboard", tmp_path / "still.mcap", windowed, lambda payload: None, navigator="still"
    )
    try:
        assert isinstance(parts.autonomy.navigator, StillNavigator) and parts.autonomy.navigator.warmed
    finally:
        parts.on_failure()  # the recording never started: none is left behind
        for device in windowed:  # the keyboard's start opened SDL's display; its stop closes it
            device.stop()
