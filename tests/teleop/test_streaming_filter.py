"""The streaming second-order-section step against scipy.signal.sosfilt."""

import numpy as np
import pytest
from scipy import signal

from otgym.teleop.streaming_filter import sos_step


@pytest.mark.parametrize("order, cutoff_hz", [(2, 10.0), (3, 3.5), (5, 8.0)])
def test_sample_by_sample_equals_sosfilt_over_a_whole_signal(order, cutoff_hz):
    """500 samples of 2-channel noise at 50 Hz through Butterworth low-passes of odd and
    even order (one section with a zero b2 and a2 for odd orders): the outputs and the
    final state agree with one sosfilt call over the whole signal to 1e-12. Catches
    the two state updates in the wrong order, a sign flipped on a1 or a2, or the state
    not carried between samples."""
    sos = signal.butter(order, cutoff_hz, fs=50.0, output="sos")
    x = np.random.default_rng(order).normal(size=(500, 2))
    expected, final = signal.sosfilt(sos, x, axis=0, zi=np.zeros((sos.shape[0], 2, 2)))
    state = np.zeros((sos.shape[0], 2, 2))
    out = np.array([sos_step(sos, sample, state) for sample in x])
    np.testing.assert_allclose(out, expected, rtol=0, atol=1e-12)
    np.testing.assert_allclose(state, final, rtol=0, atol=1e-12)
    assert np.abs(out).max() > 0.1  # not vacuous: the signal passes
