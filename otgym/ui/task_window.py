"""The window of ``otgym play --task NAME``: any registered task (``otgym.tasks.base.Task``)
played in real time with a pointing device.

Each frame (``TICK_HZ``) the window reads the device, turns its sample into a trap
increment through the same retargeting as the interactive task (clutch, tremor filter,
dead band, scale, speed clamp: ``otgym.teleop.retarget``) and adds it up. Each time the
task's ``control_period_s`` of wall time has passed, the sum over the period becomes a
velocity (um/s), the task's ``device_action`` turns it into an action, and the task
steps once; its ``frame`` is drawn with the episode's step, reward, return and the
successes so far, and the light dose where the task's ``info`` reports one (its
``light_dose...`` values: ``light_dose_text``). A finished episode (terminated or truncated) is written as a row and
a fresh one starts. With a ``recording`` (``otgym.ui.task_recording``) every episode's
start and end (with the task's metrics) and every state are recorded too. Stepping runs in the window's own thread: a step slower than the
period slows the episode, it never queues steps.

Input. ``--device`` is read as ``otgym play`` reads it (``otgym.ui.bindings``: the
keyboard or the gamepad through the window, the simulated or haptic styluses in their
own processes); the mouse works with every device, as a stick: press the left button
in the picture and drag, and the trap moves towards the pointer, faster the farther it
is from where you pressed (full speed at ``MOUSE_FULL_SPEED_PX``). Keys: R starts a new
episode, Esc quits.
"""

from __future__ import annotations

import csv
import dataclasses
import os
import time
from pathlib import Path

import numpy as np

os.environ.setdefault("SDL_FRAMEBUFFER_ACCELERATION", "0")  # as otgym.ui.app: no OpenGL present
import pygame  # noqa: E402

from otgym.tasks.base import Task  # noqa: E402
from otgym.teleop.device import Device  # noqa: E402
from otgym.teleop.mouse_drag import DRAG_GAIN_PER_S, MouseDragDevice  # noqa: E402
from otgym.teleop.retarget import RetargetConfig, Retargeter  # noqa: E402
from otgym.ui.palette import BACKGROUND_RGB, DIM_TEXT_RGB, TEXT_RGB, fonts  # noqa: E402

TICK_HZ = 50.0
"""Device reads per second (the interactive task's tick rate)."""
DEFAULT_PERIOD_S = 0.1
"""Wall seconds per step for a task whose ``control_period_s`` is None."""
FRAME_SIZE = (840, 560)
"""The task's picture, in pixels; the status lines sit below it."""
STATUS_HEIGHT = 90
WINDOW_SIZE = (FRAME_SIZE[0], FRAME_SIZE[1] + STATUS_HEIGHT)
MOUSE_FULL_SPEED_PX = 100.0
"""A mouse drag this far from where it was pressed asks for the retargeter's top speed."""
EPISODE_FIELDS = ("episode", "steps", "return", "success", "ended_by")


def check_playable(task: Task) -> Task:
    """``task`` if it draws a frame and takes pointing-device input; else ValueError.
    Read from the task's class, before any of its work is done."""
    if type(task).frame is Task.frame:
        raise ValueError(f"--task {task.name!r} draws no frame (Task.frame), so it cannot be played in a window")
    if type(task).device_action is Task.device_action:
        raise ValueError(f"--task {task.name!r} takes no pointing-device input (Task.device_action)")
    return task


@dataclasses.dataclass
class Compiled:
    """A task with its params and jitted one-environment reset and step."""

    task: Task
    params: object
    reset: object
    step: object
    period_s: float

    @classmethod
    def build(cls, task: Task, preset: str | None = None) -> Compiled:
        """Build the params (the task's host work) and compile reset and step once."""
        import jax

        params = task.make_params(task.config(preset))
        reset, step = jax.jit(task.reset), jax.jit(task.step)
        obs, state = reset(jax.random.PRNGKey(0), params)
        action = task.check_action(task.device_action(np.zeros(2), params), params)
        jax.block_until_ready(step(jax.random.PRNGKey(0), state, action, params))
        period = task.control_period_s(params)
        return cls(task, params, reset, step, float(period) if period else DEFAULT_PERIOD_S)


