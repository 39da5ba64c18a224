"""One person's session of the interactive task, paced by the wall clock: trials one
after another, mode switches, pause, reset, quitting, and a ``Snapshot`` of every tick
for a view. ``otgym play`` runs it in a process of its own under its window
(``otgym.runtime.worker``), the sim node runs it behind the bus (``otgym.bus.nodes``).

Pacing (a fixed-step accumulator): ``advance(now)`` runs the 50 Hz ticks that are due
by the wall clock since the trial started or resumed, at most ``MAX_CATCH_UP_TICKS``
at once; a simulation further behind than that drops the debt (counted in
``late_ticks``) instead of bursting. So simulated time follows wall time while a tick
costs less than its period, whoever calls ``advance``: a worker process's loop, a
thread of its own (``start_thread``), or a test stepping it.

Everything that changes the simulation (a mode key, pause, reset, the next trial, a
forwarded device's sample, a mouse drag, quitting) is posted as a command and applied
by ``advance`` between ticks, so the loop is only ever touched by the thread that
ticks it. ``snapshot`` is replaced whole after each tick (one reference assignment,
safe to read from another thread).

Sink (``otgym.runtime.protocols.Sink``: ``describe(task)``, ``tick(record,
sphere_xy_um, mode)``, ``event(name, **fields)``, ``close()``) gets the task once at the session's start
(the chip, route and spheres: latched topics), every tick and the events ``trial_start`` (trial, scenario, mode,
participant, the spheres' radii in um), ``mode`` (a switch), ``paused`` / ``resumed`` (trial,
time_s), ``trial_end`` (the trial's row), ``autonomy_lost`` / ``autonomy_back``
(trial, time_s, mode: the autonomy's dP_r stopped or came back) and ``session_end``:
the MCAP recording of ``otgym play`` (``otgym.ui.recording``) or the sim node's
publisher (``otgym.bus.sim_node``).

Trials: trial t (from 1) meets scenario ``seed * 10000 + t`` (the experiment's
numbering). A trial ends when the task is DONE (goal reached, a trap lost, the task's
time limit), when the session's ``duration_s`` of simulated time is spent, or when
the session is quit mid-trial (``finish``: the window closed); its row has
``runtime.trials.TRIAL_COLUMNS`` and then ``modes_used`` and ``ended_by`` (``goal``,
``trap_lost``, ``time_limit``, ``duration`` or ``aborted``). ``completion_time_s`` is
the simulated time at which the trial ended, whatever ended it (``reached_goal`` says
whether the goal was reached; the task alone leaves it empty unless DONE). With
``hold_between_trials`` (``otgym play``) the row waits in ``take_finished`` and no
tick runs until ``next_trial`` is posted (the questionnaires come in between);
without it the next trial starts at once. With ``hold_first_trial`` (the sim node of
``otgym play --distributed``) trial 1 too waits for ``next_trial``: the session's other
nodes, the window among them, are up before its clock starts. A reset (R) abandons the trial without a row
and starts the next trial number.
"""

from __future__ import annotations

import collections
import dataclasses
import math
import threading
import time
from collections.abc import Callable

import numpy as np

from otgym.autonomy.protocol import Autonomy
from otgym.runtime.loop import DeviceBinding, InteractiveLoop, TickRecord
from otgym.runtime.protocols import Sink
from otgym.runtime.snapshot import Snapshot, smoothed_velocity
from otgym.shared import MODES
from otgym.task.task import InteractiveTask, Observation
from otgym.teleop.device import Sample, start_devices
from otgym.teleop.forwarded import ForwardedDevice
from otgym.teleop.mouse_drag import MouseDragDevice

MAX_CATCH_UP_TICKS = 3
EXTRA_COLUMNS = ["modes_used", "ended_by"]
ENDINGS = ("goal", "trap_lost", "time_limit", "duration", "aborted")


