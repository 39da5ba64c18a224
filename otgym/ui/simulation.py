"""The interactive loop of one person's session, paced by the wall clock: trials one
after another, mode switches, pause and reset, and a ``Snapshot`` of every tick for
the views.

Pacing (a fixed-step accumulator): ``advance(now)`` runs the 50 Hz ticks that are due
by the wall clock since the trial started or resumed, at most ``MAX_CATCH_UP_TICKS``
at once; a simulation further behind than that drops the debt (counted in
``late_ticks``) instead of bursting. So simulated time follows wall time while a tick
costs less than its period, whoever calls ``advance``: the window's frame loop, or a
thread of its own (``otgym.ui.app`` says which and why).

Everything that changes the simulation (a mode key, pause, reset, the next trial, the
keyboard's key events) is posted as a command and applied by ``advance`` between
ticks, so the loop is only ever touched by the thread that ticks it. The views read
``snapshot``, replaced whole after each tick (one reference assignment, safe to read
from another thread).

Recording: with a ``SessionRecording`` every tick's messages go into its MCAP file,
with the events ``trial_start`` (trial, scenario, mode, the spheres' radii in um),
``mode`` (a switch), ``trial_end`` (the trial's row) and ``session_end``.

Trials: trial t (from 1) meets scenario ``seed * 10000 + t`` (the experiment's
numbering). A trial ends when the task is DONE (goal reached, a trap lost, the task's
time limit) or when the session's ``duration_s`` of simulated time is spent; its row
(``runtime.trials.TRIAL_COLUMNS`` and then ``modes_used`` and ``ended_by``) waits in
``take_finished`` and no tick runs until ``next_trial`` is posted. A reset (R)
abandons the trial without a row and starts the next trial number.
"""

from __future__ import annotations

import collections
import dataclasses
import math
import threading
import time
from typing import Callable

import numpy as np

from otgym.runtime.loop import DeviceBinding, InteractiveLoop, TickRecord
from otgym.runtime.task import InteractiveTask, Observation
from otgym.shared import MODES
from otgym.teleop.device import start_devices
from otgym.ui.recording import SessionRecording

MAX_CATCH_UP_TICKS = 3
OBSTACLE_VELOCITY_SMOOTHING_S = 0.3
"""Time constant of the obstacles' velocity estimate (their Brownian jitter averages out)."""
EXTRA_COLUMNS = ["modes_used", "ended_by"]


@dataclasses.dataclass(frozen=True)
class Snapshot:
    """What the views draw: the state after the latest tick (one environment)."""

    trial: int
    mode: str
    paused: bool
    observation: Observation
    record: TickRecord | None  # None before the trial's first tick
    sphere_xy_um: np.ndarray  # (S, 2)
    obstacle_velocity_um_s: np.ndarray  # (K, 2)
    encountered: np.ndarray  # (K,) bool
    collided: np.ndarray  # (K,) bool
    alpha: float

    @property
    def time_s(self) -> float:
        return float(self.observation.time_s[0])


