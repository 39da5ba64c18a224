"""The plants of the interactive task: what turns the controller's trap commands into
the bodies' motion. The controller (``otgym.runtime.loop``'s tick: devices and the
autonomy blended into dP_s, the trap-speed cap, the task's phases and metrics) is the
same for every plant; a plant is what ``InteractiveLoop`` calls ``reset``, ``dispatch``
and ``complete`` on:

- ``simulator``: the ``InteractiveTask`` itself (the JAX physics);
- ``RigPlant``: a rig outside otgym, an optical-tweezers set-up or anything that stands
  in for one. Each tick's commanded traps go out (the sim node publishes them on
  ``/otgym/traps``, as every tick); the rig answers with the measured centre of every
  sphere (``MeasuredPoses``, fed from ``/otgym/rig/poses``), and the tick's observation
  is built from the latest measurement instead of a physics step.

The rig's contract (``otgym.bus.topics``; docs/ros2.md, "A rig in place of the
simulator"): at each trial's start it is told where the trial starts every sphere
(``send_start``: ``/otgym/rig/start``, latched); it publishes every sphere's centre, um
in the chip frame, in the order of ``/otgym/bodies`` (the session description's
``sphere_body``), stamped with the UNIX time it measured them.

Safety limits on top of the controller's (each tick that applies one counts in
``held_ticks``):

- the trial begins on the rig: after a trial's start the traps hold until a measurement
  has every sphere within the trap law's escape distance of where the start put it (a
  rig that has placed its bodies at ``/otgym/rig/start``); measurements before that,
  and those stamped before the start, do not count (a rig's answers from the trial
  before may arrive after the start);
- the traps hold while no measurement newer than ``timeout_s`` has arrived (a rig that
  is silent or stalls);
- the traps wait for the robots: they hold while the latest measurement has a trapped
  sphere farther than ``wait_fraction`` of the escape distance from its trap (the
  distance below), halfway to losing it: commands never run away from a rig that lags
  (its own dynamics, or commands delayed on a loaded machine);
- the traps lead the rig by at most the escape distance: the newest command the latest
  measurement shows the rig following (every trapped sphere within the wait distance of
  it) is the rig's; a command farther than the escape distance from it holds the traps.
  So commands that reach the rig late, or not at all (a controller or a bus that stalls
  under load, a rig that stops listening), never put a trap farther ahead of the robots
  than a trap can pull them.

Each trap's distance to its handle, which decides a lost trap, is taken against the
trap commands in effect when the rig measured (its stamp) or up to
``COMMAND_DELAY_S`` before, and back to the newest command the rig was seen following,
the nearest of them, so the delay of the commands on their way to the rig (the bus, a
bridge, its loop) does not count as lag, the delay of its answers on their way back does
not slow the traps, and a rig still following an older command is waited for, not
taken as having lost its robots.

What a rig does not measure: the robot-cell contact force (NaN in the observation, so
the feedback's contact cue stays off and a trial's ``peak_contact_force_pn`` is empty);
an obstacle touching the assembly counts when the measured gap reaches zero.
"""

from __future__ import annotations

import collections
import dataclasses
import threading
import time
from collections.abc import Callable

import numpy as np

from otgym.task.task import DONE, InteractiveTask, Observation, TaskState

RIG_TIMEOUT_S = 0.25
"""A measurement older than this (12 ticks; the autonomy's bound too) counts as none: the traps hold."""
WAIT_FRACTION = 0.5
"""The traps wait for a trapped sphere farther than this fraction of the escape distance from its trap."""
COMMAND_DELAY_S = 1.0
"""How late a trap command may reach the rig (the bus, a bridge, the rig's own loop, on
a loaded machine): a measurement is compared with each command in effect within this
before its stamp. A handle is taken as lost only when it is farther than the trap
law's escape distance from all of them: a robot that escaped stays off its traps'
path, which the wait holds still, so it is found within this time."""
COMMAND_HISTORY = 1000
"""Trap commands kept to match a measurement's stamp (20 s of ticks)."""


def simulator(task: InteractiveTask, measured=None, send_start=None) -> InteractiveTask:
    """The simulator as the plant: the task's own physics (``measured`` and ``send_start`` unused)."""
    return task


class MeasuredPoses:
    """The latest measurement of a rig, handed over between threads or processes:
    ``update(arrival_s, stamp_s, sphere_xy_um)`` with the arrival by ``time.monotonic``
    (one clock for every process), the stamp in UNIX seconds, the centres (S, 2) um."""

    def __init__(self):
        self._latest: tuple[float, float, np.ndarray] | None = None
        self._lock = threading.Lock()
        self.received = 0

    def update(self, arrival_s: float, stamp_s: float, sphere_xy_um) -> None:
        with self._lock:
            self._latest = (float(arrival_s), float(stamp_s), np.asarray(sphere_xy_um, float))
            self.received += 1

    def latest(self) -> tuple[float, float, np.ndarray] | None:
        with self._lock:
            return self._latest


