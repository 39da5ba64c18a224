"""The window of ``otgym play``: 1280 x 720 at 60 frames per second, the global view
(left), the local microscope view (right, top) and the cues (right, below), over the
real-time simulation (``otgym.ui.simulation``).

Frames and ticks. The window draws at ``FPS`` (pygame's ``Clock.tick``); the
simulation ticks at 50 Hz by the wall clock. By default the simulation runs in a
thread of its own (``threaded=True``). Measured with ``benchmarks/ui_fps.py`` on this
project's 2-core machine with other jobs beside it (load average 4-5), headless: a
tick takes 12-17 ms of its 20 ms and a frame's drawing about 2-3 ms (plus a 3.4 ms
microscope render at 25 Hz). A frame loop that also ran the ticks (a fixed-step
accumulator: run the ticks due, then draw) gave 16 fps p50 and a real-time factor of
0.57, since each frame with a tick in it waits for the whole tick; with the ticks in
their own thread, whose XLA and numpy work releases the interpreter lock, the window
drew 59 fps p50 at a real-time factor of 0.80 (the simulation alone, nothing drawn:
0.90 under the same load). Under Xvfb the flip itself costs about 9 ms (a software X
server on the same two cores), and the threaded window fell to 22 fps: see
benchmarks/README.md.

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
Esc ends the session), then the next trial starts, until Esc or the simulation's
duration is spent.
"""

from __future__ import annotations

import functools
import time
from pathlib import Path

import numpy as np
import pygame

from otgym.teleop.pygame_devices import KEYBOARD_EVENTS
from otgym.ui import cues, views
from otgym.ui.mouse_device import MouseDragDevice
from otgym.ui.records import append_trial
from otgym.ui.simulation import Simulation
from otgym.ui.views import DIM_TEXT_RGB, TEXT_RGB, BACKGROUND_RGB, CuePanel, GlobalView, LocalView, fonts

WINDOW_SIZE = (1280, 720)
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