class Session:
    """One participant's trials on ``task`` with ``bindings`` (devices started and
    stopped here); ``duration_s`` None: until quit. ``autonomy``: dP_r for every
    trial's loop (``InteractiveLoop``'s; None: its own navigator). ``forwarded``:
    devices among the bindings' that ``feed`` and ``lose`` reach by index.
    ``first_trial``: the number (and so the scenario) of the first trial, 1 unless a
    study resumes a participant's session (``otgym study run``)."""

    def __init__(
        self,
        task: InteractiveTask,
        bindings: list[DeviceBinding],
        participant: str,
        mode: str,
        seed: int,
        duration_s: float | None = None,
        clock: Callable[[], float] = time.monotonic,
        sink: Sink | None = None,
        *,
        autonomy: Autonomy | None = None,
        hold_between_trials: bool = True,
        forwarded: tuple[ForwardedDevice, ...] = (),
        first_trial: int = 1,
        hold_first_trial: bool = False,
    ):
        if mode not in MODES:
            raise ValueError(f"unknown mode {mode!r}; choose one of {', '.join(MODES)}")
        if first_trial < 1:
            raise ValueError(f"trial numbers start at 1, got first_trial {first_trial}")
        self.task = task
        self.bindings = bindings
        self.participant = participant
        self.mode = mode
        self.seed = seed
        self.duration_s = duration_s
        self.clock = clock
        self.sink = sink
        self.autonomy = autonomy
        self.hold_between_trials = hold_between_trials
        self.hold_first_trial = hold_first_trial
        self.forwarded = tuple(forwarded)
        self.trial = first_trial - 1
        self.paused = False
        self.over = False
        self.late_ticks = 0
        self.ticks = 0
        self.loop: InteractiveLoop | None = None
        self.snapshot: Snapshot | None = None
        self._layout = None
        self._spent_s = 0.0
        self._commands: collections.deque = collections.deque()
        self._finished: collections.deque = collections.deque()
        self._waiting = False
        self._held_start = False
        """Before trial 1 under ``hold_first_trial``: waiting for ``next_trial``."""
        self._next_tick_wall_s = 0.0
        self._modes_used: list[str] = []
        self._autonomy_live = True
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()

    @property
    def force_limits_n(self) -> list[float]:
        """Each binding's device's force limit (0: no haptics)."""
        return [binding.device.caps.force_limit_n for binding in self.bindings]

    @property
    def layout(self):
        """The task's ``TaskLayout`` (what a view draws it with), built on first use."""
        if self._layout is None:
            from otgym.task.layout import layout_of

            self._layout = layout_of(self.task)
        return self._layout

    # --- lifetime -----------------------------------------------------------------
    def start(self) -> None:
        """Start every device (none left running if one fails), then trial 1 (with
        ``hold_first_trial``: once ``next_trial`` is posted)."""
        start_devices([binding.device for binding in self.bindings])
        self._warm_up()
        if self.sink is not None:
            self.sink.describe(self.task)  # the chip, route and spheres: a replay or a ui node draws the global view
        if self.hold_first_trial:
            self._waiting = self._held_start = True
        else:
            self._new_trial()

    def _warm_up(self) -> None:
        """Two ticks of a throwaway loop on trial 1's scenario: the jitted step and the
        loop's helpers compile here, not in the first seconds of the trial. Not for a
        plant whose ``warm_up_in_session`` is False (a rig: its reset tells the rig where
        a trial starts, and a throwaway loop is no trial)."""
        if not getattr(self.task, "warm_up_in_session", True):
            return
        loop = InteractiveLoop(
            self.task, self.bindings, self.task.scenario(self._scenario_seed(self.trial + 1)), self.mode, seed=0
        )
        loop.tick()
        loop.tick()
        for binding in self.bindings:
            binding.device.set_force(np.zeros(3))

    def close(self) -> None:
        """Stop the thread (if any), zero every device's force, stop the devices, end
        the sink's session."""
        self.stop_thread()
        for binding in self.bindings:
            binding.device.set_force(np.zeros(3))
            binding.device.stop()
        if self.sink is not None:
            self.sink.event("session_end", trials=self.trial, ticks=self.ticks)
            self.sink.close()

    def finish(self) -> None:
        """Quit: stop the thread (if any), apply the commands posted, and end a trial
        under way as ``aborted`` (its row goes to ``take_finished``) if it has run."""
        self.stop_thread()
        self._apply_commands()
        if self.loop is not None and not self._waiting and not self.over and self.loop.time_s > 0:
            self._end_trial("aborted")
        self.over = True

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
            self._stop.wait(min(self.next_tick_in_s(), 0.005))

    # --- commands (any thread) -----------------------------------------------------
    def post(self, command: Callable[[], None]) -> None:
        self._commands.append(command)

    def set_mode(self, mode: str) -> None:
        if mode not in MODES:
            raise ValueError(f"unknown mode {mode!r}; choose one of {', '.join(MODES)}")
        self.post(lambda: self._set_mode(mode))

    def toggle_pause(self) -> None:
        self.post(lambda: self._set_paused(not self.paused))

    def set_paused(self, paused: bool) -> None:
        self.post(lambda: self._set_paused(bool(paused)))

    def reset(self) -> None:
        self.post(self._new_trial)

    def next_trial(self) -> None:
        self.post(self._new_trial)

    def feed(self, index: int, sample: Sample | None) -> None:
        """The latest sample of forwarded device ``index``."""
        self.post(lambda: self.forwarded[index].feed(sample))

    def lose(self, index: int, reason: str) -> None:
        """Forwarded device ``index`` was lost (its driver raised ``reason``)."""
        self.post(lambda: self.forwarded[index].lose(reason))

    def drag(self, robot: int, pointer_um, traps_um) -> None:
        """Begin or continue dragging robot ``robot`` (the mouse: pointer and the robot's trap centre, chip um)."""
        pointer_um, traps_um = np.asarray(pointer_um, float), np.asarray(traps_um, float)
        self.post(lambda: [device.drag_to(pointer_um, traps_um) for device in self._drag_devices(robot)])

    def release_drag(self) -> None:
        self.post(lambda: [device.release() for device in self._drag_devices(None)])

    def _drag_devices(self, robot: int | None) -> list[MouseDragDevice]:
        return [
            binding.device
            for binding in self.bindings
            if isinstance(binding.device, MouseDragDevice) and (robot is None or binding.device.robot == robot)
        ]

    def take_finished(self) -> dict | None:
        """The row of a trial that ended, once; None when none is waiting."""
        return self._finished.popleft() if self._finished else None

    def poll(self) -> None:
        """Nothing comes back from a session in this process (``SessionControl``'s
        ``poll``): its snapshot and rows are read directly."""

    # --- the ticking thread ---------------------------------------------------------
    def next_tick_in_s(self) -> float:
        """Wall seconds until the next tick is due (inf while paused, waiting or over)."""
        if self.paused or self._waiting or self.over:
            return math.inf
        return max(self._next_tick_wall_s - self.clock(), 0.0)

    def _apply_commands(self) -> None:
        while self._commands:
            self._commands.popleft()()

    def advance(self, now_s: float | None = None) -> int:
        """Apply posted commands, then run the ticks due by the wall clock; returns how many ran."""
        self._apply_commands()
        if self._waiting and not self.hold_between_trials and not self._held_start and not self.over:
            self._new_trial()
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
        if record.autonomy_live != self._autonomy_live:
            self._autonomy_live = record.autonomy_live
            if self.sink is not None:
                self.sink.event(
                    "autonomy_back" if record.autonomy_live else "autonomy_lost",
                    trial=self.trial,
                    time_s=record.time_s,
                    mode=record.mode,
                )
        self._publish(record, before)
        if self.sink is not None:
            self.sink.tick(record, self.snapshot.sphere_xy_um, record.mode)
        spent = self._spent_s + loop.time_s
        if loop.done:
            self._end_trial()
        elif self.duration_s is not None and spent >= self.duration_s - 0.5 * loop.tick_s:
            self._end_trial("duration")

    def _publish(self, record: TickRecord | None, before: Observation | None) -> None:
        loop = self.loop
        obs = loop.observation
        previous = self.snapshot
        velocity = np.zeros_like(obs.obstacle_xy_um[0])
        if before is not None and previous is not None and previous.trial == self.trial:
            velocity = smoothed_velocity(
                previous.obstacle_velocity_um_s, before.obstacle_xy_um[0], obs.obstacle_xy_um[0], loop.tick_s
            )
        metrics = loop.state.metrics
        alpha = record.alpha if record is not None else float(previous.alpha if previous else 0.0)
        self.snapshot = Snapshot(
            self.trial,
            self.mode,
            self.paused,
            obs,
            record,
            loop.sphere_xy_um(),
            velocity,
            metrics.encountered[0].copy(),
            metrics.collided[0].copy(),
            alpha,
            tuple(f"device{i}" for i in loop.lost_devices),
            self._autonomy_live,
            float(metrics.light_dose_mj_per_um2[0]),
        )

    def _end_trial(self, ended_by: str | None = None) -> None:
        """End the trial: by the task (DONE: goal, trap lost or its time limit) when
        ``ended_by`` is None, else by the session (``duration``, ``aborted``)."""
        loop = self.loop
        row = loop.state.metrics.rows()[0]
        if ended_by is None:
            ended_by = "goal" if row["reached_goal"] else "trap_lost" if row["trap_losses"] else "time_limit"
        if not math.isfinite(row["completion_time_s"]):
            row["completion_time_s"] = loop.time_s
        row.update(
            participant=self.participant,
            mode=self._modes_used[0],
            trial=self.trial,
            scenario=self._scenario_seed(self.trial),
            modes_used="+".join(self._modes_used),
            ended_by=ended_by,
        )
        self._spent_s += loop.time_s
        self.over = self.duration_s is not None and self._spent_s >= self.duration_s - 0.5 * loop.tick_s
        self._waiting = True
        self._finished.append(row)
        if self.sink is not None:
            self.sink.event(
                "trial_end",
                **{
                    key: None if isinstance(value, float) and not math.isfinite(value) else value
                    for key, value in row.items()
                },
            )

    def _scenario_seed(self, trial: int) -> int:
        return self.seed * 10_000 + trial

    def _new_trial(self) -> None:
        if self.over:
            return
        self.trial += 1
        scenario_seed = self._scenario_seed(self.trial)
        self.loop = InteractiveLoop(
            self.task,
            self.bindings,
            self.task.scenario(scenario_seed),
            self.mode,
            seed=scenario_seed,
            autonomy=self.autonomy,
        )
        self._modes_used = [self.mode]
        self._waiting = self._held_start = False
        self._next_tick_wall_s = self.clock()
        self._publish(None, None)
        if self.sink is not None:
            self.sink.event(
                "trial_start",
                trial=self.trial,
                scenario=scenario_seed,
                mode=self.mode,
                participant=self.participant,
                sphere_radius_um=self.loop.sphere_radius_um.tolist(),
            )

    def _set_mode(self, mode: str) -> None:
        self.mode = mode
        if self.loop is not None:
            self.loop.mode = mode
        if mode not in self._modes_used:
            self._modes_used.append(mode)
        if self.sink is not None:
            self.sink.event("mode", trial=self.trial, mode=mode)
        if self.snapshot is not None:
            self.snapshot = dataclasses.replace(self.snapshot, mode=mode)

    def _set_paused(self, paused: bool) -> None:
        if paused == self.paused:
            return
        self.paused = paused
        if self.paused:
            for binding in self.bindings:
                binding.device.set_force(np.zeros(3))
        else:
            self._next_tick_wall_s = self.clock()
        if self.sink is not None:
            self.sink.event(
                "paused" if paused else "resumed",
                trial=self.trial,
                time_s=self.loop.time_s if self.loop is not None else 0.0,
            )
        if self.snapshot is not None:
            self.snapshot = dataclasses.replace(self.snapshot, paused=self.paused)
