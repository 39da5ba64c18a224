"""Tick-by-tick traces of chosen trials of a batch (``otgym.runtime.trials.run_trials``'s
``recorder``): what one environment saw and was commanded each tick, copied out of the
batch's arrays (one row, never the batch), so that tracing changes no result.

A row at ``time_s`` t holds the state after the tick (poses, the nearest obstacle's
surface gap) and the command that moved the traps during it, computed from the state of
the row before (alpha from the previous row's gap; the first tick from the reset's):

* ``alpha``: shared control's human share (NaN in the other modes, whose share is fixed);
* ``dP_h`` and ``dP_r``: the person's and the autonomy's increments (um per tick, per
  trap) as they enter the blend ``dP_s = tau (alpha dP_h + (1 - alpha) dP_r)``
  (``otgym.shared.arbitration``); the one a mode gives no weight is written as 0 (dP_r in
  manual, dP_h in autonomous and mpc); ``dP_s``: what the traps moved by after the
  trap-speed clamp;
* ``events``: ``;``-joined, in tick order: ``grip`` (the grippers closed on the cell),
  ``detach``, ``collision start k`` (obstacle k's contact with the assembly begins),
  ``trap loss``, ``goal reached``, ``time limit``, ``lapse start`` / ``lapse end``
  (the simulated person's lapse of responsiveness, ``otgym.human.motor``).

The last row is the tick the trial ended on: its ``time_s`` is trials.csv's
``completion_time_s``.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from otgym.runtime.tick import TickCommand
from otgym.task.task import APPROACH, CARRY, DONE, Observation, TaskState

PHASE_NAMES = {APPROACH: "approach", CARRY: "carry", DONE: "done"}


@dataclasses.dataclass(frozen=True)
class TickView:
    """One tick of a batch, as the recorder sees it (references, not copies): the
    observation the command was computed from and the one after the step, the tick's command, the autonomy's dP_r (E, T, 2) um, the
    task's state (its metrics) and, where the participants expose it, whether each
    environment's person is in a lapse (E,)."""

    before: Observation
    obs: Observation
    command: TickCommand
    robot_um: np.ndarray
    state: TaskState
    lapsed: np.ndarray | None = None


class TraceRecorder:
    """Records the environments ``envs`` (index in the batch -> label, e.g. the mode) of
    one batch, one row per tick until each is done; ``rows[env]`` holds its rows."""

    def __init__(self, envs: dict[int, str]):
        self.labels = dict(envs)
        self.rows: dict[int, list[dict]] = {env: [] for env in envs}
        self._done = {env: False for env in envs}
        self._phase: dict[int, int] = {}
        self._contact: dict[int, np.ndarray] = {}
        self._lapsed = dict.fromkeys(envs, False)
        self._counts = {env: (0, 0) for env in envs}  # detachments, trap losses so far

    def __call__(self, view: TickView) -> None:
        for env in self.labels:
            if env not in self._phase:  # the first tick: the state the trial started from
                self._phase[env], self._contact[env] = int(view.before.phase[env]), _contact(view.before, env)
            if not self._done[env]:
                self.rows[env].append(self._row(view, env))

    def _row(self, view: TickView, env: int) -> dict:
        obs, command, metrics = view.obs, view.command, view.state.metrics
        mode = str(command.modes[env])
        alpha = float(command.alpha[env])
        events = []
        phase = int(obs.phase[env])
        if not np.isnan(metrics.grip_time_s[env]) and metrics.grip_time_s[env] == obs.time_s[env]:
            events.append("grip")
        elif self._phase[env] == APPROACH and phase == CARRY:
            events.append("grip")
        detachments, losses = int(metrics.detachments[env]), int(metrics.trap_losses[env])
        if detachments > self._counts[env][0]:
            events.append("detach")
        contact = _contact(obs, env)
        events += [f"collision start {k}" for k in np.flatnonzero(contact & ~self._contact[env])]
        if losses > self._counts[env][1]:
            events.append("trap loss")
        self._counts[env] = (detachments, losses)
        if metrics.done[env]:
            self._done[env] = True
            if metrics.reached_goal[env]:
                events.append("goal reached")
            elif not losses:
                events.append("time limit")
        if view.lapsed is not None:
            lapsed = bool(view.lapsed[env])
            if lapsed != self._lapsed[env]:
                events.append("lapse start" if lapsed else "lapse end")
            self._lapsed[env] = lapsed
        self._phase[env], self._contact[env] = phase, contact
        gaps = obs.obstacle_gap_um[env]
        nearest = int(np.argmin(gaps)) if gaps.size else -1
        human = command.human_um[env] * (mode != "autonomous")
        robot = view.robot_um[env] * (mode != "manual")
        row = {
            "time_s": float(obs.time_s[env]),
            "mode": self.labels[env],
            "phase": PHASE_NAMES[phase],
            "alpha": alpha if mode == "shared" else float("nan"),
            "nearest_obstacle": nearest,
            "nearest_obstacle_gap_um": float(gaps[nearest]) if gaps.size else float("nan"),
            "lapse": bool(view.lapsed[env]) if view.lapsed is not None else None,
            "events": ";".join(events),
            "cell_x_um": float(obs.cell_xy_um[env, 0]),
            "cell_y_um": float(obs.cell_xy_um[env, 1]),
        }
        row.update(_xy("robot", obs.robot_xy_um[env]))
        row.update(_xy("trap", obs.trap_xy_um[env]))
        row.update(_xy("dP_h_trap", human))
        row.update(_xy("dP_r_trap", robot))
        row.update(_xy("dP_s_trap", command.shared_um[env]))
        row.update(_xy("obstacle", obs.obstacle_xy_um[env]))
        return row


def _contact(obs: Observation, env: int) -> np.ndarray:
    """(K,) whether each obstacle touches the assembly: the task's collision test."""
    touched = obs.obstacle_touched[env] if obs.obstacle_touched is not None else False
    return (obs.obstacle_gap_um[env] <= 0.0) | touched


def _xy(name: str, points_um: np.ndarray) -> dict:
    """``{name}{i}_x_um``, ``{name}{i}_y_um`` of points (N, 2)."""
    return {
        f"{name}{i}_{axis}_um": float(points_um[i, a]) for i in range(len(points_um)) for a, axis in enumerate("xy")
    }