class TaskWindow:
    """The window over ``compiled`` driven by ``primary`` (None: the mouse alone),
    retargeted by ``retarget``; ``keyboards``: devices fed the window's key events."""

    def __init__(
        self,
        compiled: Compiled,
        primary: Device | None,
        retarget: RetargetConfig,
        *,
        seed: int = 0,
        keyboards=(),
        screen: pygame.Surface | None = None,
        label: str = "",
        recording=None,
    ):
        import jax

        self.compiled = compiled
        self.keyboards = list(keyboards)
        self.mouse = MouseDragDevice(0, primary, retarget.motion_scale_um_per_mm, plane=retarget.plane)
        self.retargeter = Retargeter(retarget, TICK_HZ)
        self._mouse_um_per_px = retarget.max_trap_speed_um_s / (DRAG_GAIN_PER_S * MOUSE_FULL_SPEED_PX)
        self.screen = screen if screen is not None else pygame.display.set_mode(WINDOW_SIZE)
        self.type = fonts()
        self.label = label or compiled.task.name
        self.key = jax.random.PRNGKey(seed)
        self.rows: list[dict] = []
        self.recording = recording
        self.last_info: dict | None = None
        self.running = True
        self.steps = 0
        self.successes = 0
        self._press_px: np.ndarray | None = None
        self._increment_um = np.zeros(2)
        self._ticks = 0
        self._next_step_s: float | None = None
        self._new_episode()

    # --- the task ---------------------------------------------------------------------
    def _new_episode(self) -> None:
        import jax

        self.key, reset_key = jax.random.split(self.key)
        self.obs, self.state = self.compiled.reset(reset_key, self.compiled.params)
        self.episode_steps, self.episode_return, self.last_reward = 0, 0.0, 0.0
        self.last_info = None
        self._dirty = True
        if self.recording is not None:
            self.recording.episode_start(len(self.rows) + 1, self.state)

    def _record(self, success: bool, ended_by: str) -> None:
        row = (len(self.rows) + 1, self.episode_steps, round(self.episode_return, 6), success, ended_by)
        self.rows.append(dict(zip(EPISODE_FIELDS, row)))
        self.successes += bool(success)
        if self.recording is not None:
            self.recording.episode_end(
                len(self.rows), self.episode_steps, self.episode_return, success, ended_by, self.last_info
            )

    def _end_episode(self, success: bool, ended_by: str) -> None:
        self._record(success, ended_by)
        self._new_episode()

    def step_task(self, velocity_um_s: np.ndarray) -> None:
        """One step of the task with the action the device's ``velocity_um_s`` asks for."""
        import jax

        task, params = self.compiled.task, self.compiled.params
        action = task.check_action(task.device_action(velocity_um_s, params), params)
        self.key, step_key = jax.random.split(self.key)
        self.obs, self.state, reward, terminated, truncated, info = self.compiled.step(
            step_key, self.state, action, params
        )
        self.steps += 1
        self.episode_steps += 1
        self.last_reward = float(reward)
        self.episode_return += self.last_reward
        self.last_info = info
        self._dirty = True
        if self.recording is not None:
            self.recording.state(self.state)
        if bool(terminated) or bool(truncated):
            self._end_episode(bool(info["success"]), "terminated" if bool(terminated) else "truncated")

    # --- input ------------------------------------------------------------------------
    def handle_event(self, event) -> None:
        if event.type == pygame.QUIT or (event.type == pygame.KEYDOWN and event.key == pygame.K_ESCAPE):
            self.running = False
            return
        if event.type == pygame.KEYDOWN and event.key == pygame.K_r:
            self._end_episode(False, "reset")
        if event.type in (pygame.KEYDOWN, pygame.KEYUP, pygame.WINDOWFOCUSLOST):
            for keyboard in self.keyboards:
                keyboard.handle_event(event)
        if event.type == pygame.MOUSEBUTTONDOWN and event.button == 1 and event.pos[1] < FRAME_SIZE[1]:
            self._press_px = np.asarray(event.pos, float)
        if event.type == pygame.MOUSEBUTTONUP and event.button == 1 or event.type == pygame.WINDOWFOCUSLOST:
            self._press_px = None
            self.mouse.release()
        if self._press_px is not None and event.type in (pygame.MOUSEMOTION, pygame.MOUSEBUTTONDOWN):
            scale = self._mouse_um_per_px
            self.mouse.drag_to(np.asarray(event.pos, float) * scale, self._press_px * scale)

    def frame(self, now_s: float) -> None:
        """One frame at time ``now_s`` (the pace's clock: ``time.monotonic()`` in ``run``,
        a test's own in tests): events, the device, a step when due, drawing."""
        for event in pygame.event.get():
            self.handle_event(event)
        self._increment_um += self.retargeter(self.mouse.read(), time.monotonic())  # samples: the real clock
        self._ticks += 1
        period = self.compiled.period_s
        if self._next_step_s is None:
            self._next_step_s = now_s + period
        elif now_s >= self._next_step_s:
            velocity = self._increment_um * TICK_HZ / self._ticks  # the mean over the period's ticks
            self._increment_um, self._ticks = np.zeros(2), 0
            self.step_task(velocity)
            self._next_step_s += period
            if self._next_step_s < now_s:  # late (a slow step or frame): no backlog of steps
                self._next_step_s = now_s + period
        if self._dirty:
            self.draw()

    def run(self, duration_s: float | None = None) -> None:
        """Frames until Esc, the window closing, or ``duration_s`` of simulated time."""
        self.mouse.start()
        clock = pygame.time.Clock()
        try:
            while self.running:
                self.frame(time.monotonic())
                if duration_s is not None and self.steps * self.compiled.period_s >= duration_s - 1e-9:
                    break
                clock.tick(TICK_HZ)
        finally:
            self.mouse.stop()
        if self.episode_steps:
            self._record(False, "stopped")  # the episode under way when the window closed

    # --- drawing ----------------------------------------------------------------------
    def draw(self) -> None:
        picture = np.ascontiguousarray(self.compiled.task.frame(self.state, self.compiled.params, FRAME_SIZE))
        height, width = picture.shape[:2]
        self.screen.fill(BACKGROUND_RGB)
        self.screen.blit(pygame.image.frombuffer(picture.tobytes(), (width, height), "RGB"), (0, 0))
        limit = self.compiled.task.max_steps(self.compiled.params)
        lines = (
            (
                f"{self.label}   episode {len(self.rows) + 1}   step {self.episode_steps}/{limit}   "
                f"reward {self.last_reward:+.2f}   return {self.episode_return:+.2f}   "
                f"successes {self.successes} of {len(self.rows)}",
                TEXT_RGB,
            ),
            (light_dose_text(self.last_info), TEXT_RGB),
            ("device or arrows move; mouse: press in the picture and drag; R new episode; Esc quit", DIM_TEXT_RGB),
        )
        for row, (text, rgb) in enumerate(lines):
            if text:
                self.screen.blit(self.type["body"].render(text, True, rgb), (12, FRAME_SIZE[1] + 8 + 26 * row))
        pygame.display.flip()
        self._dirty = False

    def save_screenshot(self, path: Path) -> None:
        pygame.image.save(self.screen, str(path))


