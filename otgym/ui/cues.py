"""The situational-awareness cues of the interface (paper section III-C and Fig. 9:
"local and global views with situational awareness cues, haptic force, and motion
direction guidance"), as pure functions from the task's state to what a cue shows:
fractions of a gauge, a colour, a direction, a flag. ``otgym.ui.views`` draws them;
keeping them here makes each one testable without a window.

* Contact force gauge: robot-cell contact force over the 10 pN limit of the feedback's
  contact cue (``FeedbackConfig.contact_limit_pn``); 1 at the limit, more beyond.
* Haptic force: each device's commanded force over its own continuous limit.
* Motion direction: the unit vector from the cell to the route a little ahead of it.
* Obstacle proximity: the gap to the nearest obstacle, coloured from green (far:
  alpha 0.1 in shared control) to red (near: alpha 0.5), by the paper's alpha law of
  that gap whatever the mode, so the colour means the same in every mode.
* Fine-tune prompt: shown in shared mode while alpha is in the paper's fine-tuning
  band (alpha >= 0.4, ``task.FINE_TUNE_ALPHA``, the threshold the simulated participants act on too): the person's share has risen and the
  autonomy wants their correction. Not shown in manual mode (alpha is always 1 there:
  nothing changes that a prompt could announce) nor autonomous (alpha 0).
* Trap-loss warning: a handle lagging its trap by at least half the trap law's escape
  distance (where the feedback's bend stiffening starts, ``teleop.feedback``), rising
  to 1 at the escape distance, where the trap loses it.
* Loss banner: a device or the autonomy lost (a driver's link gone, a bus node dead).
* Light dose: the cell's light dose so far in the trial (mJ/um^2, the trial metric of
  ``otgym.physics.light_dose``: time in the traps' light weighted by its intensity at
  the cell), or "unknown" where the window does not have it (NaN).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from otgym.autonomy.navigator import route_point
from otgym.shared import ArbitrationConfig, alpha_for_mode
from otgym.shared.arbitration import ALPHA_FAR, ALPHA_NEAR
from otgym.task.task import FINE_TUNE_ALPHA  # the cue's threshold, defined once there

TRAP_WARNING_FRACTION = 0.5
"""Warn from this fraction of the escape distance (the feedback's bend stiffening starts there)."""
DIRECTION_LOOKAHEAD_UM = 10.0
"""The motion-direction arrow points at the route this far ahead of the cell (a robot length)."""
SAFE_RGB = (40, 190, 70)
DANGER_RGB = (225, 45, 35)


@dataclasses.dataclass(frozen=True)
class Gauge:
    """A bar: ``fraction`` of its full scale (may exceed 1), ``over`` past the limit."""

    fraction: float
    over: bool


def contact_gauge(contact_force_pn: float, limit_pn: float = 10.0) -> Gauge:
    """The robot-cell contact force against its limit (1 at the limit)."""
    fraction = max(float(contact_force_pn), 0.0) / limit_pn
    return Gauge(fraction, fraction > 1.0)


def haptic_gauges(force_n, limit_n) -> list[Gauge | None]:
    """Per device: the norm of its commanded force (D, 3) over its limit (D,); None
    for a device without haptics (limit 0)."""
    forces = np.atleast_2d(np.asarray(force_n, float))
    gauges = []
    for force, limit in zip(forces, np.atleast_1d(np.asarray(limit_n, float))):
        if limit <= 0:
            gauges.append(None)
            continue
        fraction = float(np.linalg.norm(force)) / float(limit)
        gauges.append(Gauge(fraction, fraction >= 1.0))
    return gauges


def motion_direction(
    cell_xy_um, cell_arc_um: float, route_um, route_arc_um, lookahead_um: float = DIRECTION_LOOKAHEAD_UM
) -> np.ndarray:
    """(2,) unit vector (chip frame) from the cell to the route ``lookahead_um`` ahead
    of its progress; zeros at the route's end."""
    target = route_point(np.asarray(route_um), np.asarray(route_arc_um), cell_arc_um + lookahead_um)
    delta = target - np.asarray(cell_xy_um, float)
    norm = float(np.linalg.norm(delta))
    return delta / norm if norm > 1e-9 else np.zeros(2)


def proximity_level(gap_um: float, arbitration: ArbitrationConfig = ArbitrationConfig()) -> float:
    """0 (far: alpha 0.1) to 1 (near: alpha 0.5) by the shared-control law of ``gap_um``."""
    alpha = float(alpha_for_mode("shared", gap_um, arbitration))
    return float(np.clip((alpha - ALPHA_FAR) / (ALPHA_NEAR - ALPHA_FAR), 0.0, 1.0))


def ramp_rgb(level: float) -> tuple[int, int, int]:
    """Green at 0 to red at 1 through amber (red rises, green falls: monotone)."""
    t = float(np.clip(level, 0.0, 1.0))
    return tuple(int(round(s + (d - s) * t)) for s, d in zip(SAFE_RGB, DANGER_RGB))


def fine_tune_prompt(alpha: float, mode: str) -> bool:
    """Show "FINE-TUNE": shared mode with alpha in the fine-tuning band."""
    return mode == "shared" and alpha >= FINE_TUNE_ALPHA


def trap_loss_level(handle_offset_um, escape_distance_um: float) -> float:
    """0 below ``TRAP_WARNING_FRACTION`` of the escape distance for every handle, rising
    linearly to 1 at the escape distance (the worst handle of (T, 2) offsets; NaN
    offsets, handles the sensor did not find, count as 0)."""
    ratio = _worst_lag_ratio(handle_offset_um, escape_distance_um)
    return float(np.clip((ratio - TRAP_WARNING_FRACTION) / (1.0 - TRAP_WARNING_FRACTION), 0.0, 1.0))


def trap_loss_warning(handle_offset_um, escape_distance_um: float) -> bool:
    """True as soon as a handle lags its trap by ``TRAP_WARNING_FRACTION`` of the escape distance."""
    return _worst_lag_ratio(handle_offset_um, escape_distance_um) >= TRAP_WARNING_FRACTION


def _worst_lag_ratio(handle_offset_um, escape_distance_um: float) -> float:
    offsets = np.asarray(handle_offset_um, float).reshape(-1, 2)
    distance = np.nan_to_num(np.linalg.norm(offsets, axis=-1), nan=0.0)
    return float(distance.max(initial=0.0)) / escape_distance_um


def obstacle_tally(encountered, collided) -> tuple[int, int]:
    """(avoided, encountered) so far: obstacles that came within the encounter gap, and
    those of them never touched (``TrialMetrics``' definition)."""
    encountered = np.asarray(encountered, bool)
    return int((encountered & ~np.asarray(collided, bool)).sum()), int(encountered.sum())


def format_elapsed(time_s: float) -> str:
    """ "m:ss.s" of simulated time."""
    minutes, seconds = divmod(max(float(time_s), 0.0), 60.0)
    return f"{int(minutes)}:{seconds:04.1f}"


def light_dose_text(dose_mj_per_um2: float) -> str:
    """The light dose cue's value: three significant figures in mJ/um^2, or "unknown"
    for NaN (``Snapshot``'s default, where its maker has no dose)."""
    dose = float(dose_mj_per_um2)
    return "unknown" if math.isnan(dose) else f"{dose:.3g} mJ/um^2"


def loss_warnings(lost_devices, autonomy_live: bool, mode: str, simulator_live: bool = True) -> list[str]:
    """The lines of the loss banner: the simulator gone (a window on the bus), each
    device whose link was lost (by name; its robot's input is zero, the traps hold),
    and the autonomy when its dP_r stopped in a mode that uses it (shared control then
    runs as manual, autonomous holds the traps: ``InteractiveLoop``'s fallback)."""
    lines = [] if simulator_live else ["SIMULATOR LOST: waiting for it"]
    lines += [f"{name} LOST: its robot holds" for name in lost_devices]
    if not autonomy_live and mode == "shared":
        lines.append("AUTONOMY LOST: manual control")
    elif not autonomy_live and mode == "autonomous":
        lines.append("AUTONOMY LOST: the traps hold")
    return lines
