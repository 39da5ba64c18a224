"""Planar geometry that the task's drivers share (numpy): the autonomy places its
formation with it, the simulated participants their robots."""

from __future__ import annotations

import numpy as np


def rotate(vectors, angle):
    """Rotate (..., T, 2) vectors by ``angle`` (...,) rad."""
    cos, sin = np.cos(angle)[..., None], np.sin(angle)[..., None]
    return np.stack(
        [cos * vectors[..., 0] - sin * vectors[..., 1], sin * vectors[..., 0] + cos * vectors[..., 1]], axis=-1
    )
