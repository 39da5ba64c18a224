"""Haptic feedback: the force on one stylus from the vision force sensor's reading of
its robot's handles (paper section II-D: "a vision-based force sensor measures the
relative distance and direction between the robots and the tweezers' focal points
... the system calculates the optical forces ... and scales these forces").

The input is what a real set-up measures (``otgym.sim.sensor.VisionForceSensor``'s
``SensorReading``: the trap-law force on each handle and where the handle is), never
the simulator's true state. Per control tick, for the H handles of one robot:

1. Reaction: F = -newtons_per_pn * sum_h g_h f_h, where f_h is the trap's force on
   handle h (it points from the handle to the trap, i.e. along the trap's lead over
   the handle); the operator feels the trap dragging the robot, a force that resists
   the commanded motion.
2. Bend stiffening: g_h = 1 + bend_stiffening * clip((d_h / d_bend - 0.5) / 0.5, 0, 1)^2,
   d_h = |trap - handle|, d_bend = ``TrapLaw.escape_distance``: the force grows as a
   handle nears the distance where the trap loses it (for the paper's law it falls
   beyond delta, so without this the stylus would go slack just before the loss).
3. Contact cue: plus ``contact_gain_n`` * clip((c / contact_limit_pn - 0.5) / 0.5, 0, 1)^2
   against the commanded direction (the direction of the traps' lead, the sum of
   trap - handle), where c is the robot-cell contact force: the stylus stiffens before
   the cell is squeezed past its limit.
4. Low-pass: a second-order Butterworth at ``cutoff_hz`` (Brownian jitter of the
   handles; the paper filters feedback noise, the authors' release used an EMA), run
   tick by tick with its state kept.
5. Device frame: the chip-plane force mapped back through the retargeting plane
   (``retarget.chip_to_device``), its norm saturated at ``force_limit_n``.

Invalid or non-finite sensor entries contribute nothing: the filter then decays from
its last value instead of jumping.
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING

import numpy as np

from otgym.teleop.device import saturate_force
from otgym.teleop.retarget import PLANES, chip_to_device
from otgym.teleop.streaming_filter import sos_step
from otgym.teleop.touch import TOUCH_CAPS


def _scipy_signal():
    """scipy.signal, imported on first use: it takes seconds to import, and most
    importers of this module (the CLI, the tests' collection) build no filter."""
    from scipy import signal

    return signal


if TYPE_CHECKING:
    from otgym.physics.traps import TrapLaw

FILTER_ORDER = 2


@dataclasses.dataclass(frozen=True)
class FeedbackConfig:
    newtons_per_pn: float = 2.0
    """Stylus newtons per trap piconewton. The paper's trap law peaks at 0.30 pN (just
    past delta; K delta = 0.20 pN at the end of its linear part), so 2 N/pN gives at
    most 0.6 N, below the Touch's 0.88 N continuous limit with room for the bend and
    contact cues. The authors' release scaled its force to a peak of about 2.9 N. For
    another law use ``newtons_per_pn_for``."""
    force_limit_n: float = TOUCH_CAPS.force_limit_n
    """Geomagic Touch continuous force, 0.88 N (3.3 N peak)."""
    cutoff_hz: float = 10.0
    bend_stiffening: float = 2.0
    contact_limit_pn: float = 10.0
    """Robot-cell contact force limit (the release rewards contact within 0.05-10 pN)."""
    contact_gain_n: float = 0.3
    plane: str = "xy"
    """The retargeting plane this device uses (``RetargetConfig.plane``)."""

    def __post_init__(self):
        for name in ("newtons_per_pn", "cutoff_hz", "contact_limit_pn"):
            value = getattr(self, name)
            if not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
                raise ValueError(f"{name} must be positive and finite, got {value!r}")
        for name in ("force_limit_n", "bend_stiffening", "contact_gain_n"):
            value = getattr(self, name)
            if not isinstance(value, (int, float)) or not math.isfinite(value) or value < 0:
                raise ValueError(f"{name} must be finite and >= 0, got {value!r}")
        if self.plane not in PLANES:
            raise ValueError(f"plane must be one of {PLANES}, got {self.plane!r}")


def newtons_per_pn_for(trap_law: TrapLaw, peak_force_n: float = 0.6) -> float:
    """The scale that maps the law's largest restoring force to ``peak_force_n``."""
    if not math.isfinite(peak_force_n) or peak_force_n <= 0:
        raise ValueError(f"peak_force_n must be positive and finite, got {peak_force_n!r}")
    return peak_force_n / trap_law.max_force_pn


def stable_newtons_per_pn(
    trap_stiffness_pn_per_um: float, handles: int, motion_scale_um_per_mm: float, arm_stiffness_n_per_m: float = 300.0
) -> float:
    """The largest force scale at which the hand-trap loop's quasi-static gain is one:
    a trap offset d pushes the hand (stiffness k_arm) back by F / k_arm, which moves the
    traps by tau F / k_arm; with F = s * H * K d that is d again when
    s = k_arm / (H K tau), in N/pN with tau in um/m. A larger scale over-corrects
    every offset a tick later and the loop oscillates (seen in the simulated
    participants at the 0.6 N full scale of ``newtons_per_pn_for`` with the 50 pN/um
    literature traps: a 0.1 um lag already gave 0.3 N, 2 um of hand yield at the
    trap). Haptic teleoperation of stiff traps is scaled for stability this way
    (Pacoret & Regnier, Rev. Sci. Instrum. 84, 081301, 2013); the paper says only that
    its forces were "empirically scaled". Default arm stiffness: the 300 N/m of
    ``otgym.human.motor.HumanParams``."""
    for name, value in (
        ("trap_stiffness_pn_per_um", trap_stiffness_pn_per_um),
        ("handles", handles),
        ("motion_scale_um_per_mm", motion_scale_um_per_mm),
        ("arm_stiffness_n_per_m", arm_stiffness_n_per_m),
    ):
        if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
            raise ValueError(f"{name} must be positive and finite, got {value!r}")
    return arm_stiffness_n_per_m / (handles * trap_stiffness_pn_per_um * motion_scale_um_per_mm * 1000.0)


def _ramp(ratio) -> np.ndarray:
    """0 up to half the threshold, rising quadratically to 1 at the threshold."""
    return np.clip((np.asarray(ratio) - 0.5) / 0.5, 0.0, 1.0) ** 2


def chip_force_n(
    handle_force_pn, handle_offset_um, contact_force_pn, valid, config: FeedbackConfig, bend_distance_um: float
) -> np.ndarray:
    """The stylus force (..., 2) in N in the chip frame, before filtering and
    saturation, for arrays of one robot's handles (..., H, 2) (leading axes batch
    devices): minus the scaled trap forces, stiffened toward the bend, plus the contact
    cue against the trap's lead. Invalid or non-finite readings contribute nothing."""
    force = np.asarray(handle_force_pn, dtype=float)
    offset = np.asarray(handle_offset_um, dtype=float)
    usable = np.asarray(valid, dtype=bool) & np.isfinite(force).all(axis=-1) & np.isfinite(offset).all(axis=-1)
    force = np.where(usable[..., None], force, 0.0)
    offset = np.where(usable[..., None], offset, 0.0)
    gain = 1.0 + config.bend_stiffening * _ramp(np.linalg.norm(offset, axis=-1) / bend_distance_um)
    chip_n = -config.newtons_per_pn * (gain[..., None] * force).sum(axis=-2)
    lead = offset.sum(axis=-2)
    lead_norm = np.linalg.norm(lead, axis=-1, keepdims=True)
    contact = np.asarray(contact_force_pn, dtype=float)
    contact = np.where(np.isfinite(contact), contact, 0.0)
    cue_n = config.contact_gain_n * _ramp(contact / config.contact_limit_pn)
    return chip_n - np.where(lead_norm > 0, cue_n[..., None] * lead / np.maximum(lead_norm, 1e-300), 0.0)


class FeedbackLaw:
    """Streaming feedback for one device (its robot's handles); call once per tick."""

    def __init__(self, config: FeedbackConfig, trap_law: TrapLaw, tick_rate_hz: float):
        if not math.isfinite(tick_rate_hz) or tick_rate_hz <= 0:
            raise ValueError(f"tick_rate_hz must be positive and finite, got {tick_rate_hz!r}")
        if config.cutoff_hz >= tick_rate_hz / 2:
            raise ValueError(
                f"cutoff_hz must be below the Nyquist frequency {tick_rate_hz / 2} Hz, got {config.cutoff_hz!r}"
            )
        self.config = config
        self.bend_distance_um = float(trap_law.escape_distance)
        self._sos = _scipy_signal().butter(FILTER_ORDER, config.cutoff_hz, fs=tick_rate_hz, output="sos")
        self.reset()

    def reset(self) -> None:
        self._zi = np.zeros((self._sos.shape[0], 2, 2))

    def __call__(self, handle_force_pn, handle_offset_um, contact_force_pn: float, valid) -> np.ndarray:
        """(3,) stylus force in newtons (device frame).

        handle_force_pn: (H, 2) trap force on each handle (sensor reading);
        handle_offset_um: (H, 2) trap minus handle, the trap's lead (the vector
        ``TrapLaw.force_pn`` takes); contact_force_pn: robot-cell contact force;
        valid: (H,) the sensor's validity flags."""
        force = np.asarray(handle_force_pn, dtype=float)
        offset = np.asarray(handle_offset_um, dtype=float)
        valid = np.asarray(valid, dtype=bool)
        if force.ndim != 2 or force.shape[1] != 2 or offset.shape != force.shape or valid.shape != force.shape[:1]:
            raise ValueError(
                f"handle_force_pn and handle_offset_um must be (H, 2) and valid (H,), "
                f"got {force.shape}, {offset.shape}, {valid.shape}"
            )
        chip_n = chip_force_n(force, offset, contact_force_pn, valid, self.config, self.bend_distance_um)
        filtered = sos_step(self._sos, chip_n, self._zi)
        return saturate_force(chip_to_device(filtered, self.config.plane), self.config.force_limit_n)
