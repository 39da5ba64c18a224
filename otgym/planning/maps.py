"""Synthetic maps for the planner's tests and benchmarks.

``random_obstacle_map``: each pixel blocked independently with a given probability,
with its two opposite corners free and 8-connected to each other. (Chip-shaped maps
come from ``otgym.sim.chip``.)
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage


def random_obstacle_map(shape: tuple[int, int], obstacle_fraction: float, seed: int) -> np.ndarray:
    """Free mask with each pixel blocked with probability ``obstacle_fraction``.

    The top-left and bottom-right pixels are free; raises ``ValueError`` if they are
    not 8-connected (then pick another seed).
    """
    rng = np.random.default_rng(seed)
    free = rng.random(shape) >= obstacle_fraction
    free[0, 0] = free[-1, -1] = True
    labels, _ = ndimage.label(free, structure=np.ones((3, 3)))
    if labels[0, 0] != labels[-1, -1]:
        raise ValueError(f"seed {seed}: the corners of the random map are not connected")
    return free
