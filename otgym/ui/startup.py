"""The window of ``otgym play`` while its simulation starts: it opens at once and says
what the simulation process is doing (building the task, compiling) and for how long,
instead of leaving the user with no window for the 10-20 s of a first compile.

``wait_in_window(screen, start, title)`` runs ``start()`` (e.g. ``SessionProcess.start``)
in a thread and draws the start-up screen on ``screen`` until it returns; the latest
status comes from ``StartupStatus.set`` (the worker's ``status`` events). Closing the
window or pressing Esc while it waits raises ``StartupAborted`` once ``start`` has
returned (a half-started worker is never left behind)."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

import pygame

from otgym.ui.palette import BACKGROUND_RGB, DIM_TEXT_RGB, TEXT_RGB, fonts

FRAME_S = 1 / 30
"""The start-up screen's frame period: enough for a moving spinner, little CPU."""


class StartupAborted(Exception):
    """The user closed the window before the simulation was ready."""


class StartupStatus:
    """The latest status line, set from any thread."""

    def __init__(self, text: str = "starting the simulation process"):
        self._lock = threading.Lock()
        self._text = text

    def set(self, text: str) -> None:
        with self._lock:
            self._text = text

    @property
    def text(self) -> str:
        with self._lock:
            return self._text


def draw_startup(screen: pygame.Surface, type_: dict, title: str, status: str, elapsed_s: float) -> None:
    """One frame of the start-up screen (``type_``: ``palette.fonts()``): the title, the
    status, the seconds waited and a spinner, centred."""
    screen.fill(BACKGROUND_RGB)
    width, height = screen.get_size()
    lines = [
        (type_["prompt"], title, TEXT_RGB),
        (type_["body"], f"{status} ...", TEXT_RGB),
        (type_["small"], f"{elapsed_s:4.0f} s   (Esc or closing the window stops)", DIM_TEXT_RGB),
    ]
    y = height // 2 - 60
    for font, text, rgb in lines:
        surface = font.render(text, True, rgb)
        screen.blit(surface, surface.get_rect(midtop=(width // 2, y)))
        y += surface.get_height() + 14
    angle = 2 * 3.14159 * (elapsed_s % 1.0)
    centre = pygame.Vector2(width // 2, y + 30)
    for k in range(8):  # a ring of dots, the brightest one turning once a second
        offset = pygame.Vector2(18, 0).rotate_rad(angle - k * 0.6)
        shade = max(60, 255 - 25 * k)
        pygame.draw.circle(screen, (shade, shade, shade), centre + offset, 4)
    pygame.display.flip()


def wait_in_window(screen: pygame.Surface, start: Callable[[], None], title: str, status: StartupStatus) -> None:
    """Run ``start()`` in a thread, drawing the start-up screen until it returns; its
    exception is raised here. StartupAborted if the user closed the window meanwhile."""
    failure: list[BaseException] = []

    def run() -> None:
        try:
            start()
        except BaseException as error:  # noqa: BLE001  re-raised in the window's thread
            failure.append(error)

    thread = threading.Thread(target=run, name="otgym-start", daemon=True)
    type_ = fonts()
    began = time.monotonic()
    thread.start()
    aborted = False
    while thread.is_alive():
        for event in pygame.event.get():
            if event.type == pygame.QUIT or (event.type == pygame.KEYDOWN and event.key == pygame.K_ESCAPE):
                aborted = True
        draw_startup(screen, type_, title, "stopping" if aborted else status.text, time.monotonic() - began)
        thread.join(FRAME_S)
    if failure:
        raise failure[0]
    if aborted:
        raise StartupAborted("closed before the simulation was ready")
