"""Retargeting: a device's tip velocity -> the human's trap increment dP_h (paper
section II-D: "the velocity of the device's tips incrementally controls the positions
of the optical traps"; section II-E's dP_h).

Per control tick (rate ``tick_rate_hz``), in this order:

1. Input: the latest sample if it is finite and at most ``silence_timeout_s`` old,
   else none. Non-finite samples are dropped and counted; a silent device (no fresh
   sample) gives zero output while the filter is fed zeros and decays: nothing is ever
   extrapolated, so the traps hold (safety first).
2. Clutch (deadman): motion passes only while button ``clutch_bit`` is held. On
   release the output is zero at once and the filter is cleared, so re-engaging never
   replays old motion (ROS 2 ``teleop_twist_joy``: an enable button, zero sent on
   release).
3. Plane: device axes -> chip axes (chip x right, y down): "xy" maps device x -> chip x
   and device y (up) -> chip -y; "xz" maps device x -> chip x and device z (toward the
   user) -> chip y.
4. Tremor filter: a Butterworth low-pass (``scipy.signal.butter(..., output='sos')``)
   run sample by sample with its state kept between ticks (``streaming_filter.sos_step``).
   Physiological tremor lies at 8-12 Hz (McAuley & Marsden, Brain 123, 1545, 2000)
   while voluntary hand motion stays below about 2-3 Hz; the defaults (order 3, cutoff
   3.5 Hz at 50 Hz ticks) pass 1 Hz within 0.01 dB, attenuate 8 Hz by 23 dB and 10 Hz
   by 31 dB, with a group delay of about 0.09 s. (The authors' release used an
   exponential moving average, alpha 0.05: at 100 Hz it takes 22 dB off 10 Hz but also
   4 dB off 1 Hz, a lag of 0.2 s.)
5. Dead band: a filtered tip speed below ``dead_band_mm_s`` is zero (hand drift);
   above it the velocity passes unchanged.
6. Scale and clamp: dP_h = tau v / tick_rate_hz um with tau =
   ``motion_scale_um_per_mm``, its length clamped to ``max_trap_speed_um_s /
   tick_rate_hz``.

dP_h is already in trap micrometres: a shared-control law built on the paper's
dP_s = tau (alpha dP_h + (1 - alpha) dP_r) must not apply tau to it a second time.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from otgym.teleop.device import Sample
from otgym.teleop.streaming_filter import sos_step


def _scipy_signal():
    """scipy.signal, imported on first use: it takes seconds to import, and most
    importers of this module (the CLI, the tests' collection) build no filter."""
    from scipy import signal

    return signal


PLANES = ("xy", "xz")


@dataclasses.dataclass(frozen=True)
class RetargetConfig:
    motion_scale_um_per_mm: float = 2.0
    """The paper's tau: trap um per stylus mm. 2 um/mm maps a Geomagic Touch's ~160 mm
    workspace width onto ~320 um, about the default chip's width, so the whole chip is
    reachable with little clutching, while 1 mm of hand motion (well above a hand's
    ~0.1 mm positioning precision) moves the trap 2 um, a fifth of a 10 um robot. With
    the default dead band and clamp the human commands 2-10 um/s at tip speeds of
    1-5 mm/s, the slow, steady hand speeds of fine manipulation."""
    dead_band_mm_s: float = 1.0
    """Filtered tip speeds below this are zero (hand drift)."""
    max_trap_speed_um_s: float = 10.0
    """Clamp on the trap speed the human can command."""
    tremor_cutoff_hz: float = 3.5
    """Low-pass cutoff (see the module docstring for the resulting gains)."""
    filter_order: int = 3
    silence_timeout_s: float = 0.1
    """A sample older than this (or none) counts as no input: the traps hold."""
    clutch_bit: int | None = 0
    """Motion passes only while this button bit is held; None: always engaged."""
    plane: str = "xy"
    """Device axes mapped onto the chip plane: "xy" or "xz" (see the module docstring)."""

    def __post_init__(self):
        for name in ("motion_scale_um_per_mm", "max_trap_speed_um_s", "tremor_cutoff_hz", "silence_timeout_s"):
            value = getattr(self, name)
            if not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
                raise ValueError(f"{name} must be positive and finite, got {value!r}")
        if not isinstance(self.dead_band_mm_s, (int, float)) or not (
            math.isfinite(self.dead_band_mm_s) and self.dead_band_mm_s >= 0
        ):
            raise ValueError(f"dead_band_mm_s must be finite and >= 0, got {self.dead_band_mm_s!r}")
        if not isinstance(self.filter_order, int) or not 1 <= self.filter_order <= 8:
            raise ValueError(f"filter_order must be an integer within 1..8, got {self.filter_order!r}")
        if self.clutch_bit is not None and (not isinstance(self.clutch_bit, int) or not 0 <= self.clutch_bit <= 31):
            raise ValueError(f"clutch_bit must be None or an integer within 0..31, got {self.clutch_bit!r}")
        if self.plane not in PLANES:
            raise ValueError(f"plane must be one of {PLANES}, got {self.plane!r}")


def tremor_filter_sos(config: RetargetConfig, tick_rate_hz: float) -> np.ndarray:
    """The tremor low-pass as second-order sections at the tick rate."""
    if not math.isfinite(tick_rate_hz) or tick_rate_hz <= 0:
        raise ValueError(f"tick_rate_hz must be positive and finite, got {tick_rate_hz!r}")
    if config.tremor_cutoff_hz >= tick_rate_hz / 2:
        raise ValueError(
            f"tremor_cutoff_hz must be below the Nyquist frequency {tick_rate_hz / 2} Hz, "
            f"got {config.tremor_cutoff_hz!r}"
        )
    return _scipy_signal().butter(config.filter_order, config.tremor_cutoff_hz, fs=tick_rate_hz, output="sos")


def tremor_filter_gain_db(config: RetargetConfig, tick_rate_hz: float, freq_hz) -> np.ndarray:
    """The tremor filter's design gain in dB at ``freq_hz`` (scalar or array)."""
    freqs = np.atleast_1d(np.asarray(freq_hz, dtype=float))
    _, response = _scipy_signal().sosfreqz(tremor_filter_sos(config, tick_rate_hz), worN=freqs, fs=tick_rate_hz)
    gain = 20 * np.log10(np.maximum(np.abs(response), 1e-300))
    return gain if np.ndim(freq_hz) else float(gain[0])


def device_to_chip(vector_mm, plane: str) -> np.ndarray:
    """(..., 3) device-frame vectors -> (..., 2) chip-plane vectors (chip x right, y down)."""
    v = np.asarray(vector_mm, dtype=float)
    return np.stack([v[..., 0], -v[..., 1]] if plane == "xy" else [v[..., 0], v[..., 2]], axis=-1)


def chip_to_device(vector, plane: str) -> np.ndarray:
    """(..., 2) chip-plane vectors -> (..., 3) device-frame vectors (inverse of ``device_to_chip``
    on the plane, zero along the unused device axis)."""
    c = np.asarray(vector, dtype=float)
    zero = np.zeros_like(c[..., 0])
    return np.stack([c[..., 0], -c[..., 1], zero] if plane == "xy" else [c[..., 0], zero, c[..., 1]], axis=-1)


class Retargeter:
    """Streaming retargeter for one device; call it once per control tick."""

    def __init__(self, config: RetargetConfig, tick_rate_hz: float):
        self.config = config
        self.tick_rate_hz = float(tick_rate_hz)
        self._sos = tremor_filter_sos(config, tick_rate_hz)
        self._max_step_um = config.max_trap_speed_um_s / self.tick_rate_hz
        self.reset()

    def reset(self) -> None:
        """Clear the filter, the held sample and the counters."""
        self._zi = np.zeros((self._sos.shape[0], 2, 2))
        self._last: Sample | None = None
        self._last_dropped_sequence: int | None = None
        self.dropped_nonfinite = 0
        self.silent_ticks = 0

    def __call__(self, sample: Sample | None, now_s: float) -> np.ndarray:
        """The (2,) trap increment dP_h in um (chip frame) for this tick."""
        config = self.config
        if sample is not None:
            if sample.finite:
                self._last = sample
            elif sample.sequence != self._last_dropped_sequence:
                self._last_dropped_sequence = sample.sequence
                self.dropped_nonfinite += 1
        fresh = self._last is not None and now_s - self._last.time_s <= config.silence_timeout_s
        if not fresh:
            self.silent_ticks += 1
            self._filter(np.zeros(2))
            return np.zeros(2)
        if config.clutch_bit is not None and not (self._last.buttons >> config.clutch_bit) & 1:
            self._zi[:] = 0.0
            return np.zeros(2)
        velocity = self._filter(device_to_chip(self._last.velocity_mm_s, config.plane))
        if np.linalg.norm(velocity) < config.dead_band_mm_s:
            return np.zeros(2)
        step = velocity * (config.motion_scale_um_per_mm / self.tick_rate_hz)
        length = float(np.linalg.norm(step))
        return step * (self._max_step_um / length) if length > self._max_step_um else step

    def _filter(self, velocity_mm_s: np.ndarray) -> np.ndarray:
        return sos_step(self._sos, velocity_mm_s, self._zi)


class BatchRetargeter:
    """Steps 3-6 of ``Retargeter`` for N always-engaged devices at once (simulated
    participants in batched experiments, whose input is never stale or non-finite):
    plane mapping, the same tremor low-pass (state kept per device), dead band, scale
    and clamp. Input: stylus velocities (N, 2) in the plane's two device axes."""

    def __init__(self, config: RetargetConfig, tick_rate_hz: float, n_devices: int):
        self.config = config
        self._sos = tremor_filter_sos(config, tick_rate_hz)
        self._step_um = config.motion_scale_um_per_mm / float(tick_rate_hz)
        self._max_step_um = config.max_trap_speed_um_s / float(tick_rate_hz)
        self._zi = np.zeros((self._sos.shape[0], 2, n_devices, 2))

    def __call__(self, planar_velocity_mm_s) -> np.ndarray:
        """(N, 2) trap increments dP_h in um (chip frame) for this tick."""
        velocity = np.asarray(planar_velocity_mm_s, dtype=float)
        device = np.zeros(velocity.shape[:-1] + (3,))
        device[..., 0] = velocity[..., 0]
        device[..., 1 if self.config.plane == "xy" else 2] = velocity[..., 1]
        chip = device_to_chip(device, self.config.plane)
        filtered, self._zi = _scipy_signal().sosfilt(self._sos, chip[None], axis=0, zi=self._zi)
        filtered = filtered[0]
        speed = np.linalg.norm(filtered, axis=-1, keepdims=True)
        step = np.where(speed < self.config.dead_band_mm_s, 0.0, filtered * self._step_um)
        length = np.linalg.norm(step, axis=-1, keepdims=True)
        return step * np.minimum(1.0, self._max_step_um / np.maximum(length, 1e-300))
