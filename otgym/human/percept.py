"""What a simulated participant can perceive: the window's picture and its cue panel,
and nothing else (docs/decisions/0027-participant-perceives-the-window.md).

A person at ``otgym play`` sees the global view (the cell, the traps, the obstacles, the
route) and the cue panel (the mode, alpha as a number and a bar, the fine-tune prompt,
the nearest-obstacle gap), feels the stylus force and knows what their own hand did.
They never see the autonomy's command, nor alpha before the window shows it. A
``Percept`` holds exactly the window's part of that, for E environments; it is built in
one place, ``percept_from_window``, from what the window draws (``WindowDisplay`` keeps
the window's latency). The simulated participants' step (``otgym.human.participants``)
takes a ``Percept``, so no autonomy command can reach it.

Latency. The window draws the latest snapshot the simulation published (a snapshot per
20 ms tick, drawn at 60 frames a second, then the monitor's own delay): what is on
screen is the scene ``DISPLAY_LATENCY_S`` older than the state the controller reads.
0.02 s is **assumed** (a tick; plausible range 0-0.1 s: a frame of 16.7 ms plus a
monitor's 5-50 ms), not measured on the window.
"""

from __future__ import annotations

import dataclasses
from collections import deque

import numpy as np

from otgym.task.task import FINE_TUNE_ALPHA

DISPLAY_LATENCY_S = 0.02
"""How much older the scene on screen is than the state the controller reads (assumed)."""


@dataclasses.dataclass(frozen=True)
class ShownRoute:
    """The planned route as the window draws it (a polyline with its arc lengths, um) and
    the formation's trap offsets around the cell (the robots' shape, um): what the person
    knows of where to go and how the robots hold the cell."""

    route_um: np.ndarray  # (N, 2)
    route_arc_um: np.ndarray  # (N,)
    offsets_um: np.ndarray  # (T, 2)

    def point_at(self, arc_um) -> np.ndarray:
        """Points (..., 2) on the route at arc lengths ``arc_um`` (...,), clipped to its ends."""
        route, arc_axis = np.asarray(self.route_um, float), np.asarray(self.route_arc_um, float)
        arc = np.clip(arc_um, 0.0, arc_axis[-1])
        return np.stack([np.interp(arc, arc_axis, route[:, 0]), np.interp(arc, arc_axis, route[:, 1])], axis=-1)


@dataclasses.dataclass(frozen=True)
class Percept:
    """The window's picture and cue panel for E environments (T traps, K obstacles; um).

    The scene as drawn: the cell, its progress along the route and whether it is held
    (``phase``), the traps (yellow crosses), the obstacles. The cue panel: the mode, alpha
    as shown, the fine-tune prompt, the nearest-obstacle gap. No field holds the
    autonomy's command: a participant cannot read it."""

    mode: np.ndarray  # (E,) str: the mode the panel shows
    phase: np.ndarray  # (E,) APPROACH, CARRY or DONE (the cell free, held, delivered)
    cell_xy_um: np.ndarray  # (E, 2)
    cell_arc_um: np.ndarray  # (E,)
    trap_xy_um: np.ndarray  # (E, T, 2)
    obstacle_xy_um: np.ndarray  # (E, K, 2)
    alpha_shown: np.ndarray  # (E,) the human's share as the panel shows it
    fine_tune_shown: np.ndarray  # (E,) bool: the FINE-TUNE prompt is on screen
    nearest_gap_um: np.ndarray  # (E,) the nearest-obstacle cue


PERCEPT_FIELDS = tuple(field.name for field in dataclasses.fields(Percept))


def percept_from_window(obs, modes, alpha_shown) -> Percept:
    """The ``Percept`` of a window snapshot: the scene after a tick (``obs``, an
    ``otgym.task.task.Observation``), the modes (E,) the panel names and the alpha (E,)
    it shows. The fine-tune prompt is ``otgym.ui.cues.fine_tune_prompt``'s rule (shared
    mode, alpha at least ``FINE_TUNE_ALPHA``)."""
    modes = np.asarray(modes)
    alpha = np.asarray(alpha_shown, float)
    return Percept(
        mode=modes.copy(),
        phase=np.asarray(obs.phase).copy(),
        cell_xy_um=np.array(obs.cell_xy_um, float),
        cell_arc_um=np.array(obs.cell_arc_um, float),
        trap_xy_um=np.array(obs.trap_xy_um, float),
        obstacle_xy_um=np.array(obs.obstacle_xy_um, float),
        alpha_shown=alpha.copy(),
        fine_tune_shown=(modes == "shared") & (alpha >= FINE_TUNE_ALPHA),
        nearest_gap_um=np.array(obs.nearest_obstacle_gap_um, float),
    )


def latency_ticks(latency_s, tick_s: float):
    """The window's latency in whole ticks (at least 0): an int for one latency, an
    (E,) int array for one per environment."""
    latency = np.asarray(latency_s, dtype=float)
    if not (np.all(np.isfinite(latency)) and np.all(latency >= 0)):
        raise ValueError(f"display latency must be a non-negative number of seconds, got {latency_s!r}")
    ticks = np.rint(latency / tick_s).astype(np.int64)
    return int(ticks) if ticks.ndim == 0 else ticks


def rows_at_latency(history, ticks):
    """Per environment, the entry of ``history`` (a sequence of (E, ...) arrays or
    ``Percept``s, oldest first, newest last) ``ticks`` older than the newest, or the
    oldest while fewer are kept: ``ticks`` an int (the same for all) or (E,)."""
    if np.ndim(ticks) == 0:
        return history[max(len(history) - 1 - int(ticks), 0)]
    index = np.maximum(len(history) - 1 - np.asarray(ticks), 0)
    if np.all(index == index[0]):
        return history[int(index[0])]
    rows = np.arange(len(index))
    if isinstance(history[0], Percept):
        return Percept(**{name: np.stack([getattr(h, name) for h in history])[index, rows] for name in PERCEPT_FIELDS})
    return np.stack(list(history))[index, rows]


class WindowDisplay:
    """The window as the simulated participants see it: ``show(obs, modes, alpha)`` after
    each tick (the snapshot the window would draw: the scene after the tick, the mode and
    the alpha the tick used), ``percept()`` what is on screen now: the snapshot
    ``latency_s`` (in whole ticks) older than the latest (the oldest one kept until there
    are enough). ``latency_s``: one latency, or one per environment (E,)."""

    def __init__(self, tick_s: float, latency_s=DISPLAY_LATENCY_S):
        self._ticks = latency_ticks(latency_s, tick_s)
        self._snapshots: deque[Percept] = deque(maxlen=int(np.max(self._ticks)) + 1)

    def show(self, obs, modes, alpha) -> None:
        self._snapshots.append(percept_from_window(obs, modes, alpha))

    def percept(self) -> Percept:
        if not self._snapshots:
            raise RuntimeError("the window has shown nothing yet: call show() first")
        return rows_at_latency(self._snapshots, self._ticks)