class Simulation:
    """One participant's trials on ``task`` with ``bindings`` (devices started and
    stopped here); ``duration_s`` None: until closed."""

    def __init__(self, task: InteractiveTask, bindings: list[DeviceBinding], participant: str, mode: str,
                 seed: int, duration_s: float | None = None, clock: Callable[[], float] = time.monotonic,
                 recording: SessionRecording | None = None):
        if mode not in MODES:
            raise ValueError(f"unknown mode {mode!r}; choose one of {', '.join(MODES)}")
        self.task = task
        self.bindings = bindings
        self.participant = participant
        self.mode = mode
        self.seed = seed
        self.duration_s = duration_s
        self.clock = clock
        self.recording = recording
        self.trial = 0
        self.paused = False
        self.over = False
        self.late_ticks = 0
        self.ticks = 0
        self.loop: InteractiveLoop | None = None
        self.snapshot: Snapshot | None = None
        self._spent_s = 0.0
        self._commands: collections.deque = collections.deque()
        self._finished: collections.deque = collections.deque()
        self._waiting = False
        self._next_tick_wall_s = 0.0
        self._modes_used: list[str] = []
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()

    # --- lifetime -----------------------------------------------------------------
    def start(self) -> None:
        """Start every device (none left running if one fails), then trial 1."""
        start_devices([binding.device for binding in self.bindings])
        self._warm_up()
        if self.recording is not None:
            self.recording.describe(self.task)  # the chip, route and spheres, so a replay draws the global view
        self._new_trial()

    def _warm_up(self) -> None:
        """Two ticks of a throwaway loop on trial 1's scenario: the jitted step and the
        loop's helpers compile here, not in the first seconds of the trial."""
        loop = InteractiveLoop(self.task, self.bindings, self.task.scenario(self._scenario_seed(1)), self.mode,
                               seed=0)
        loop.tick()
        loop.tick()
        for binding in self.bindings:
            binding.device.set_force(np.zeros(3))

    def close(self) -> None:
        """Stop the thread (if any), zero every device's force, stop the devices."""
        self.stop_thread()
        for binding in self.bindings:
            binding.device.set_force(np.zeros(3))
            binding.device.stop()
        if self.recording is not None:
            self.recording.event("session_end", trials=self.trial, ticks=self.ticks)
            self.recording.close()

    def start_thread(self) -> None:
        """Tick in a thread of its own (``advance`` at each tick deadline)."""
        self._stop.clear()
        self._thread = threading.Thread(target=self._thread_main, name="otgym-simulation", daemon=True)
        self._thread.start()

    def stop_thread(self) -> None:
        if self._thread is not None:
            self._stop.set()
            self._thread.join()
            self._thread = None

    def _thread_main(self) -> None:
        while not self._stop.is_set():
            self.advance()
            wait_s = self._next_tick_wall_s - self.clock() if not (self.paused or self._waiting) else 0.005
            self._stop.wait(min(max(wait_s, 0.0), 0.005))

    # --- commands (any thread) -----------------------------------------------------
    def post(self, command: Callable[[], None]) -> None:
        self._commands.append(command)

    def set_mode(self, mode: str) -> None:
        if mode not in MODES:
            raise ValueError(f"unknown mode {mode!r}; choose one of {', '.join(MODES)}")
        self.post(lambda: self._set_mode(mode))

    def toggle_pause(self) -> None:
        self.post(self._toggle_pause)

    def reset(self) -> None:
        self.post(self._new_trial)

    def next_trial(self) -> None:
        self.post(self._new_trial)

    def take_finished(self) -> dict | None:
        """The row of a trial that ended, once; None when none is waiting."""
        return self._finished.popleft() if self._finished else None

    # --- the ticking thread ---------------------------------------------------------
    def advance(self, now_s: float | None = None) -> int:
        """Apply posted commands, then run the ticks due by the wall clock; returns how many ran."""
        while self._commands:
            self._commands.popleft()()
        if self.paused or self._waiting or self.over:
            return 0
        now_s = self.clock() if now_s is None else now_s
        ran = 0
        while now_s >= self._next_tick_wall_s and ran < MAX_CATCH_UP_TICKS:
            self._tick()
            ran += 1
            self._next_tick_wall_s += self.loop.tick_s
            if self._waiting:
                return ran
        if now_s - self._next_tick_wall_s > self.loop.tick_s:
            self.late_ticks += 1
            self._next_tick_wall_s = now_s
        return ran

    def _tick(self) -> None:
        loop = self.loop
        before = loop.observation
        record = loop.tick()
        self.ticks += 1
        self._publish(record, before)
        if self.recording is not None:
            self.recording.tick(record, self.snapshot.sphere_xy_um, self.mode)
        spent = self._spent_s + loop.time_s
        if loop.done or (self.duration_s is not None and spent >= self.duration_s - 0.5 * loop.tick_s):
            self._end_trial()

    def _publish(self, record: TickRecord | None, before: Observation | None) -> None:
        loop = self.loop
        obs = loop.observation
        previous = self.snapshot
        velocity = np.zeros_like(obs.obstacle_xy_um[0])
        if before is not None and previous is not None and previous.trial == self.trial:
            raw = (obs.obstacle_xy_um[0] - before.obstacle_xy_um[0]) / loop.tick_s
            weight = loop.tick_s / OBSTACLE_VELOCITY_SMOOTHING_S
            velocity = previous.obstacle_velocity_um_s + weight * (raw - previous.obstacle_velocity_um_s)
        metrics = loop.state.metrics
        alpha = record.alpha if record is not None else float(previous.alpha if previous else 0.0)
        self.snapshot = Snapshot(self.trial, self.mode, self.paused, obs, record, loop.sphere_xy_um(), velocity,
                                 metrics.encountered[0].copy(), metrics.collided[0].copy(), alpha)

    def _end_trial(self) -> None:
        loop = self.loop
        row = loop.state.metrics.rows()[0]
        if row["reached_goal"]:
            ended_by = "goal"
        elif row["trap_losses"]:
            ended_by = "trap_lost"
        elif loop.done:
            ended_by = "time_limit"
        else:
            ended_by = "duration"
        row.update(participant=self.participant, mode=self._modes_used[0], trial=self.trial,
                   scenario=self._scenario_seed(self.trial), modes_used="+".join(self._modes_used),
                   ended_by=ended_by)
        self._spent_s += loop.time_s
        self.over = self.duration_s is not None and self._spent_s >= self.duration_s - 0.5 * loop.tick_s
        self._waiting = True
        self._finished.append(row)
        if self.recording is not None:
            self.recording.event("trial_end", **{key: None if isinstance(value, float) and not math.isfinite(value)
                                                 else value for key, value in row.items()})

    def _scenario_seed(self, trial: int) -> int:
        return self.seed * 10_000 + trial

    def _new_trial(self) -> None:
        if self.over:
            return
        self.trial += 1
        scenario_seed = self._scenario_seed(self.trial)
        self.loop = InteractiveLoop(self.task, self.bindings, self.task.scenario(scenario_seed), self.mode,
                                    seed=scenario_seed)
        self._modes_used = [self.mode]
        self._waiting = False
        self._next_tick_wall_s = self.clock()
        self._publish(None, None)
        if self.recording is not None:
            self.recording.event("trial_start", trial=self.trial, scenario=scenario_seed, mode=self.mode,
                                 sphere_radius_um=self.loop.sphere_radius_um.tolist())

    def _set_mode(self, mode: str) -> None:
        self.mode = mode
        if self.loop is not None:
            self.loop.mode = mode
        if mode not in self._modes_used:
            self._modes_used.append(mode)
        if self.recording is not None:
            self.recording.event("mode", trial=self.trial, mode=mode)
        if self.snapshot is not None:
            self.snapshot = dataclasses.replace(self.snapshot, mode=mode)

    def _toggle_pause(self) -> None:
        self.paused = not self.paused
        if self.paused:
            for binding in self.bindings:
                binding.device.set_force(np.zeros(3))
        else:
            self._next_tick_wall_s = self.clock()
        if self.snapshot is not None:
            self.snapshot = dataclasses.replace(self.snapshot, paused=self.paused)