@dataclasses.dataclass(frozen=True)
class RigStep:
    """A tick's command to the rig (``RigPlant.dispatch``)."""

    trap_xy_um: np.ndarray  # (1, T, 2) the commanded traps
    before_done: np.ndarray  # (1,)


class RigPlant:
    """A rig as the plant of ``task`` (one environment; see the module's docstring):
    ``measured`` holds its latest measurement, ``send_start(sphere_xy_um, stamp_s)``
    tells it where a trial starts every sphere. Everything but ``reset``, ``dispatch``
    and ``complete`` is the task's (chip, route, bodies, configuration)."""

    warm_up_in_session = False
    """A session runs no throwaway warm-up loop on a rig: each ``reset`` sends the rig a
    trial's start, and the rig would get one for a trial that never runs."""

    def __init__(
        self,
        task: InteractiveTask,
        measured: MeasuredPoses,
        send_start: Callable[[np.ndarray, float], None],
        *,
        timeout_s: float = RIG_TIMEOUT_S,
        wait_fraction: float = WAIT_FRACTION,
        clock: Callable[[], float] = time.monotonic,
        wall_clock: Callable[[], float] = time.time,
    ):
        self.task, self.measured, self.send_start = task, measured, send_start
        self.timeout_s, self.clock, self.wall_clock = timeout_s, clock, wall_clock
        self.escape_distance_um = float(task.config.scene.trap_law.escape_distance)
        self.wait_um = wait_fraction * self.escape_distance_um
        model = task.scene.model
        self._sphere_body = np.asarray(model.sphere_body, int)
        self._radius = np.asarray(model.sphere_radius_um, float)
        self._payload = int(task.scene.payload)
        self._robots = [int(r) for r in task.scene.robots]
        self._obstacle_spheres = [np.flatnonzero(self._sphere_body == o) for o in task.scene.obstacles]
        self._grippers = np.asarray(task.scene.gripper_spheres, int)  # (R, 2)
        self._gripper_radius = float(self._radius[self._grippers[0, 0]])
        self._cell_radius = float(task.config.scene.cell_radius_um)
        self._commands: collections.deque = collections.deque(maxlen=COMMAND_HISTORY)
        self._start_stamp_s = -np.inf
        self._followed: tuple[float, np.ndarray] | None = None
        """(send time, traps) of the newest command the rig was seen following."""
        self._measured_stamp_s: float | None = None
        self._engaged = False
        self.held_ticks = 0
        """Ticks on which a safety limit held the traps (see the module's docstring)."""

    def __getattr__(self, name):
        return getattr(self.task, name)

    def reset(self, scenarios, key) -> TaskState:
        """The trial's start as the task sets it up (``InteractiveTask.reset``), sent to the rig."""
        if len(scenarios) != 1:
            raise ValueError(f"a rig runs one environment, got {len(scenarios)} scenarios")
        state = self.task.reset(scenarios, key)
        self._start_stamp_s = self.wall_clock()
        self._commands.clear()
        self._measured_stamp_s = None
        self._engaged = False
        self._start_xy_um = np.asarray(state.sphere_xy_um[0], float).copy()
        self._commands.append((self._start_stamp_s, state.observation.trap_xy_um[0].copy()))
        self._followed = self._commands[0]
        self.send_start(state.sphere_xy_um[0].copy(), self._start_stamp_s)
        return state

    def _fresh(self) -> tuple[float, np.ndarray] | None:
        """(stamp, centres) of the latest measurement if it counts (see the module's
        docstring); the first to count engages the trial."""
        latest = self.measured.latest()
        if latest is None:
            return None
        arrival_s, stamp_s, spheres = latest
        if stamp_s < self._start_stamp_s or self.clock() - arrival_s > self.timeout_s:
            return None
        if spheres.shape != (len(self._sphere_body), 2):
            return None
        if not self._engaged:
            if np.linalg.norm(spheres - self._start_xy_um, axis=-1).max() > self.escape_distance_um:
                return None
            self._engaged = True
        return stamp_s, spheres

    def dispatch(self, state: TaskState, trap_increment_um, key=None) -> RigStep:
        """The tick's trap command: the traps moved by ``trap_increment_um`` (1, T, 2), or
        held where the trial is DONE or a safety limit holds them."""
        increment = np.where((state.phase == DONE)[:, None, None], 0.0, np.asarray(trap_increment_um, float))
        if not np.all(np.isfinite(increment)):
            raise ValueError("trap increments must be finite")
        fresh = self._fresh()
        hold = fresh is None or self._trap_distance_um(*fresh).max() > self.wait_um
        if not hold:
            self._follow(*fresh)
            lead = np.linalg.norm(state.observation.trap_xy_um[0] + increment[0] - self._followed[1], axis=-1)
            hold = lead.max() > self.escape_distance_um
        if hold:
            increment = np.zeros_like(increment)
            self.held_ticks += 1
        traps = state.observation.trap_xy_um + increment
        self._commands.append((self.wall_clock(), traps[0].copy()))
        return RigStep(traps, state.phase == DONE)

    def complete(self, state: TaskState, pending: RigStep, alpha=None) -> Observation:
        """The tick's observation from the latest measurement (the previous one's spheres
        while none is fresh, each handle's distance still taken against the commands that
        measurement answered); the task's phases and metrics updated as after a physics
        step."""
        fresh = self._fresh()
        if fresh is not None:
            self._measured_stamp_s = fresh[0]
            spheres = fresh[1]
            self._follow(*fresh)
        else:
            spheres = state.sphere_xy_um[0]  # nothing new: the last measurement, or the trial's start
        if self._measured_stamp_s is None:  # the traps have held since the start
            distance = np.linalg.norm(spheres[self.task.trap_sphere] - pending.trap_xy_um[0], axis=-1)
        else:
            distance = self._trap_distance_um(self._measured_stamp_s, spheres)
        time_s = float(state.observation.time_s[0]) + self.task.config.tick_s
        observation, state.route_index = self.observe(
            spheres, pending.trap_xy_um[0], distance, time_s, state.route_index
        )
        state.sphere_xy_um = np.asarray(spheres, float)[None]
        self.task._account(state, observation, pending.before_done, alpha)
        state.observation = observation
        return observation

    def step(self, state: TaskState, trap_increment_um, key=None, alpha=None) -> Observation:
        return self.complete(state, self.dispatch(state, trap_increment_um, key), alpha)

    def _follow(self, stamp_s: float, spheres) -> None:
        """The newest command sent by ``stamp_s`` with every trapped sphere of
        ``spheres`` within the wait distance of it becomes the one the rig follows."""
        candidates = [command for command in self._commands if self._followed[0] < command[0] <= stamp_s]
        if not candidates:
            return
        handles = np.asarray(spheres, float)[self.task.trap_sphere]
        distance = np.linalg.norm(np.stack([traps for _, traps in candidates]) - handles, axis=-1).max(axis=-1)
        followed = np.flatnonzero(distance <= self.wait_um)
        if followed.size:
            self._followed = candidates[int(followed[-1])]

    def _trap_distance_um(self, stamp_s: float, spheres) -> np.ndarray:
        """Each trapped sphere's distance (T,) to the nearest of the trap commands in
        effect between ``stamp_s - COMMAND_DELAY_S`` (or the command the rig was seen
        following, if older) and ``stamp_s`` (the earliest kept if all are later)."""
        since_s = min(stamp_s - COMMAND_DELAY_S, self._followed[0])
        chosen = [self._commands[0][1]]
        for sent_s, traps in self._commands:
            if sent_s > stamp_s:
                break
            if sent_s < since_s:
                chosen = []
            chosen.append(traps)
        handles = np.asarray(spheres, float)[self.task.trap_sphere]
        return np.linalg.norm(np.stack(chosen) - handles[None], axis=-1).min(axis=0)

    def observe(
        self, sphere_xy_um, trap_xy_um, trap_distance_um, time_s: float, route_index
    ) -> tuple[Observation, np.ndarray]:
        """One environment's observation from measured centres (S, 2), the commanded traps
        (T, 2) and each trapped sphere's distance to its trap (T,): bodies at their
        spheres' mean, gaps as ``otgym.task.task``'s measurement takes them; and the new
        route index (1,) (``InteractiveTask.route_index`` from ``route_index``)."""
        spheres = np.asarray(sphere_xy_um, float)
        bodies, radius = self._sphere_body, self._radius
        cell = spheres[bodies == self._payload].mean(axis=0)
        obstacles = np.array([spheres[s].mean(axis=0) for s in self._obstacle_spheres]).reshape(-1, 2)
        obstacle_radius = np.array([radius[s].max() for s in self._obstacle_spheres])
        assembly = bodies <= self._payload
        between = np.linalg.norm(spheres[assembly][:, None] - obstacles[None], axis=-1)
        gaps = (between - radius[assembly][:, None] - obstacle_radius[None]).min(axis=0, initial=np.inf)
        grippers = spheres[self._grippers]  # (R, 2, 2)
        cell_gap = (np.linalg.norm(grippers - cell, axis=-1) - self._cell_radius - self._gripper_radius).min(axis=-1)
        handles = spheres[self.task.trap_sphere]
        index = self.task.route_index(cell[None], np.asarray(route_index))
        observation = Observation(
            time_s=np.array([time_s]),
            phase=np.zeros(1, int),  # set by the task's accounting
            cell_xy_um=cell[None],
            cell_arc_um=self.task.route_arc_um[index],
            trap_xy_um=np.asarray(trap_xy_um, float)[None],
            handle_xy_um=handles[None],
            robot_xy_um=np.array([spheres[bodies == robot].mean(axis=0) for robot in self._robots])[None],
            obstacle_xy_um=obstacles[None],
            obstacle_gap_um=gaps[None],
            contact_force_pn=np.full((1, len(self._robots)), np.nan),
            cell_gap_um=cell_gap[None],
            trap_distance_um=np.asarray(trap_distance_um, float)[None],
            obstacle_touched=np.zeros((1, len(obstacles)), bool),
        )
        return observation, index