class PlayApp:
    """The window over ``simulation`` (already started); ``keyboard``: the keyboard
    device to feed key events to (None: no keyboard device)."""

    def __init__(self, simulation: Simulation, out_dir: Path, *, keyboard=None, questionnaire: bool = True,
                 threaded: bool = True, fps: int = FPS, screen: pygame.Surface | None = None):
        self.simulation = simulation
        self.task = simulation.task
        self.out_dir = Path(out_dir)
        self.keyboard = keyboard
        self.questionnaire = questionnaire
        self.threaded = threaded
        self.fps = fps
        self.screen = screen if screen is not None else pygame.display.set_mode(WINDOW_SIZE)
        pygame.display.set_caption("otgym play")
        self.clock = pygame.time.Clock()
        self.type = fonts()
        self.global_view = GlobalView(self.task, GLOBAL_RECT)
        self.local_view = LocalView(self.task, LOCAL_RECT, simulation.loop.sphere_radius_um)
        self.drag_devices = [b.device for b in simulation.bindings if isinstance(b.device, MouseDragDevice)]
        self.cue_panel = CuePanel(self.task, CUE_RECT, [b.device.caps.force_limit_n for b in simulation.bindings])
        self.running = True
        self.show_help = False
        self.drag: tuple[int, np.ndarray] | None = None
        self.frame_times_s: list[float] = []
        self.trials_written = 0

    # --- events ---------------------------------------------------------------------
    def handle_event(self, event) -> None:
        if event.type == pygame.QUIT:
            self.running = False
            return
        if event.type == pygame.KEYDOWN:
            if event.key == pygame.K_ESCAPE:
                self.running = False
            elif event.key in MODE_KEYS:
                self.simulation.set_mode(MODE_KEYS[event.key])
            elif event.key == pygame.K_SPACE:
                self.simulation.toggle_pause()
            elif event.key == pygame.K_r:
                self._release_drag()
                self.simulation.reset()
            elif event.key == pygame.K_h:
                self.show_help = not self.show_help
        if self.keyboard is not None and event.type in KEYBOARD_EVENTS and event.type not in (
                pygame.MOUSEBUTTONDOWN, pygame.MOUSEBUTTONUP, pygame.MOUSEMOTION):
            self.simulation.post(functools.partial(self.keyboard.handle_event, event))
        if event.type == pygame.MOUSEBUTTONDOWN and event.button == 1 and self.global_view.rect.collidepoint(event.pos):
            robot = self.global_view.robot_at(self.simulation.snapshot, event.pos)
            if robot is not None:
                self.drag = (robot, self.global_view.to_um(event.pos))
        elif event.type == pygame.MOUSEMOTION and self.drag is not None:
            self.drag = (self.drag[0], self.global_view.to_um(event.pos))
        elif event.type == pygame.MOUSEBUTTONUP and event.button == 1:
            self._release_drag()

    def _release_drag(self) -> None:
        self.drag = None
        for device in self.drag_devices:
            device.release()

    def _update_drag(self) -> None:
        if self.drag is None:
            return
        robot, pointer_um = self.drag
        for device in self.drag_devices:
            if device.robot == robot:
                device.drag_to(pointer_um, self.global_view.trap_centre_um(self.simulation.snapshot, robot))

    # --- frames ---------------------------------------------------------------------
    def frame(self) -> None:
        """One frame: events, (ticks when not threaded), finished trials, drawing."""
        for event in pygame.event.get():
            self.handle_event(event)
        self._update_drag()
        if not self.threaded:
            self.simulation.advance()
        self._finish_trials()
        if self.simulation.over and self.running:
            self.running = False
        self.draw()
        pygame.display.flip()

    def run(self) -> None:
        """Frames until Esc, the window closing, or the session's duration spent."""
        if self.threaded:
            self.simulation.start_thread()
        try:
            last = time.perf_counter()
            while self.running:
                self.frame()
                self.clock.tick(self.fps)
                now = time.perf_counter()
                self.frame_times_s.append(now - last)
                last = now
        finally:
            self.simulation.stop_thread()

    def _finish_trials(self) -> None:
        row = self.simulation.take_finished()
        if row is None:
            return
        append_trial(self.out_dir / "trials.csv", row)
        self.trials_written += 1
        if self.questionnaire and not self._ask(row):
            self.running = False
            return
        self.simulation.next_trial()

    def _ask(self, row: dict) -> bool:
        """The questionnaires in this window; False when the person left them with Esc."""
        from otgym.study.questionnaires import append_answers
        from otgym.ui.questionnaire import run_questionnaire

        answers = run_questionnaire(self.screen, self.clock, row["participant"], row["mode"], row["trial"],
                                    weighted=False, fps=self.fps)
        if answers is None:
            return False
        append_answers(self.out_dir / "questionnaires.csv", answers)
        return True

    # --- drawing --------------------------------------------------------------------
    def draw(self) -> None:
        snapshot = self.simulation.snapshot
        screen = self.screen
        screen.fill(BACKGROUND_RGB)
        self.global_view.draw(screen, snapshot, self.drag)
        self.local_view.update(snapshot, time.monotonic())
        self.local_view.draw(screen, snapshot, self.type["small"])
        self.cue_panel.draw(screen, snapshot, self.type)
        self._draw_status(snapshot)
        if self.show_help:
            self._draw_help()

    def _draw_status(self, snapshot) -> None:
        text = lambda s, pos, rgb=TEXT_RGB, size="body": self.screen.blit(  # noqa: E731
            self.type[size].render(s, True, rgb), pos)
        sim = self.simulation
        avoided, encountered = cues.obstacle_tally(snapshot.encountered, snapshot.collided)
        text("otgym play", (12, 12), TEXT_RGB, "title")
        text(f"participant {sim.participant}    trial {snapshot.trial}    time {cues.format_elapsed(snapshot.time_s)}"
             f"    obstacles avoided {avoided} / {encountered}", (150, 16))
        if snapshot.paused:
            text("PAUSED (space)", (700, 14), (250, 180, 30), "title")
        text("microscope, around the cell", (LOCAL_RECT.left, LOCAL_RECT.top - 20), DIM_TEXT_RGB, "small")
        legend = ("route", "robots", "traps +", "cell", "obstacles (arrow: next 3 s)", "flow")
        colours = (views.ROUTE_RGB, views.ROBOT_RGB, views.TRAP_RGB, views.CELL_RGB, views.OBSTACLE_RGB,
                   views.FLOW_RGB)
        x = 12
        y = self.global_view.rect.bottom + 10
        for name, rgb in zip(legend, colours):
            pygame.draw.circle(self.screen, rgb, (x + 6, y + 8), 6)
            label = self.type["small"].render(name, True, DIM_TEXT_RGB)
            self.screen.blit(label, (x + 16, y + 1))
            x += label.get_width() + 34
        fps = self.clock.get_fps()
        text(f"{fps:4.0f} fps    H: help", (GLOBAL_RECT.right - 150, y), DIM_TEXT_RGB, "small")

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
