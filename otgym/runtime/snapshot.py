"""What a view draws of a session after each tick (``Snapshot``), and the obstacles'
velocity estimate it shows (``smoothed_velocity``). The session (``otgym.runtime.session``)
makes one per tick; the window's bus driver (``otgym.ui.node``) rebuilds one from the
sim node's topics."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from otgym.runtime.loop import TickRecord
from otgym.task.task import Observation

OBSTACLE_VELOCITY_SMOOTHING_S = 0.3
"""Time constant of the obstacles' velocity estimate (their Brownian jitter averages out)."""


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
    lost_devices: tuple[str, ...] = ()
    """Devices whose link was lost (binding i is ``device<i>``, as the recording and the bus name it)."""
    autonomy_live: bool = True
    """The latest tick had the autonomy's dP_r."""
    light_dose_mj_per_um2: float = math.nan
    """The cell's light dose so far in the trial (``TrialMetrics``); NaN where unknown."""

    @property
    def time_s(self) -> float:
        return float(self.observation.time_s[0])


def smoothed_velocity(
    previous_um_s: np.ndarray, before_um: np.ndarray, after_um: np.ndarray, tick_s: float
) -> np.ndarray:
    """The obstacles' velocity estimate after one tick: a first-order low-pass
    (``OBSTACLE_VELOCITY_SMOOTHING_S``) of their displacement over the tick."""
    raw = (after_um - before_um) / tick_s
    return previous_um_s + tick_s / OBSTACLE_VELOCITY_SMOOTHING_S * (raw - previous_um_s)
