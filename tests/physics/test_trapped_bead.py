"""Calibration traces of a trapped bead against equipartition and the power spectrum.

Bead 1 um across, k = 10 pN/um: gamma = 6 pi eta a = 8.39e-3 pN s/um, relaxation
time tau = gamma/k = 0.84 ms, corner frequency fc = k / (2 pi gamma) = 190 Hz.
A 40 s trace holds T / (2 tau) = 23,800 effectively independent samples per axis, so
the variance has a relative standard error sqrt(2/23800) = 0.92 % per axis (0.65 % for
both axes together): the 3 % tolerance is 4.6 standard errors. The corner frequency
from a fit of the spectrum has relative error about 1/sqrt(pi fc T) = 0.65 % per axis
(Berg-Sorensen & Flyvbjerg 2004), so 5 % is more than 7 standard errors.
"""

import numpy as np
import pytest
from scipy import optimize, signal

from otgym.physics import simulate_trapped_bead

KT = 1.380649e-5 * 298.15
DIAMETER, STIFFNESS, RATE, DURATION = 1.0, 10.0, 10_000.0, 40.0
GAMMA = 6 * np.pi * 8.9e-4 * DIAMETER / 2


pytestmark = pytest.mark.slow  # module fixtures that compile or solve for seconds


@pytest.fixture(scope="module")
def trace():
    return simulate_trapped_bead(DIAMETER, STIFFNESS, sample_rate_hz=RATE, duration_s=DURATION, seed=3)


def test_trace_shape_and_units(trace):
    assert trace.shape == (int(RATE * DURATION), 2)
    assert np.all(np.isfinite(trace))


def test_position_variance_obeys_equipartition(trace):
    settled = trace[int(0.01 * RATE) :]  # drop 10 ms = 12 relaxation times
    assert settled.var(axis=0).mean() == pytest.approx(KT / STIFFNESS, rel=0.03)


def aliased_lorentzian(f, variance, corner_hz):
    """One-sided PSD of an Ornstein-Uhlenbeck process sampled every 1/RATE
    (exact for discrete samples; Berg-Sorensen & Flyvbjerg 2004, eq. 32)."""
    dt = 1.0 / RATE
    c = np.exp(-2 * np.pi * corner_hz * dt)
    return 2 * variance * dt * (1 - c**2) / (1 + c**2 - 2 * c * np.cos(2 * np.pi * f * dt))


def test_power_spectrum_corner_frequency(trace):
    frequency, psd = signal.welch(trace, fs=RATE, nperseg=8192, axis=0)
    keep = (frequency > 5) & (frequency < 0.4 * RATE)
    expected = STIFFNESS / (2 * np.pi * GAMMA)
    for axis in range(2):
        (variance, corner), _ = optimize.curve_fit(
            aliased_lorentzian, frequency[keep], psd[keep, axis], p0=(KT / STIFFNESS, 100.0), sigma=psd[keep, axis]
        )
        assert corner == pytest.approx(expected, rel=0.05)


def test_free_bead_diffuses_with_stokes_einstein():
    trace = simulate_trapped_bead(1.0, 0.0, sample_rate_hz=1000.0, duration_s=20.0, seed=1)
    steps = np.diff(np.vstack([[0.0, 0.0], trace]), axis=0)  # 40,000 increments
    d = steps.var() * 1000.0 / 2
    assert d == pytest.approx(KT / GAMMA, rel=0.03)  # sqrt(2/40000) = 0.7 %: 4 sigma


@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"diameter_um": -1.0}, "diameter_um"),
        ({"diameter_um": float("nan")}, "diameter_um"),
        ({"stiffness_pn_per_um": -3.0}, "stiffness_pn_per_um"),
        ({"temperature_k": -1.0}, "temperature_k"),
        ({"viscosity_pa_s": 0.0}, "viscosity_pa_s"),
        ({"sample_rate_hz": float("inf")}, "sample_rate_hz"),
        ({"duration_s": 0.0}, "duration_s"),
    ],
)
def test_bad_input_names_the_parameter(kwargs, name):
    arguments = {"diameter_um": 1.0, "stiffness_pn_per_um": 10.0, "duration_s": 0.01}
    arguments.update(kwargs)
    diameter = arguments.pop("diameter_um")
    stiffness = arguments.pop("stiffness_pn_per_um")
    with pytest.raises(ValueError, match=name):
        simulate_trapped_bead(diameter, stiffness, **arguments)