def light_dose_text(info: dict | None) -> str:
    """The light dose line of the status: each scalar ``light_dose...`` value of the
    latest step's ``info`` (mJ/um^2, ``otgym.physics.light_dose``), e.g. "light dose
    0.0123 mJ/um^2"; empty for a task that reports none (or before the first step)."""
    parts = []
    for name, value in (info or {}).items():
        array = np.asarray(value)
        if name.startswith("light_dose") and array.size == 1:
            label = name.removesuffix("_mj_per_um2").replace("_", " ")
            parts.append(f"{label} {float(array.reshape(())):.3g} mJ/um^2")
    return "   ".join(parts)


def write_episodes(path: Path, rows: list[dict]) -> None:
    """The episodes as CSV (``EPISODE_FIELDS``), the header first."""
    with open(path, "w", newline="") as handle:
        writer = csv.DictWriter(handle, EPISODE_FIELDS)
        writer.writeheader()
        writer.writerows(rows)


def play_task(
    task_name: str,
    preset: str | None,
    device: str,
    seed: int,
    duration_s: float | None,
    screenshot: Path | None,
    out: Path,
) -> TaskWindow | None:
    """``otgym play --task``: open the window, build and compile the task while the
    start-up screen shows it, play until Esc or ``duration_s``, record the session
    (``out/session.mcap``: ``otgym.ui.task_recording``), write ``out/episodes.csv``
    (and the screenshot). None if closed before it was ready (nothing recorded)."""
    from otgym import tasks
    from otgym.record.mcap_file import session_path
    from otgym.teleop.device import DeviceError, start_devices
    from otgym.ui.bindings import play_binding, play_bindings, robot_primaries, window_devices
    from otgym.ui.startup import StartupAborted, StartupStatus, draw_startup, wait_in_window
    from otgym.ui.task_recording import TaskRecording

    task = check_playable(tasks.load(task_name))
    task.config(preset)  # an unknown preset: ValueError before the window opens
    windowed = window_devices(device)
    keyboards = [d for d in windowed if hasattr(d, "handle_event")]
    pygame.display.init()
    pygame.font.init()
    try:
        pygame.display.set_caption(f"otgym play --task {task_name}")  # before the window: it opens with its title
        screen = pygame.display.set_mode(WINDOW_SIZE)
        title = f"otgym play: task {task_name!r}, device {device}"
        status = StartupStatus("building the task and compiling its step")
        draw_startup(screen, fonts(), title, status.text, 0.0)
        try:
            primary = robot_primaries(device, windowed)[0]
            start_devices(windowed)
        except DeviceError as error:
            raise ValueError(str(error)) from None
        built: list[Compiled] = []
        try:
            wait_in_window(screen, lambda: built.append(Compiled.build(task, preset)), title, status)
        except StartupAborted:
            return None
        binding = play_bindings([primary], clutch=play_binding(device).clutch)[0]
        out.mkdir(parents=True, exist_ok=True)
        compiled = built[0]
        recording = TaskRecording(session_path(out), task, compiled.params, preset, seed, compiled.period_s)
        try:
            window = TaskWindow(
                compiled, primary, binding.retarget, seed=seed, keyboards=keyboards, screen=screen, recording=recording
            )
            window.run(duration_s)
        finally:
            recording.close()
        write_episodes(out / "episodes.csv", window.rows)
        if screenshot is not None:
            window.save_screenshot(screenshot)
        return window
    finally:
        for each in windowed:
            each.stop()
        pygame.quit()
