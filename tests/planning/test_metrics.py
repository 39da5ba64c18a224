"""Table I metrics against paths whose values are known in closed form."""

import math

import numpy as np
import pytest

from otgym.planning.metrics import (
    curvature_spectrum,
    high_frequency_curvature,
    path_length,
    path_metrics,
    resample_by_arc_length,
)


def test_straight_line_has_no_curvature():
    metrics = path_metrics(np.array([[0.0, 0.0], [3.0, 4.0], [6.0, 8.0]]))
    assert metrics.length_um == pytest.approx(10.0)
    assert metrics.mean_curvature_per_um == pytest.approx(0.0, abs=1e-12)
    assert metrics.angular_deviation_deg == pytest.approx(0.0, abs=1e-9)


def test_circle_arc_curvature_is_one_over_radius():
    radius, step = 20.0, 0.25
    angle = np.linspace(0, np.pi, 20001)
    arc = radius * np.column_stack((np.cos(angle), np.sin(angle)))
    metrics = path_metrics(arc, step)
    assert metrics.length_um == pytest.approx(np.pi * radius, rel=1e-6)
    # chords of length h on a circle turn by 2 asin(h / 2R) = h / R to O(h^3)
    assert metrics.mean_curvature_per_um == pytest.approx(1 / radius, rel=1e-3)
    assert metrics.angular_deviation_deg == pytest.approx(math.degrees(step / radius), rel=1e-3)


def test_angular_deviation_of_a_square_corner_path():
    # two corners of 90 degrees on a 3-sided path; resampling at 0.5 um puts the
    # corners on sample points, so the turning is exactly 2 * 90 degrees over N - 1 angles
    path = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]])
    points = resample_by_arc_length(path, 0.5)
    turns = len(points) - 2
    assert path_metrics(path, 0.5).angular_deviation_deg == pytest.approx(180.0 / turns)


def test_spectrum_peaks_at_the_path_wavelength():
    x = np.linspace(0, 400, 40001)
    wavy = np.column_stack((x, 0.05 * np.sin(2 * np.pi * x / 8.0)))  # small amplitude: s ~ x
    frequency, amplitude = curvature_spectrum(wavy, 0.25)
    assert frequency[np.argmax(amplitude)] == pytest.approx(1 / 8.0, rel=0.02)


def test_high_frequency_curvature_separates_jitter_from_smooth_bends():
    x = np.linspace(0, 200, 20001)
    slow = np.column_stack((x, 2.0 * np.sin(2 * np.pi * x / 100.0)))  # 0.01 cycles/um
    fast = np.column_stack((x, 0.02 * np.sin(2 * np.pi * x / 2.0)))  # 0.5 cycles/um
    assert high_frequency_curvature(slow) < 0.01 * high_frequency_curvature(fast)


def test_bad_paths_are_rejected():
    with pytest.raises(ValueError, match="two"):
        path_length(np.array([[0.0, 1.0]]))
    with pytest.raises(ValueError, match="NaN"):
        path_length(np.array([[0.0, 1.0], [np.inf, 0.0]]))
    with pytest.raises(ValueError, match="step"):
        resample_by_arc_length(np.array([[0.0, 0.0], [1.0, 0.0]]), -1.0)


def test_pauses_and_repeated_points_do_not_change_the_metrics():
    path = np.array([[0.0, 0.0], [5.0, 0.0], [5.0, 0.0], [5.0, 5.0]])
    assert path_metrics(path) == path_metrics(path[[0, 1, 3]])
