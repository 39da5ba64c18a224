"""Input checks shared by the physics layer: every failure is a ValueError that names
the offending parameter, so a bad configuration never turns into a silent NaN."""

from __future__ import annotations

import math

import numpy as np


def require_finite(name: str, value) -> np.ndarray:
    array = np.asarray(value, dtype=float)
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return array


def require_positive(name: str, value) -> np.ndarray:
    array = require_finite(name, value)
    if not np.all(array > 0):
        raise ValueError(f"{name} must be positive, got {value!r}")
    return array


def require_non_negative(name: str, value) -> np.ndarray:
    array = require_finite(name, value)
    if not np.all(array >= 0):
        raise ValueError(f"{name} must be non-negative, got {value!r}")
    return array


def require_shape(name: str, array: np.ndarray, shape: tuple) -> None:
    """Check ``array.shape`` against ``shape``; ``None`` entries match any size."""
    actual = np.shape(array)
    if len(actual) != len(shape) or any(
        expected is not None and expected != got for expected, got in zip(shape, actual)
    ):
        wanted = tuple("*" if s is None else s for s in shape)
        raise ValueError(f"{name} must have shape {wanted}, got {actual}")


def require_positive_scalar(name: str, value: float) -> float:
    if not isinstance(value, (int, float, np.floating, np.integer)) or isinstance(value, bool):
        raise ValueError(f"{name} must be a number, got {value!r}")
    if not math.isfinite(value) or value <= 0:
        raise ValueError(f"{name} must be positive and finite, got {value!r}")
    return float(value)
