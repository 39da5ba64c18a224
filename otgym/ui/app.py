"""The window of ``otgym play``: 1280 x 720 at 60 frames per second, the global view
(left), the local microscope view (right, top) and the cues (right, below), over a
session of the interactive task (``otgym.runtime.session``).

Processes. The window only draws and forwards input; the session (its ticks, the
devices' retargeting and feedback, the recording) runs elsewhere, behind a driver with
one interface, ``otgym.runtime.protocols.SessionControl``: a ``SessionProcess``
(``otgym.runtime.worker``: its own process, what ``otgym play`` runs; why:
docs/decisions/0012-session-in-its-own-process.md), a ``BusSession`` (``otgym.ui.node``:
a sim node on the bus, what ``otgym play --distributed`` and ``otgym node ui`` run), or
a ``Session`` in this process (tests step it frame by frame).

What the window forwards: the mode keys, pause, reset, the next trial after the
questionnaires, quitting, the mouse dragging a robot (``drag``), and the samples of the
devices that live here (``window_devices``: the keyboard and the gamepad, whose events
only this window's SDL queue receives), read every frame and fed to the session.

Drawing. Each frame draws only what changed and presents only those rectangles
(``pygame.display.update(rects)``): a new snapshot redraws the moving bodies of the
global view (where they are and where they were), the local view, the cue panel and
the status line; a frame without a new snapshot redraws nothing but the frame-rate
counter twice a second. Presenting goes through the platform's framebuffer
(``SDL_FRAMEBUFFER_ACCELERATION=0``, below), not SDL's OpenGL path.

Keys (also in the help overlay, H):

=============  ===============================================================
1 / 2 / 3      manual / shared / autonomous control, at once, mid-trial
space          pause (simulated time stops; every device is sent zero force)
R              reset: abandon this trial (no row), start the next trial number
H              show or hide the help
Esc            quit (every device is sent zero force and stopped)
mouse drag     press on or near a robot in the global view and drag: its traps
               follow the pointer (a rate command through the retargeting)
arrows / WASD  keyboard device: move both robots (the formation) while held
=============  ===============================================================

After each trial its row is appended to ``out_dir/trials.csv`` (``otgym.ui.records``),
then, unless ``questionnaire=False``, the questionnaires are shown in the window and
their answers appended to ``out_dir/questionnaires.csv`` (a questionnaire left with
Esc ends the session), then the next trial starts, until Esc, the window closing, or
the session's duration spent. Quitting mid-trial saves that trial's row with
``ended_by`` ``aborted`` (no questionnaire).
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np

os.environ.setdefault("SDL_FRAMEBUFFER_ACCELERATION", "0")
"""The window's surface is presented by the platform's own framebuffer (X11: shared
memory), not through an OpenGL renderer, which without a GPU costs milliseconds of CPU
per present (docs/decisions/0047-sdl-framebuffer-present.md)."""
import pygame  # noqa: E402

from otgym.runtime.protocols import SessionControl  # noqa: E402
from otgym.teleop.device import DeviceError  # noqa: E402
from otgym.teleop.pygame_devices import KEYBOARD_EVENTS  # noqa: E402
from otgym.ui import cues, views  # noqa: E402
from otgym.ui.palette import WINDOW_SIZE  # noqa: E402
from otgym.ui.records import append_trial  # noqa: E402
from otgym.ui.views import BACKGROUND_RGB, DIM_TEXT_RGB, TEXT_RGB, CuePanel, GlobalView, LocalView, fonts  # noqa: E402

FPS = 60
MODE_KEYS = {pygame.K_1: "manual", pygame.K_2: "shared", pygame.K_3: "autonomous"}
HELP_LINES = (
    ("1 / 2 / 3", "manual / shared / autonomous control"),
    ("space", "pause / resume (devices get zero force)"),
    ("R", "reset: start the next trial"),
    ("H", "show / hide this help"),
    ("Esc", "quit"),
    ("mouse", "press on a robot in the global view and drag it"),
    ("arrows, W A S D", "keyboard: move both robots while held"),
    ("sticks + shoulders", "gamepad: left robot 0, right robot 1; hold the shoulder"),
    ("Touch button 1", "Touch: hold to move (the clutch)"),
)
GLOBAL_RECT = pygame.Rect(12, 52, 856, 620)
LOCAL_RECT = pygame.Rect(896, 52, 360, 360)
CUE_RECT = pygame.Rect(896, 428, 360, 284)
STATUS_RECT = pygame.Rect(0, 0, WINDOW_SIZE[0], 50)
FPS_TEXT_PERIOD_S = 0.5
DANGER_RGB = cues.DANGER_RGB


class PlayApp:
    """The window over ``session`` (a driver: see the module's docstring), already
    started. ``window_devices``: devices read here and fed to the session by index
    (the keyboard gets the key events); ``step``: advance an in-process ``Session`` in
    each frame (tests); ``dirty_rects``: present only what changed (False: the whole
    frame every frame)."""

    def __init__(
        self,
        session: SessionControl,
        out_dir: Path,
        *,
        window_devices=(),
        questionnaire: bool = True,
        step: bool = False,
        fps: int = FPS,
        screen: pygame.Surface | None = None,
        dirty_rects: bool = True,
    ):
        self.session = session
        self.out_dir = Path(out_dir)
        self.window_devices = list(window_devices)
        self.keyboards = [d for d in self.window_devices if hasattr(d, "handle_event")]
        self.questionnaire = questionnaire
        self.step = step
        self.fps = fps
        self.dirty_rects = dirty_rects
        pygame.display.set_caption("otgym play")  # before the window: it opens with its title
        self.screen = screen if screen is not None else pygame.display.set_mode(WINDOW_SIZE)
        self.clock = pygame.time.Clock()
        self.type = fonts()
        layout = session.layout
        self.global_view = GlobalView(layout, GLOBAL_RECT)
        self.local_view = LocalView(layout, LOCAL_RECT)
        self.cue_panel = CuePanel(layout, CUE_RECT, session.force_limits_n)
        self.running = True
        self.show_help = False
        self.drag: tuple[int, np.ndarray] | None = None
        self.frame_times_s: list[float] = []
        self.trials_written = 0
        self.frames_with_new_state = 0
        self._window_sequences: list[int | None] = [None] * len(self.window_devices)
        self._window_lost: set[int] = set()
        self._drawn_snapshot = None
        self._full_redraw = True
        self._fps_text_at_s = -np.inf
        self._fps_rect = pygame.Rect(GLOBAL_RECT.right - 150, self.global_view.rect.bottom + 10, 150, 20)

    # --- events ---------------------------------------------------------------------
    def handle_event(self, event) -> None:
        if event.type == pygame.QUIT:
            self.running = False
            return
        if event.type in (pygame.WINDOWEXPOSED, pygame.WINDOWRESTORED, pygame.WINDOWSIZECHANGED):
            self._full_redraw = True
        if event.type == pygame.KEYDOWN:
            if event.key == pygame.K_ESCAPE:
                self.running = False
            elif event.key in MODE_KEYS:
                self.session.set_mode(MODE_KEYS[event.key])
            elif event.key == pygame.K_SPACE:
                self.session.toggle_pause()
            elif event.key == pygame.K_r:
                self._release_drag()
                self.session.reset()
            elif event.key == pygame.K_h:
                self.show_help = not self.show_help
                self._full_redraw = True
        if event.type in KEYBOARD_EVENTS and event.type not in (
            pygame.MOUSEBUTTONDOWN,
            pygame.MOUSEBUTTONUP,
            pygame.MOUSEMOTION,
        ):
            for keyboard in self.keyboards:
                keyboard.handle_event(event)
        snapshot = self.session.snapshot
        if (
            event.type == pygame.MOUSEBUTTONDOWN
            and event.button == 1
            and snapshot is not None
            and self.global_view.rect.collidepoint(event.pos)
        ):
            robot = self.global_view.robot_at(snapshot, event.pos)
            if robot is not None:
                self.drag = (robot, self.global_view.to_um(event.pos))
        elif event.type == pygame.MOUSEMOTION and self.drag is not None:
            self.drag = (self.drag[0], self.global_view.to_um(event.pos))
        elif event.type == pygame.MOUSEBUTTONUP and event.button == 1:
            self._release_drag()

    def _release_drag(self) -> None:
        if self.drag is not None:
            self.drag = None
            self.session.release_drag()

    def _update_drag(self) -> None:
        snapshot = self.session.snapshot
        if self.drag is None or snapshot is None:
            return
        robot, pointer_um = self.drag
        self.session.drag(robot, pointer_um, self.global_view.trap_centre_um(snapshot, robot))

    def _forward_window_devices(self) -> None:
        """Each window device's new sample to the session (a lost one once, with the reason)."""
        for index, device in enumerate(self.window_devices):
            if index in self._window_lost:
                continue
            try:
                sample = device.read()
            except DeviceError as error:
                self._window_lost.add(index)
                self.session.lose(index, str(error))
                continue
            if sample is not None and sample.sequence != self._window_sequences[index]:
                self._window_sequences[index] = sample.sequence
                self.session.feed(index, sample)

    # --- frames ---------------------------------------------------------------------
    def frame(self) -> None:
        """One frame: events, input forwarded, (ticks when stepping), finished trials, drawing."""
        for event in pygame.event.get():
            self.handle_event(event)
        self._update_drag()
        self._forward_window_devices()
        if self.step:
            self.session.advance()
        self.session.poll()
        self._finish_trials()
        if self.session.over and self.running:
            self.running = False
        rects = self.draw()
        if rects is None or not self.dirty_rects:
            pygame.display.flip()
        elif rects:
            pygame.display.update(rects)

    def run(self) -> None:
        """Frames until Esc, the window closing, or the session's duration spent; then
        the session is finished (a trial under way saved as aborted)."""
        try:
            last = time.perf_counter()
            while self.running:
                self.frame()
                self.clock.tick(self.fps)
                now = time.perf_counter()
                self.frame_times_s.append(now - last)
                last = now
        finally:
            self.session.finish()
            self._finish_trials(ask=False)

    def _finish_trials(self, ask: bool = True) -> None:
        while (row := self.session.take_finished()) is not None:
            append_trial(self.out_dir / "trials.csv", row)
            self.trials_written += 1
            if not ask or row["ended_by"] == "aborted":
                continue
            if self.questionnaire and not self._ask(row):
                self.running = False
                return
            self._full_redraw = True  # the form covered the window
            self.session.next_trial()

    def _ask(self, row: dict) -> bool:
        """The questionnaires in this window; False when the person left them with Esc."""
        from otgym.study.questionnaires import append_answers
        from otgym.ui.questionnaire import run_questionnaire

        answers = run_questionnaire(
            self.screen, self.clock, row["participant"], row["mode"], row["trial"], weighted=False, fps=self.fps
        )
        if answers is None:
            return False
        append_answers(self.out_dir / "questionnaires.csv", answers)
        return True

    # --- drawing --------------------------------------------------------------------
    def draw(self) -> list[pygame.Rect] | None:
        """Draw what changed since the last frame; the rectangles to present (None: the
        whole window)."""
        snapshot = self.session.snapshot
        if snapshot is None:  # the whole window says so until the first snapshot, which redraws it all
            self.screen.fill(BACKGROUND_RGB)
            self._text("waiting for the simulator ...", (40, 40), TEXT_RGB, "title")
            self._full_redraw = True
            return None
        now = time.monotonic()
        rendered = self.local_view.update(snapshot, now)
        fresh = snapshot is not self._drawn_snapshot
        self.frames_with_new_state += fresh
        full = self._full_redraw or self.show_help
        rects: list[pygame.Rect] = []
        if full:
            self.screen.fill(BACKGROUND_RGB)
            self._draw_legend()
        if full or fresh or self.drag is not None:
            rects += self.global_view.draw(self.screen, snapshot, self.drag)
        if full or fresh or rendered:
            rects += self.local_view.draw(self.screen, snapshot, self.type["small"])
        if full or fresh:
            rects += self.cue_panel.draw(self.screen, snapshot, self.type)
            rects.append(self._draw_status(snapshot))
        if full or now - self._fps_text_at_s >= FPS_TEXT_PERIOD_S:
            self._fps_text_at_s = now
            rects.append(self._draw_fps())
        self._drawn_snapshot = snapshot
        if self.show_help:
            self._draw_help()
        if full:
            self._full_redraw = False
            return None
        return rects

    def _text(self, s: str, pos, rgb=TEXT_RGB, size: str = "body") -> pygame.Rect:
        return self.screen.blit(self.type[size].render(s, True, rgb), pos)

    def _draw_status(self, snapshot) -> pygame.Rect:
        """The status line (participant, trial, time, obstacles; pause; a lost device or
        autonomy) and the local view's caption, over a cleared strip."""
        self.screen.fill(BACKGROUND_RGB, STATUS_RECT)
        avoided, encountered = cues.obstacle_tally(snapshot.encountered, snapshot.collided)
        self._text("otgym play", (12, 12), TEXT_RGB, "title")
        self._text(
            f"participant {self.session.participant}    trial {snapshot.trial}    "
            f"time {cues.format_elapsed(snapshot.time_s)}    obstacles avoided {avoided} / {encountered}",
            (150, 16),
        )
        if snapshot.paused:
            self._text("PAUSED (space)", (700, 14), (250, 180, 30), "title")
        warnings = cues.loss_warnings(
            self._lost_devices(snapshot),
            snapshot.autonomy_live,
            snapshot.mode,
            getattr(self.session, "simulator_live", True),
        )
        if warnings:
            self._text("    ".join(warnings), (880, 8), DANGER_RGB, "body")
        self._text("microscope, around the cell", (LOCAL_RECT.left, LOCAL_RECT.top - 20), DIM_TEXT_RGB, "small")
        return STATUS_RECT

    def _lost_devices(self, snapshot) -> tuple[str, ...]:
        lost = getattr(self.session, "lost_devices", None)
        return tuple(lost) if lost is not None else snapshot.lost_devices

    def _draw_legend(self) -> None:
        legend = ("route", "robots", "traps +", "cell", "obstacles (arrow: next 3 s)", "flow")
        colours = (views.ROUTE_RGB, views.ROBOT_RGB, views.TRAP_RGB, views.CELL_RGB, views.OBSTACLE_RGB, views.FLOW_RGB)
        x = 12
        y = self.global_view.rect.bottom + 10
        for name, rgb in zip(legend, colours):
            pygame.draw.circle(self.screen, rgb, (x + 6, y + 8), 6)
            label = self.type["small"].render(name, True, DIM_TEXT_RGB)
            self.screen.blit(label, (x + 16, y + 1))
            x += label.get_width() + 34

    def _draw_fps(self) -> pygame.Rect:
        self.screen.fill(BACKGROUND_RGB, self._fps_rect)
        self._text(f"{self.clock.get_fps():4.0f} fps    H: help", self._fps_rect.topleft, DIM_TEXT_RGB, "small")
        return self._fps_rect

    def _draw_help(self) -> None:
        box = pygame.Rect(0, 0, 700, 60 + 30 * len(HELP_LINES))
        box.center = self.screen.get_rect().center
        overlay = pygame.Surface(box.size, pygame.SRCALPHA)
        overlay.fill((10, 12, 16, 235))
        self.screen.blit(overlay, box.topleft)
        pygame.draw.rect(self.screen, DIM_TEXT_RGB, box, 1, border_radius=6)
        self.screen.blit(self.type["title"].render("Keys", True, TEXT_RGB), (box.left + 20, box.top + 16))
        for index, (key, meaning) in enumerate(HELP_LINES):
            y = box.top + 52 + 30 * index
            self.screen.blit(self.type["body"].render(key, True, (250, 215, 30)), (box.left + 20, y))
            self.screen.blit(self.type["body"].render(meaning, True, TEXT_RGB), (box.left + 220, y))

    def save_screenshot(self, path: Path) -> None:
        pygame.image.save(self.screen, str(path))
