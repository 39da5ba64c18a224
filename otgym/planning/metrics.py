"""Path metrics of the paper's Table I and its frequency-domain smoothness analysis.

Any path -- planned, smoothed or a recorded trajectory -- is an ``(n, 2)`` array of
points (x_um, y_um) joined by straight segments. Curvature-type metrics depend on how
densely a path is sampled, so they are computed on the path resampled at a uniform
arc-length step ``h`` (default 0.25 um): points p_0..p_N placed every h along the
polyline (linear interpolation; repeated points and pauses vanish). With headings
theta_j = atan2(p_{j+1,y} - p_{j,y}, p_{j+1,x} - p_{j,x}) and turning angles
dtheta_j = wrap(theta_{j+1} - theta_j) in (-pi, pi]:

* total length:        L = sum_i |p_{i+1} - p_i| over the original points (um);
* mean curvature:      kappa_mean = (1 / (N - 1)) sum_j |dtheta_j| / h (1/um), the mean
  of the discrete curvature |d theta / d s|;
* angular deviation:   (1 / (N - 1)) sum_j |dtheta_j| in degrees, the mean absolute
  heading change between consecutive steps.

At a fixed h the two curvature metrics are proportional (kappa_mean = angular
deviation * pi / 180 / h); both are reported so that the rows compare column by
column with the paper's Table I, whose values depend on its own (unpublished)
sampling. Ratios between rows are what carries over.

* curvature spectrum: the one-sided amplitude spectrum of the signed curvature
  kappa_j = dtheta_j / h against arc length, |FFT(w (kappa - mean kappa))| * 2 / sum w
  with a Hann window w, at spatial frequencies k / (N_k h) cycles/um;
* high-frequency curvature: the RMS of the curvature's components above a cutoff
  spatial frequency (default 0.1 cycles/um, wavelengths shorter than 10 um, the size
  of the paper's robot: features no channel geometry needs), by Parseval's theorem on
  the unwindowed FFT. Jitter and sharp grid turns put power there; a smooth curve
  does not.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

DEFAULT_STEP_UM = 0.25
DEFAULT_CUTOFF_PER_UM = 0.1


@dataclasses.dataclass(frozen=True)
class PathMetrics:
    """Table I metrics of one path (see the module docstring for the formulas)."""

    length_um: float
    mean_curvature_per_um: float
    angular_deviation_deg: float
    hf_curvature_rms_per_um: float


def path_length(path_um: np.ndarray) -> float:
    """Total length of a polyline (um)."""
    path_um = _check_path(path_um)
    return float(np.linalg.norm(np.diff(path_um, axis=0), axis=1).sum())


def resample_by_arc_length(path_um: np.ndarray, step_um: float = DEFAULT_STEP_UM) -> np.ndarray:
    """Points every ``step_um`` along a polyline, starting at its first point."""
    path_um = _check_path(path_um)
    if not (step_um > 0 and math.isfinite(step_um)):
        raise ValueError(f"resampling step must be a positive number of um, got {step_um!r}")
    arc = np.concatenate(([0.0], np.cumsum(np.linalg.norm(np.diff(path_um, axis=0), axis=1))))
    targets = np.arange(0.0, arc[-1] + 1e-12, step_um)
    keep = np.concatenate(([True], np.diff(arc) > 0))  # np.interp needs increasing abscissae
    return np.column_stack([np.interp(targets, arc[keep], path_um[keep, axis]) for axis in (0, 1)])


def turning_angles(path_um: np.ndarray, step_um: float = DEFAULT_STEP_UM) -> np.ndarray:
    """Signed heading changes dtheta_j (rad) of the path resampled every ``step_um``."""
    points = resample_by_arc_length(path_um, step_um)
    heading = np.arctan2(*np.diff(points, axis=0).T[::-1])
    return np.angle(np.exp(1j * np.diff(heading)))


def curvature_spectrum(path_um: np.ndarray, step_um: float = DEFAULT_STEP_UM) -> tuple[np.ndarray, np.ndarray]:
    """(spatial frequency in cycles/um, amplitude in 1/um) of the signed curvature."""
    curvature = turning_angles(path_um, step_um) / step_um
    if curvature.size < 2:
        return np.zeros(0), np.zeros(0)
    window = np.hanning(curvature.size)
    amplitude = np.abs(np.fft.rfft(window * (curvature - curvature.mean()))) * 2.0 / window.sum()
    return np.fft.rfftfreq(curvature.size, d=step_um), amplitude


def high_frequency_curvature(
    path_um: np.ndarray, step_um: float = DEFAULT_STEP_UM, cutoff_per_um: float = DEFAULT_CUTOFF_PER_UM
) -> float:
    """RMS (1/um) of the curvature components above ``cutoff_per_um`` cycles/um."""
    curvature = turning_angles(path_um, step_um) / step_um
    if curvature.size == 0:
        return 0.0
    spectrum = np.fft.rfft(curvature)
    spectrum[np.fft.rfftfreq(curvature.size, d=step_um) <= cutoff_per_um] = 0.0
    return float(np.sqrt(np.mean(np.fft.irfft(spectrum, n=curvature.size) ** 2)))


def path_metrics(
    path_um: np.ndarray, step_um: float = DEFAULT_STEP_UM, cutoff_per_um: float = DEFAULT_CUTOFF_PER_UM
) -> PathMetrics:
    """All Table I metrics of one path."""
    turns = np.abs(turning_angles(path_um, step_um))
    mean_turn = float(turns.mean()) if turns.size else 0.0
    return PathMetrics(
        length_um=path_length(path_um),
        mean_curvature_per_um=mean_turn / step_um,
        angular_deviation_deg=math.degrees(mean_turn),
        hf_curvature_rms_per_um=high_frequency_curvature(path_um, step_um, cutoff_per_um),
    )


def _check_path(path_um) -> np.ndarray:
    path_um = np.asarray(path_um, dtype=np.float64)
    if path_um.ndim != 2 or path_um.shape[1] != 2 or path_um.shape[0] < 2:
        raise ValueError(f"a path needs at least two (x_um, y_um) points, got shape {path_um.shape}")
    if not np.all(np.isfinite(path_um)):
        raise ValueError("a path contains NaN or infinite coordinates")
    return path_um
