"""One human motor model for otgym: a person moving a hand-held stylus, closed loop,
simulated for B hands at once at a fixed tick rate (``HumanMotor``, numpy).

Used by the simulated operator of the planning pipeline (``otgym.human.operator``, the
manual row of Table I) and by the simulated study participants
(``otgym.human.participants``), whose task-level policy decides an *intended* stylus
displacement and lets this model turn it into the hand's actual stylus velocity, one
tick at a time. Units: mm and mm/s at the stylus tip, s, newton (N) for the haptic
device's force. Planar: the two stylus axes. The model's parts (reaction delay,
intermittent corrections with Fitts timing, extent and direction errors, neuromuscular
lag, signal-dependent noise, tremor and slow drift, arm impedance, lapses, two hands
with one plan),
their parameters and sources: ``otgym.human.params``.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence

import numpy as np

from otgym.human.params import HumanParams


def _scipy_signal():
    """scipy.signal, imported on first use: it takes seconds to import, and most
    importers of this module (the CLI, the tests' collection) build no filter."""
    from scipy import signal

    return signal


TREMOR_WARMUP_S = 3.0  # about 15 decay times of the 8-12 Hz band-pass's slowest pole
_TREMOR_FILTER_ORDER = 4
_DRIFT_FILTER_ORDER = 2
_MS_PER_M = 1000.0  # mm/s per m/s


class HumanMotor:
    """The hand of B participants (or B trials) at a fixed tick rate, vectorised in numpy.

    Each tick, in this order: ``perceive`` (what the person sees now), ``decide_due``
    (whose corrective sub-movement starts now), ``plan`` (their new sub-movements),
    ``step`` (the stylus velocities this tick). All randomness comes from ``rng``.
    """

    def __init__(
        self,
        params: Sequence[HumanParams] | HumanParams,
        tick_rate_hz: float,
        rng: np.random.Generator | int,
        batch: int | None = None,
        hands_per_person: int = 1,
    ):
        if isinstance(params, HumanParams):
            if batch is not None and not (isinstance(batch, (int, np.integer)) and batch >= 1):
                raise ValueError(f"batch must be a positive integer, got {batch!r}")
            params = (params,) * (1 if batch is None else int(batch))
        else:
            params = tuple(params)
            if batch is not None and batch != len(params):
                raise ValueError(f"batch {batch!r} differs from the {len(params)} participants given")
        if not params or not all(isinstance(p, HumanParams) for p in params):
            raise ValueError("params must be a HumanParams or a non-empty sequence of them")
        if not (math.isfinite(tick_rate_hz) and tick_rate_hz > 0):
            raise ValueError(f"tick_rate_hz must be positive, got {tick_rate_hz!r}")
        if not (
            isinstance(hands_per_person, (int, np.integer))
            and hands_per_person >= 1
            and len(params) % hands_per_person == 0
        ):
            raise ValueError(
                f"hands_per_person must be a positive integer dividing the batch {len(params)}, "
                f"got {hands_per_person!r}"
            )
        if any(len(set(params[i : i + hands_per_person])) != 1 for i in range(0, len(params), hands_per_person)):
            raise ValueError("the hands of one person (consecutive rows) must share their HumanParams")
        for p in params:
            if p.tremor_band_hz[1] >= tick_rate_hz / 2:
                raise ValueError(
                    f"tick_rate_hz {tick_rate_hz:g} is too low for the tremor band {p.tremor_band_hz} Hz "
                    f"(its upper edge must lie below tick_rate_hz / 2)"
                )
        self.params = params
        self.batch = len(params)
        self.hands_per_person = int(hands_per_person)
        self.tick_rate_hz = float(tick_rate_hz)
        self._rng = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
        self._dt = 1.0 / self.tick_rate_hz

        def column(name):
            return np.array([getattr(p, name) for p in params], dtype=np.float64)

        self.delay_ticks = np.rint(column("reaction_time_s") * self.tick_rate_hz).astype(np.int64)
        self._interval_s = column("correction_interval_s")
        jitter = column("correction_jitter_fraction")
        self._jitter_sigma = np.sqrt(np.log1p(jitter**2))
        self._lag_keep = np.exp(-self._dt / column("neuromuscular_lag_s"))[:, None]
        self._noise_gain = np.sqrt(1.0 - self._lag_keep**2)  # keeps the noise's stationary SD
        self._extent_error = column("extent_error_fraction")
        self._direction_error_rad = np.radians(column("direction_error_deg"))
        self._noise_fraction = column("signal_dependent_noise")
        self._preferred_speed = column("preferred_speed_mm_s")
        self._fitts_a = column("fitts_a_s")
        self._fitts_b = column("fitts_b_s_per_bit")
        self._arm_mass = column("arm_mass_kg")[:, None]
        self._arm_damping = column("arm_damping_n_s_per_m")[:, None]
        self._arm_stiffness = column("arm_stiffness_n_per_m")[:, None]
        self._lapse_start_probability = -np.expm1(-column("lapse_rate_per_h") / 3600.0 * self._dt)
        self._lapse_duration = column("lapse_duration_s")

        # the hand's involuntary offsets: tremor in its band and slow drift, each its own
        # filtered noise, per participant
        tremor = [_tremor_filter(tuple(p.tremor_band_hz), self.tick_rate_hz) for p in params]
        drift = [_drift_filter(float(p.drift_cutoff_hz), self.tick_rate_hz) for p in params]
        self._offset_sos = [[sos for sos, _ in tremor], [sos for sos, _ in drift]]
        self._offset_input_sd = [
            column("tremor_rms_mm") / np.array([math.sqrt(gain) for _, gain in tremor]),
            column("drift_rms_mm") / np.array([math.sqrt(gain) for _, gain in drift]),
        ]
        self._offset_state = [[np.zeros((sos.shape[0], 2, 2)) for sos in bank] for bank in self._offset_sos]
        self._tremor_block = int(math.ceil(self.tick_rate_hz))  # ticks of tremor filtered at a time
        self._tremor_ahead = self._filter_tremor(int(math.ceil(TREMOR_WARMUP_S * self.tick_rate_hz)))
        self._tremor_mm = self._tremor_ahead[-1]
        self._tremor_next = len(self._tremor_ahead)

        self._history: np.ndarray | None = None
        self._history_length = int(self.delay_ticks.max()) + 1
        self._rows = np.arange(self.batch)
        self._seen = np.zeros(self.batch, dtype=np.int64)
        self._ticks = np.zeros(self.batch, dtype=np.int64)
        self._next_due = np.zeros(self.batch, dtype=np.int64)
        self._lapse_until = np.zeros(self.batch, dtype=np.int64)
        self._command = np.zeros((self.batch, 2))
        self._remaining = np.zeros(self.batch, dtype=np.int64)
        self._velocity = np.zeros((self.batch, 2))
        self._noise = np.zeros((self.batch, 2))
        self._yield_m = np.zeros((self.batch, 2))  # the hand's displacement from its intended motion
        self._yield_m_s = np.zeros((self.batch, 2))
        self.reset()

    @property
    def command_mm_s(self) -> np.ndarray:
        """(B, 2) velocity of the current sub-movement (zero when none is running)."""
        return np.where((self._remaining > 0)[:, None], self._command, 0.0)

    @property
    def lapsed(self) -> np.ndarray:
        """(B,) whether each participant is in a lapse of responsiveness now."""
        return self._ticks < self._lapse_until

    def reset(self, mask: np.ndarray | None = None) -> None:
        """Start a new trial for the participants in ``mask`` (all by default): nothing
        seen yet, hand at rest, the first sub-movement due one reaction time from now.
        The tremor goes on (it is the person's, not the trial's)."""
        mask = self._mask(mask)
        self._seen[mask] = 0
        self._ticks[mask] = 0
        self._next_due[mask] = self.delay_ticks[mask]
        self._lapse_until[mask] = 0
        self._command[mask] = 0.0
        self._remaining[mask] = 0
        self._velocity[mask] = 0.0
        self._noise[mask] = 0.0
        self._yield_m[mask] = 0.0
        self._yield_m_s[mask] = 0.0

    def perceive(self, observation: np.ndarray) -> np.ndarray:
        """Push this tick's observation (B, ...) and return what each participant sees
        now: the observation of ``delay_ticks`` calls ago (the first one since ``reset``
        while fewer have been pushed). Call once per tick."""
        observation = np.asarray(observation, dtype=np.float64)
        if observation.ndim == 0 or observation.shape[0] != self.batch:
            raise ValueError(f"observation must have shape (B={self.batch}, ...), got {observation.shape}")
        length = self._history_length
        if self._history is None or self._history.shape[2:] != observation.shape[1:]:
            if self._history is not None and self._seen.any():
                raise ValueError(
                    f"observation shape changed from {(self.batch, *self._history.shape[2:])} to "
                    f"{observation.shape} within a trial"
                )
            self._history = np.zeros((self.batch, length, *observation.shape[1:]))
        rows = self._rows
        self._history[rows, self._seen % length] = observation
        self._seen += 1
        lag = np.minimum(self.delay_ticks, self._seen - 1)
        return self._history[rows, (self._seen - 1 - lag) % length].copy()

    def decide_due(self) -> np.ndarray:
        """(B,) bool: a corrective sub-movement starts this tick (not during a lapse)."""
        due = (self._ticks == self._next_due) & ~self.lapsed
        if self.hands_per_person > 1:  # a person's hands start together (whole persons only)
            due = np.repeat(due.reshape(-1, self.hands_per_person).all(axis=1), self.hands_per_person)
        return due

    def submovement_duration_s(self, distance_mm, tolerance_mm, max_speed_mm_s=None) -> np.ndarray:
        """(B,) planned duration of a sub-movement over ``distance_mm`` to within
        ``tolerance_mm``: max(Fitts' MT, correction interval, distance / preferred speed,
        distance / ``max_speed_mm_s``). Arguments broadcast to (B,)."""
        distance = np.broadcast_to(np.asarray(distance_mm, dtype=np.float64), (self.batch,))
        tolerance = np.broadcast_to(np.asarray(tolerance_mm, dtype=np.float64), (self.batch,))
        if not (np.all(np.isfinite(distance)) and np.all(distance >= 0)):
            raise ValueError("distance_mm must be finite and non-negative")
        if not (np.all(np.isfinite(tolerance)) and np.all(tolerance > 0)):
            raise ValueError("tolerance_mm must be finite and positive")
        speed = self._preferred_speed
        if max_speed_mm_s is not None:
            limit = np.broadcast_to(np.asarray(max_speed_mm_s, dtype=np.float64), (self.batch,))
            if not np.all(limit > 0):
                raise ValueError("max_speed_mm_s must be positive")
            speed = np.minimum(speed, limit)
        fitts = self._fitts_a + self._fitts_b * np.log2(distance / tolerance + 1.0)
        return np.maximum.reduce([fitts, self._interval_s, distance / speed])

    def plan(self, intended_displacement_mm, tolerance_mm, max_speed_mm_s=None) -> None:
        """For the participants whose sub-movement is due (``decide_due``), start one
        toward ``intended_displacement_mm`` (B, 2) from the hand's position, to within
        ``tolerance_mm`` (B,): its duration from ``submovement_duration_s``, its
        displacement with extent and direction errors. Others keep their movement."""
        displacement = np.asarray(intended_displacement_mm, dtype=np.float64)
        if displacement.shape != (self.batch, 2) or not np.all(np.isfinite(displacement)):
            raise ValueError(
                f"intended_displacement_mm must be finite with shape (B={self.batch}, 2), got {displacement.shape}"
            )
        duration = self.submovement_duration_s(np.linalg.norm(displacement, axis=1), tolerance_mm, max_speed_mm_s)
        due = self.decide_due()
        if not due.any():
            return
        hands = self.hands_per_person
        count = int(due.sum())
        scale = 1.0 + self._extent_error[due] * self._rng.standard_normal(count)
        angle = self._direction_error_rad[due] * self._rng.standard_normal(count)
        if hands == 1:
            executed = _scale_rotate(displacement[due], scale, angle)
        else:  # one plan: the common part errs once per person, each hand's difference on its own
            duration = np.repeat(duration.reshape(-1, hands).max(axis=1), hands)
            common = np.repeat(displacement.reshape(-1, hands, 2).mean(axis=1), hands, axis=0)[due]
            leader = np.repeat(np.arange(0, count, hands), hands)  # due rows come in whole persons
            executed = _scale_rotate(common, scale[leader], angle[leader]) + _scale_rotate(
                displacement[due] - common, scale, angle
            )
        self._command[due] = executed / duration[due, None]
        self._remaining[due] = np.maximum(np.rint(duration[due] * self.tick_rate_hz), 1).astype(np.int64)

    def step(self, feedback_force_n: np.ndarray | None = None) -> np.ndarray:
        """(B, 2) the stylus velocity (mm/s) this tick: the lagged sub-movement velocity
        plus signal-dependent noise, tremor and drift, and the yield F / b_arm to the device's force
        ``feedback_force_n`` (B, 2) in N along the stylus axes. Advances one tick."""
        command = self.command_mm_s
        keep = self._lag_keep
        self._velocity = command + (self._velocity - command) * keep
        noise_sd = (self._noise_fraction * np.hypot(command[:, 0], command[:, 1]))[:, None] * self._noise_gain
        self._noise = self._noise * keep + noise_sd * self._rng.standard_normal((self.batch, 2))
        if self._tremor_next == len(self._tremor_ahead):
            self._tremor_ahead = self._filter_tremor(self._tremor_block)
            self._tremor_next = 0
        tremor = self._tremor_ahead[self._tremor_next]
        self._tremor_next += 1
        velocity = self._velocity + self._noise + (tremor - self._tremor_mm) / self._dt
        self._tremor_mm = tremor
        if feedback_force_n is not None:
            force = np.asarray(feedback_force_n, dtype=np.float64)
            if force.shape != (self.batch, 2) or not np.all(np.isfinite(force)):
                raise ValueError(f"feedback_force_n must be finite with shape (B={self.batch}, 2), got {force.shape}")
            m, b, k, dt = self._arm_mass, self._arm_damping, self._arm_stiffness, self._dt
            self._yield_m_s = (self._yield_m_s + dt / m * (force - k * self._yield_m)) / (
                1.0 + dt * b / m + dt * dt * k / m
            )
            self._yield_m = self._yield_m + dt * self._yield_m_s
            velocity = velocity + self._yield_m_s * _MS_PER_M
        self._advance()
        return velocity

    def _advance(self) -> None:
        """Count the tick down: sub-movements, the next correction, lapses."""
        self._remaining = np.maximum(self._remaining - 1, 0)
        due = self.decide_due()
        if due.any():
            factor = np.exp(
                self._jitter_sigma[due] * self._rng.standard_normal(int(due.sum())) - self._jitter_sigma[due] ** 2 / 2
            )
            interval = np.rint(self._interval_s[due] * factor * self.tick_rate_hz).astype(np.int64)
            self._next_due[due] = self._ticks[due] + np.maximum(interval, 1)
        self._ticks += 1
        starting = ~self.lapsed & (self._rng.random(self.batch) < self._lapse_start_probability)
        if starting.any():
            duration = self._rng.exponential(self._lapse_duration[starting])
            self._lapse_until[starting] = self._ticks[starting] + np.maximum(
                np.rint(duration * self.tick_rate_hz), 1
            ).astype(np.int64)
        if self.hands_per_person > 1:  # the person's schedule and lapses: the first hand's
            for name in ("_next_due", "_lapse_until"):
                value = getattr(self, name).reshape(-1, self.hands_per_person)
                setattr(self, name, np.repeat(value[:, 0], self.hands_per_person))
        # a correction that falls due during a lapse comes as soon as the lapse ends
        self._next_due = np.maximum(self._next_due, self._lapse_until)

    def _filter_tremor(self, ticks: int) -> np.ndarray:
        """The next ``ticks`` tip offsets (ticks, B, 2) of each participant's tremor plus
        drift: white noise through the tremor's band-pass and, independent of it, white
        noise through the drift's low-pass, the filter states carried on (the offsets
        are streamed a block ahead of the ticks that use them)."""
        offset = np.zeros((ticks, self.batch, 2))
        for bank, input_sd, states in zip(self._offset_sos, self._offset_input_sd, self._offset_state):
            white = self._rng.standard_normal((ticks, self.batch, 2))
            for i, sos in enumerate(bank):
                filtered, states[i] = _scipy_signal().sosfilt(sos, white[:, i] * input_sd[i], axis=0, zi=states[i])
                offset[:, i] += filtered
        return offset

    def _mask(self, mask) -> np.ndarray:
        if mask is None:
            return np.ones(self.batch, dtype=bool)
        mask = np.asarray(mask)
        if mask.shape != (self.batch,) or mask.dtype != np.bool_:
            raise ValueError(f"mask must be a boolean array of shape (B={self.batch},), got {mask.dtype} {mask.shape}")
        return mask


def _scale_rotate(vectors, scale, angle_rad) -> np.ndarray:
    """(n, 2) vectors scaled by (n,) factors and rotated by (n,) angles."""
    cos, sin = np.cos(angle_rad), np.sin(angle_rad)
    x, y = vectors[:, 0], vectors[:, 1]
    return scale[:, None] * np.stack((cos * x - sin * y, sin * x + cos * y), axis=1)


@functools.lru_cache(maxsize=32)
def _tremor_filter(band_hz: tuple[float, float], rate_hz: float) -> tuple[np.ndarray, float]:
    """Band-pass second-order sections and their noise gain (output variance for unit
    white input: the sum of the squared impulse response, which has decayed to nothing
    within ``TREMOR_WARMUP_S``)."""
    sos = _scipy_signal().butter(_TREMOR_FILTER_ORDER, band_hz, btype="bandpass", fs=rate_hz, output="sos")
    impulse = np.zeros(int(math.ceil(4 * TREMOR_WARMUP_S * rate_hz)))
    impulse[0] = 1.0
    gain = float(np.sum(_scipy_signal().sosfilt(sos, impulse) ** 2))
    return sos, gain


@functools.lru_cache(maxsize=32)
def _drift_filter(cutoff_hz: float, rate_hz: float) -> tuple[np.ndarray, float]:
    """The drift's low-pass second-order sections and their noise gain (as ``_tremor_filter``)."""
    if not 0 < cutoff_hz < rate_hz / 2:
        raise ValueError(f"drift_cutoff_hz {cutoff_hz:g} must lie below half the tick rate {rate_hz:g} Hz")
    sos = _scipy_signal().butter(_DRIFT_FILTER_ORDER, cutoff_hz, btype="lowpass", fs=rate_hz, output="sos")
    impulse = np.zeros(int(math.ceil(4 * TREMOR_WARMUP_S * rate_hz)))
    impulse[0] = 1.0
    gain = float(np.sum(_scipy_signal().sosfilt(sos, impulse) ** 2))
    return sos, gain
