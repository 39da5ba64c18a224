"""The human model's sourced changes (issue 29, item 5): scale overrides reach the model,
the tremor's power sits in its 8-12 Hz band and the drift's below 2 Hz, and the window's
fine-tune cue and the participants share one threshold."""

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
from scipy import signal

from otgym.human import percept as percept_module
from otgym.human.motor import HumanMotor, _drift_filter, _tremor_filter
from otgym.human.params import HumanParams, sample_population, scaled
from otgym.human.participant_task import ParticipantTask
from otgym.task import task as task_module
from otgym.ui import cues

# no randomness but the involuntary offsets (the hand is never told to move)
QUIET = dataclasses.replace(HumanParams(), extent_error_fraction=0.0, direction_error_deg=0.0)


def test_scale_overrides_reach_the_population_and_the_model():
    """Scale 0 on the tremor and the drift: a resting hand does not move at all (without
    the override it does); scale 2 doubles each participant's tremor, the draws being the
    same."""
    base = sample_population(4, 90, mean=QUIET)
    none = sample_population(4, 90, mean=QUIET, scale={"tremor_rms_mm": 0.0, "drift_rms_mm": 0.0})
    doubled = sample_population(4, 90, mean=QUIET, scale={"tremor_rms_mm": 2.0})
    assert all(p.tremor_rms_mm == 0.0 and p.drift_rms_mm == 0.0 for p in none)
    np.testing.assert_allclose([p.tremor_rms_mm for p in doubled], [2 * p.tremor_rms_mm for p in base])
    assert [p.reaction_time_s for p in doubled] == [p.reaction_time_s for p in base]

    def moved(population):
        motor = HumanMotor(population, 50.0, 1)
        return np.abs(np.array([motor.step() for _ in range(100)])).max()

    assert moved(none) == 0.0
    assert moved(base) > 0.0


def test_lapse_rate_override_zero_means_no_lapse():
    """A population lapsing 3600 times an hour (once a second) lapses within 20 s; the
    same population with its lapse rate scaled by 0 never does. The default rate (short,
    demanding trials: Buckley et al. 2016) is none."""
    lapsing = HumanParams(lapse_rate_per_h=3600.0)

    def lapses(population):
        motor = HumanMotor(population, 50.0, 3)
        seen = False
        for _ in range(1000):
            seen |= bool(motor.lapsed.any())
            motor.step()
        return seen

    assert lapses(sample_population(3, 90, mean=lapsing))
    assert not lapses(sample_population(3, 90, mean=lapsing, scale={"lapse_rate_per_h": 0.0}))
    assert HumanParams().lapse_rate_per_h == 0.0


def test_scaled_refuses_what_is_not_a_scalar_parameter():
    with pytest.raises(ValueError, match="no scalar parameter"):
        scaled(HumanParams(), {"tremor_band_hz": 2.0})
    with pytest.raises(ValueError, match="no scalar parameter"):
        scaled(ParticipantTask(), {"bimanual": 0.5})
    with pytest.raises(ValueError, match="non-negative"):
        scaled(HumanParams(), {"tremor_rms_mm": -1.0})
    assert (
        scaled(ParticipantTask(), {"carry_speed_um_s": 1.5}).carry_speed_um_s
        == 1.5 * ParticipantTask().carry_speed_um_s
    )


def _band_power(sos, gain, rms, rate_hz, low, high):
    """The expected one-sided power in [low, high] Hz of white noise scaled to ``rms``
    through ``sos`` (PSD 2 sigma^2 |H|^2 / fs, sigma^2 = rms^2 / gain)."""
    frequency = np.linspace(low, high, 2001)
    _, response = signal.sosfreqz(sos, worN=frequency, fs=rate_hz)
    return float(np.trapezoid(2 * rms**2 / gain * np.abs(response) ** 2 / rate_hz, frequency))


def test_tremor_power_lies_in_its_band_and_the_drift_below_2_hz():
    """The default hand at rest, 20 participants x 2 axes for 60 s at 50 Hz: its
    displacement's Welch power in 8-12 Hz is the tremor's (0.027 mm RMS, plus the
    drift's little there) and its power in 0.5-2 Hz the drift's (0.022 mm RMS below
    2 Hz; the tremor's band-pass leaves almost none there). Each band power, averaged
    over the 40 series, must lie within 4 standard errors (SD of the 40 series' band
    powers / sqrt(40)) of its expectation from the filters' responses, and the in-band
    power must be over 60 % of the tremor's total (a tremor spread over all frequencies,
    or placed in the drift's band, fails)."""
    rate_hz, n = 50.0, 3000
    params = HumanParams()
    motor = HumanMotor(params, rate_hz, 11, batch=20)
    velocity = np.array([motor.step() for _ in range(n)])
    displacement = np.cumsum(velocity, axis=0) / rate_hz  # (n, 20, 2)
    series = displacement.reshape(n, -1).T
    frequency, power = signal.welch(series, fs=rate_hz, nperseg=int(10 * rate_hz), axis=-1)
    df = frequency[1] - frequency[0]
    tremor = _tremor_filter(params.tremor_band_hz, rate_hz)
    drift = _drift_filter(params.drift_cutoff_hz, rate_hz)
    for low, high in ((8.0, 12.0), (0.5, 2.0)):
        band = (frequency >= low) & (frequency <= high)
        measured = power[:, band].sum(axis=1) * df
        expected = _band_power(*tremor, params.tremor_rms_mm, rate_hz, low - df / 2, high + df / 2) + _band_power(
            *drift, params.drift_rms_mm, rate_hz, low - df / 2, high + df / 2
        )
        se = measured.std(ddof=1) / math.sqrt(len(measured))
        assert abs(measured.mean() - expected) < 4 * se, (low, high, measured.mean(), expected, se)
    in_band = (frequency >= 8.0) & (frequency <= 12.0)
    assert power[:, in_band].sum(axis=1).mean() * df > 0.6 * params.tremor_rms_mm**2


def test_the_fine_tune_cue_and_the_participants_share_one_threshold():
    """One definition (otgym.task.task), imported by the window's cue and by the percept
    the participants act on (the cue as shown); no task parameter of the participants'
    own; and the source has one assignment of it."""
    assert cues.FINE_TUNE_ALPHA is task_module.FINE_TUNE_ALPHA
    assert percept_module.FINE_TUNE_ALPHA is task_module.FINE_TUNE_ALPHA
    assert task_module.FINE_TUNE_ALPHA == 0.4
    assert not any("alpha" in field.name for field in dataclasses.fields(ParticipantTask))
    root = Path(task_module.__file__).parents[1]
    definitions = [path for path in root.rglob("*.py") if "FINE_TUNE_ALPHA =" in path.read_text()]
    assert definitions == [Path(task_module.__file__)]
