"""The start-up screen of ``otgym play`` (``otgym.ui.startup``), headless (SDL's dummy
drivers): the window shows the status the starting thread sets, hands back the start's
error, and stops on Esc. Every wait is for an event (a frame drawn with a given status),
under a generous deadline; nothing is timed."""

from __future__ import annotations

import os
import threading

os.environ["SDL_VIDEODRIVER"] = "dummy"
os.environ["SDL_AUDIODRIVER"] = "dummy"

import pygame  # noqa: E402
import pytest  # noqa: E402

from otgym.ui import startup  # noqa: E402

DEADLINE_S = 60.0


@pytest.fixture
def screen():
    pygame.init()
    yield pygame.display.set_mode((320, 240))
    pygame.quit()


@pytest.fixture
def drawn(monkeypatch):
    """The statuses of the frames drawn, and an event per status once a frame showed it."""
    shown: list[str] = []
    seen: dict[str, threading.Event] = {}
    real = startup.draw_startup

    def draw(screen, type_, title, status, elapsed_s):
        real(screen, type_, title, status, elapsed_s)
        shown.append(status)
        seen.setdefault(status, threading.Event()).set()

    monkeypatch.setattr(startup, "draw_startup", draw)

    def wait_for(status: str) -> bool:
        return seen.setdefault(status, threading.Event()).wait(DEADLINE_S)

    return shown, wait_for


def test_the_window_shows_each_status_the_start_sets_and_returns_when_it_is_done(screen, drawn):
    """Fails if the screen kept its first text, or returned before the start finished."""
    shown, wait_for = drawn
    status = startup.StartupStatus("starting the simulation process")
    finished = []

    def start():
        assert wait_for("starting the simulation process")
        status.set("compiling the simulation")
        assert wait_for("compiling the simulation")
        finished.append(True)

    startup.wait_in_window(screen, start, "otgym play", status)
    assert finished == [True]
    assert shown[0] == "starting the simulation process" and "compiling the simulation" in shown
    assert shown.index("compiling the simulation") > 0


def test_an_error_in_the_start_is_raised_in_the_windows_thread(screen, drawn):
    def start():
        raise ValueError("no chip named 'nochip'")

    with pytest.raises(ValueError, match="nochip"):
        startup.wait_in_window(screen, start, "otgym play", startup.StartupStatus())


@pytest.mark.parametrize(
    "event",
    [
        pygame.event.Event(pygame.KEYDOWN, key=pygame.K_ESCAPE, mod=0, unicode="", scancode=0),
        pygame.event.Event(pygame.QUIT),
    ],
    ids=["escape", "close"],
)
def test_escape_or_closing_the_window_stops_the_start_up(screen, drawn, event):
    """The window says it is stopping and, once the start returns, raises StartupAborted
    (the caller then ends the worker); without the key it would return normally."""
    _, wait_for = drawn
    status = startup.StartupStatus("compiling the simulation")

    def start():
        assert wait_for("compiling the simulation")
        pygame.event.post(event)
        assert wait_for("stopping")

    with pytest.raises(startup.StartupAborted):
        startup.wait_in_window(screen, start, "otgym play", status)
