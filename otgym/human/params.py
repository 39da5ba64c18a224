"""The parameters of otgym's one human motor model (``HumanParams``, simulated by
``otgym.human.motor.HumanMotor``) and the population they are drawn from
(``sample_population``). Units: mm and mm/s at the stylus tip, s, newton (N) for the
haptic device's force. Planar: the two stylus axes.

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
* **Physiological tremor** ``tremor_rms_mm`` (0.027 mm per axis) in ``tremor_band_hz``
  (8-12 Hz; McAuley & Marsden, Brain 123, 1545, 2000): Gaussian white noise through a
  4th-order Butterworth band-pass per participant, streamed (filtered one second ahead
  of the ticks that use it, the filter state carried on, also across ``reset``; warmed
  up for ``TREMOR_WARMUP_S`` at construction so it is stationary from the first tick)
  and scaled by the filter's noise gain so that the tip's displacement has exactly that
  RMS; the hand's velocity gets its tick-to-tick difference. The amplitude is the
  tremor alone: 38 um RMS (vector magnitude) at the instrument tip of a surgeon during
  the most delicate part of retinal microsurgery, measured apart from the lower-frequency
  motion (Singh & Riviere, Proc. IEEE 28th Northeast Bioeng. Conf., 171, 2002); the tip
  moves little along the instrument (5 um against 45-63 um RMS across it: Becker,
  Tummala & Riviere, IEEE EMBC 2008, 1948), so the magnitude lies in the two lateral
  axes, 38 / sqrt(2) = 27 um each.
* **Slow drift** ``drift_rms_mm`` (0.022 mm per axis) below ``drift_cutoff_hz`` (2 Hz):
  the rest of the hold error. Eye surgeons holding an instrument still move its tip by
  49 um RMS in all, with substantial low-frequency motion, the power of their voluntary
  movements lying below 2 Hz (98.9 % on average; Riviere, Rader & Khosla, IEEE EMBS
  1997, 1690). The 49 um were all tremor in earlier versions of this model (tremor
  0.05 mm per axis in 8-12 Hz); now the tremor's 38 um take their share of the power
  and the drift the rest, sqrt(49^2 - 38^2) = 31 um, 22 um per lateral axis. Streamed
  like the tremor, through a 2nd-order Butterworth low-pass at ``drift_cutoff_hz``
  (the filter's order is assumed), added to the tremor's displacement. The hand's
  corrections see the drift and correct it like any other error; the same for everyone
  (no between-participant spread is known: assumed).
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
* **Lapses of responsiveness** ``lapse_rate_per_h`` (0 per hour) lasting
  ``lapse_duration_s`` (3.4 s on average, exponentially distributed). During a lapse no
  sub-movement starts (the current one runs out and the hand stops); a correction
  follows as soon as it ends. Lapses start as a Poisson process in time. Rested
  subjects in a one-hour continuous monotonous visuomotor tracking task stop responding
  39.3 times an hour, for 3.4 s on average (Peiris, Jones, Davidson, Carroll & Bones,
  J. Sleep Res. 15, 291, 2006; ``MONOTONOUS_TRACKING_LAPSE_RATE_PER_H``), but such
  lapses (behavioural microsleeps) grow with time on task and fall with the task's
  demand: in a tracking task combined with a reaction-time task the median rested
  participant had none and none had more than one, against up to 18 in tracking alone
  (Buckley, Helton, Innes, Dalrymple-Alford & Jones, Conscious. Cogn. 45, 174, 2016).
  The study's trials last 1-3 minutes and demand both hands, an obstacle watch and a
  grip, so the default is the median participant of the demanding task: none. (The
  attention lapses of a reaction-time test, responses slower than 500 ms, are the slow
  tail of the reaction time, not seconds without response.) Earlier versions applied
  Peiris' rate to the study's trials.
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
(``POPULATION_CV``, sources there), the means optionally scaled (``scale``, through
``scaled``: what ``otgym experiment human-sensitivity`` varies). Participant ``i`` of
seed ``s`` is drawn from its own stream ``(s, i)``, so it is the same participant
whatever the population's size. Every parameter, its source or "assumed", and how much
the study's result moves with each assumed one: docs/human-model.md.
"""

from __future__ import annotations

import dataclasses
import math
import types
from collections.abc import Mapping

import numpy as np

MONOTONOUS_TRACKING_LAPSE_RATE_PER_H = 39.3
"""Lapses of responsiveness per hour of rested subjects in one hour of monotonous
continuous tracking (Peiris et al. 2006): for long monotonous sessions, not the default
(``HumanParams.lapse_rate_per_h``)."""


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
    tremor_rms_mm: float = 0.027
    tremor_band_hz: tuple[float, float] = (8.0, 12.0)
    drift_rms_mm: float = 0.022
    drift_cutoff_hz: float = 2.0
    preferred_speed_mm_s: float = 20.0
    fitts_a_s: float = 0.0128
    fitts_b_s_per_bit: float = 0.0947
    arm_damping_n_s_per_m: float = 7.0
    arm_mass_kg: float = 1.5
    arm_stiffness_n_per_m: float = 300.0
    lapse_rate_per_h: float = 0.0
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
            "drift_cutoff_hz",
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
            "drift_rms_mm",
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
# lapse rate (moot at the default rate 0) and duration, from Peiris et al. 2006 (39.3 +- 12.9 per hour and
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


def scaled(params, scale: Mapping[str, float]):
    """A copy of the frozen dataclass ``params`` (``HumanParams``, or the participants'
    ``ParticipantTask``) with each scalar field named in ``scale`` multiplied by its
    factor (finite, non-negative); the class's own checks apply to the result."""
    fields = {field.name: field for field in dataclasses.fields(params)}
    changes = {}
    for name, factor in scale.items():
        value = getattr(params, name, None) if name in fields else None
        if not isinstance(value, (int, float)) or isinstance(value, bool):
            raise ValueError(f"{type(params).__name__} has no scalar parameter {name!r}")
        if not (isinstance(factor, (int, float)) and math.isfinite(factor) and factor >= 0):
            raise ValueError(f"scale factor of {name} must be finite and non-negative, got {factor!r}")
        changes[name] = value * factor
    return dataclasses.replace(params, **changes)


def sample_population(
    n: int,
    seed: int,
    mean: HumanParams = HumanParams(),
    cv: Mapping[str, float] = POPULATION_CV,
    scale: Mapping[str, float] | None = None,
) -> list[HumanParams]:
    """``n`` participants: each parameter named in ``cv`` log-normal with mean
    ``getattr(mean, name)`` (times ``scale[name]`` where ``scale`` names it: ``scaled``)
    and coefficient of variation ``cv[name]`` (log-SD sigma = sqrt(log(1 + cv^2)),
    log-mean log(mean) - sigma^2 / 2); the others as in ``mean`` (scaled alike).
    Participant ``i`` comes from ``np.random.default_rng([seed, i])``, the same draws
    whatever ``mean`` and ``scale``."""
    if scale:
        mean = scaled(mean, scale)
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
