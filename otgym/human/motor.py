"""One human motor model for otgym: a person moving a hand-held stylus, closed loop.

Used by the simulated operator of the planning pipeline (``operator.py``, the manual row
of Table I) and by the simulated teleoperation participant, whose task-level policy
decides an *intended* stylus displacement and lets this model turn it into the hand's
actual stylus velocity, one tick at a time. Units: mm and mm/s at the stylus tip, s,
newton (N) for the haptic device's force. Planar: the two stylus axes.

The model, per participant (``HumanParams``; defaults are population means):

* **Reaction delay** ``reaction_time_s`` (0.2 s): the person sees what happened that
  long ago (``HumanMotor.perceive``, a delay line of round(reaction_time_s * rate)
  ticks) and starts the first movement that long after the start (``reset``). Simple
  visual reaction times are about 0.2 s: 213 ms on average over 1469 adults measured
  with calibrated hardware (Woods et al., Front. Hum. Neurosci. 9, 131, 2015), and the
  Model Human Processor's perceive-decide-act cycle is about 0.24 s (Card, Moran &
  Newell, *The Psychology of Human-Computer Interaction*, 1983).
* **Intermittent corrections** every ``correction_interval_s`` (0.4 s): manual control
  proceeds by discrete corrective sub-movements at about 2-3 per second (Craik, Br. J.
  Psychol. 38, 56, 1947; Miall, Weir & Stein, J. Motor Behav. 25, 53, 1993). Intervals
  are not periodic: each is the mean times a log-normal factor with coefficient of
  variation ``correction_jitter_fraction`` (0.2; no literature value, an assumption
  that keeps participants' corrections out of phase).
* **Speed-accuracy trade-off**: a sub-movement over distance D to a tolerance W lasts
  MT = ``fitts_a_s`` + ``fitts_b_s_per_bit`` * log2(D / W + 1) (Fitts, J. Exp. Psychol.
  47, 381, 1954; the Shannon formulation of MacKenzie, Human-Computer Interaction 7, 91,
  1992), and at least one correction interval, and no faster than
  ``preferred_speed_mm_s`` (20 mm/s) or a task's speed limit. a = 12.8 ms and
  b = 94.7 ms/bit are MacKenzie's fit of Fitts' own tapping data with a 1 oz stylus
  (J. Motor Behav. 21, 323, 1989). The preferred speed has no direct measurement: it is
  set so that steering a stylus along a 2 mm wide path, about W / b' = 20 mm/s by the
  steering law with b' of about 0.1 s (Accot & Zhai, CHI 1997), is not slowed further.
* **Extent and direction errors**: each sub-movement's displacement is scaled by
  1 + N(0, ``extent_error_fraction`` = 0.1) and rotated by N(0, ``direction_error_deg``
  = 4 deg): planar reaching errors are about a tenth of the distance in extent and a
  few degrees in direction, independent of each other (Gordon, Ghilardi & Ghez, Exp.
  Brain Res. 99, 97, 1994).
* **Neuromuscular lag** ``neuromuscular_lag_s`` (0.1 s): the hand's velocity follows the
  sub-movement's velocity through a first-order lag, the neuromuscular term of the
  crossover model of the human controller (McRuer & Jex, IEEE Trans. HFE 8, 231, 1967).
  Discretised exactly for a command held over each tick.
* **Signal-dependent noise** ``signal_dependent_noise`` (0.05): motor noise whose SD
  grows in proportion to the motor command (Harris & Wolpert, Nature 394, 780, 1998;
  execution noise dominates reaching variability: van Beers, Haggard & Wolpert,
  J. Neurophysiol. 91, 1050, 2004). Modelled as white noise on the command passed
  through the same neuromuscular lag: an Ornstein-Uhlenbeck velocity error with
  correlation time ``neuromuscular_lag_s`` and stationary SD, per axis,
  ``signal_dependent_noise`` * |command velocity|, independent of the tick rate. The
  value 0.05 is an assumption of the order of the few-percent coefficient of variation
  of steady muscle force, which grows in proportion to the force (Jones, Hamilton &
  Wolpert, J. Neurophysiol. 88, 1533, 2002); it is kept below the extent error, which
  already holds most of a movement's variability.
* **Physiological tremor** ``tremor_rms_mm`` (0.05 mm per axis) in ``tremor_band_hz``
  (8-12 Hz; McAuley & Marsden, Brain 123, 1545, 2000): Gaussian white noise through a
  4th-order Butterworth band-pass per participant, streamed (filtered one second ahead
  of the ticks that use it, the filter state carried on, also across ``reset``; warmed
  up for ``TREMOR_WARMUP_S`` at construction so it is stationary from the first tick)
  and scaled by the filter's noise gain so that the tip's displacement has exactly that
  RMS; the hand's velocity gets its tick-to-tick difference. Eye surgeons holding an
  instrument still move its tip by 49 um RMS (Riviere, Rader & Khosla, IEEE EMBS 1997),
  the amplitude that tremor cancelling was designed for (Riviere, Rader & Thakor, IEEE
  Trans. BME 45, 839, 1998).
* **Arm impedance** ``arm_mass_kg`` (1.5 kg), ``arm_damping_n_s_per_m`` (7 N s/m) and
  ``arm_stiffness_n_per_m`` (300 N/m): the hand yields to the haptic device's force F
  as a mass-spring-damper about its intended motion, m x'' + b x' + k x = F, so force
  feedback physically resists (or assists) the motion and a steady force displaces the
  hand by F / k, not without bound (integrated by backward Euler over each tick,
  unconditionally stable). The arm's impedance about its intended motion (Hogan,
  Biol. Cybern. 52, 315, 1985): stiffness 100-1000 N/m at the hand in the horizontal
  plane (Mussa-Ivaldi, Hogan & Bizzi, J. Neurosci. 5, 2732, 1985), a hand viscosity of
  several N s/m and an apparent hand mass of about 1-2 kg (Tsuji, Morasso, Goto & Ito,
  Biol. Cybern. 72, 475, 1995).
* **Lapses of responsiveness** ``lapse_rate_per_h`` (39.3 per hour) lasting
  ``lapse_duration_s`` (3.4 s on average, exponentially distributed): rested subjects in
  a one-hour continuous visuomotor tracking task stop responding that often and that
  long (Peiris, Jones, Davidson, Carroll & Bones, J. Sleep Res. 15, 291, 2006). During
  a lapse no sub-movement starts (the current one runs out and the hand stops); a
  correction follows as soon as it ends. Lapses start as a Poisson process in time.
* **Two hands, one plan** (``HumanMotor(..., hands_per_person=2)``): a person's two
  hands are consecutive rows of the batch. Their corrective sub-movements start and end
  together (simultaneous bimanual reaches to targets of different difficulty start and
  end together: Kelso, Southard & Goodman, Science 203, 1029, 1979), lapses are the
  person's, and a bimanual movement is one plan with a common part (the mean of the
  hands' displacements) and each hand's difference from it ("two hands, one brain":
  Swinnen & Wenderoth, Trends Cogn. Sci. 8, 18, 2004). The extent and direction errors
  above apply to each part in proportion to its size: one draw for the common part,
  one per hand for its difference. That errors split this way is a modelling choice
  consistent with that view (no study gives the split); it means two hands moving a
  rigid load together err together, and their relative placement errs in proportion
  to the relative movement. Noise, tremor and yielding stay per hand.

``sample_population`` draws participants: each parameter log-normal around its mean
(``POPULATION_CV``, sources there). Participant ``i`` of seed ``s`` is drawn from its
own stream ``(s, i)``, so it is the same participant whatever the population's size.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import types
from collections.abc import Mapping, Sequence

import numpy as np
from scipy import signal

TREMOR_WARMUP_S = 3.0  # about 15 decay times of the 8-12 Hz band-pass's slowest pole
_TREMOR_FILTER_ORDER = 4
_MS_PER_M = 1000.0  # mm/s per m/s


@dataclasses.dataclass(frozen=True)
class HumanParams:
    """One participant's motor parameters (units in the names; sources in the module
    docstring). Defaults are the population means."""

    reaction_time_s: float = 0.2
    correction_interval_s: float = 0.4
    correction_jitter_fraction: float = 0.2
    neuromuscular_lag_s: float = 0.1
    extent_error_fraction: float = 0.1
    direction_error_deg: float = 4.0
    signal_dependent_noise: float = 0.05
    tremor_rms_mm: float = 0.05
    tremor_band_hz: tuple[float, float] = (8.0, 12.0)
    preferred_speed_mm_s: float = 20.0
    fitts_a_s: float = 0.0128
    fitts_b_s_per_bit: float = 0.0947
    arm_damping_n_s_per_m: float = 7.0
    arm_mass_kg: float = 1.5
    arm_stiffness_n_per_m: float = 300.0
    lapse_rate_per_h: float = 39.3
    lapse_duration_s: float = 3.4

    def __post_init__(self):
        for name in (
            "correction_interval_s",
            "neuromuscular_lag_s",
            "preferred_speed_mm_s",
            "fitts_b_s_per_bit",
            "arm_damping_n_s_per_m",
            "arm_mass_kg",
            "arm_stiffness_n_per_m",
            "lapse_duration_s",
        ):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"human {name} must be positive, got {value!r}")
        for name in (
            "reaction_time_s",
            "correction_jitter_fraction",
            "extent_error_fraction",
            "direction_error_deg",
            "signal_dependent_noise",
            "tremor_rms_mm",
            "fitts_a_s",
            "lapse_rate_per_h",
        ):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise ValueError(f"human {name} must be non-negative, got {value!r}")
        band = self.tremor_band_hz
        if not (len(band) == 2 and all(math.isfinite(f) for f in band) and 0 < band[0] < band[1]):
            raise ValueError(f"human tremor_band_hz must be (low, high) with 0 < low < high, got {band!r}")


# Between-participant coefficients of variation of the log-normal population. Sourced:
# lapse rate and duration, from Peiris et al. 2006 (39.3 +- 12.9 per hour and
# 3.4 +- 0.5 s, mean +- SE over 15 subjects: SD = SE * sqrt(15)). Assumed, at the size
# of typical between-subject spreads: reaction time 0.15 (SD 30 ms at 0.2 s, within the
# 30-50 ms between-subject SDs of simple visual reaction time), tremor 0.5 (RMS tremor
# of 50-200 um across people at an instrument tip; Riviere et al. 1997 and later
# studies), the others 0.2-0.3. The tremor band, the interval jitter and Fitts'
# intercept are the same for everyone.
POPULATION_CV: Mapping[str, float] = types.MappingProxyType(
    {
        "reaction_time_s": 0.15,
        "correction_interval_s": 0.2,
        "neuromuscular_lag_s": 0.2,
        "extent_error_fraction": 0.3,
        "direction_error_deg": 0.3,
        "signal_dependent_noise": 0.3,
        "tremor_rms_mm": 0.5,
        "preferred_speed_mm_s": 0.3,
        "fitts_b_s_per_bit": 0.2,
        "arm_damping_n_s_per_m": 0.3,
        "arm_mass_kg": 0.2,
        "arm_stiffness_n_per_m": 0.3,
        "lapse_rate_per_h": 12.9 * math.sqrt(15) / 39.3,
        "lapse_duration_s": 0.5 * math.sqrt(15) / 3.4,
    }
)


def sample_population(
    n: int, seed: int, mean: HumanParams = HumanParams(), cv: Mapping[str, float] = POPULATION_CV
) -> list[HumanParams]:
    """``n`` participants: each parameter named in ``cv`` log-normal with mean
    ``getattr(mean, name)`` and coefficient of variation ``cv[name]`` (log-SD
    sigma = sqrt(log(1 + cv^2)), log-mean log(mean) - sigma^2 / 2); the others as in
    ``mean``. Participant ``i`` comes from ``np.random.default_rng([seed, i])``."""
    if not (isinstance(n, (int, np.integer)) and n >= 0):
        raise ValueError(f"population size n must be a non-negative integer, got {n!r}")
    fields = {field.name for field in dataclasses.fields(HumanParams)}
    for name, value in cv.items():
        if name not in fields or name == "tremor_band_hz":
            raise ValueError(f"population cv names {name!r}, not a scalar HumanParams field")
        if not (math.isfinite(value) and value >= 0):
            raise ValueError(f"population cv of {name} must be non-negative, got {value!r}")
    names = sorted(cv)
    sigma = np.array([math.sqrt(math.log1p(cv[name] ** 2)) for name in names])
    means = np.array([getattr(mean, name) for name in names], dtype=np.float64)
    population = []
    for i in range(n):
        draws = np.random.default_rng([seed, i]).standard_normal(len(names))
        values = means * np.exp(sigma * draws - sigma**2 / 2)
        population.append(dataclasses.replace(mean, **{name: float(v) for name, v in zip(names, values)}))
    return population


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

        filters = [_tremor_filter(tuple(p.tremor_band_hz), self.tick_rate_hz) for p in params]
        self._tremor_sos = [sos for sos, _ in filters]
        self._tremor_input_sd = column("tremor_rms_mm") / np.array([math.sqrt(gain) for _, gain in filters])
        self._tremor_state = [np.zeros((sos.shape[0], 2, 2)) for sos in self._tremor_sos]
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
        plus signal-dependent noise, tremor, and the yield F / b_arm to the device's force
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
        """The next ``ticks`` tip offsets (ticks, B, 2) of each participant's tremor:
        white noise through its band-pass, the filter state carried on (the tremor is
        streamed a block ahead of the ticks that use it)."""
        white = self._rng.standard_normal((ticks, self.batch, 2))
        tremor = np.empty_like(white)
        for i, sos in enumerate(self._tremor_sos):
            tremor[:, i], self._tremor_state[i] = signal.sosfilt(
                sos, white[:, i] * self._tremor_input_sd[i], axis=0, zi=self._tremor_state[i]
            )
        return tremor

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
    sos = signal.butter(_TREMOR_FILTER_ORDER, band_hz, btype="bandpass", fs=rate_hz, output="sos")
    impulse = np.zeros(int(math.ceil(4 * TREMOR_WARMUP_S * rate_hz)))
    impulse[0] = 1.0
    gain = float(np.sum(signal.sosfilt(sos, impulse) ** 2))
    return sos, gain
