"""Synthetic maps for the planner's tests and benchmarks (not the simulator's chip).

* ``random_obstacle_map``: each pixel blocked independently with a given probability,
  with its two opposite corners free and 8-connected to each other.
* ``branch_chip_image``: a grayscale image in the layout of the paper's chip (section
  II-B): two inlets on the left merge into a main channel that opens into a chamber
  with static pillars and splits into two outlets on the right; channels 25 um wide.
  Channels are bright (1.0) and solid dark (0.0). The simulator's own default chip
  (``otgym.sim``) replaces this wherever it is available.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

# (x_um, y_um) polylines of the channel centre lines of the 400 x 300 um chip
_CHANNELS = (
    ((0.0, 70.0), (80.0, 70.0), (120.0, 150.0)),  # inlet 1
    ((0.0, 230.0), (80.0, 230.0), (120.0, 150.0)),  # inlet 2
    ((120.0, 150.0), (280.0, 150.0)),  # main channel
    ((280.0, 150.0), (320.0, 70.0), (400.0, 70.0)),  # outlet 1
    ((280.0, 150.0), (320.0, 230.0), (400.0, 230.0)),  # outlet 2
)
_CHAMBER = ((160.0, 120.0), (240.0, 180.0))  # x0, y0, x1, y1 of the pillar chamber
_PILLARS = ((180.0, 138.0, 6.0), (200.0, 162.0, 6.0), (220.0, 138.0, 6.0))  # x, y, radius
CHIP_SIZE_UM = (400.0, 300.0)
CHIP_START_UM = (10.0, 70.0)
CHIP_GOAL_UM = (390.0, 230.0)


def branch_chip_image(pixel_size_um: float = 1.0, channel_width_um: float = 25.0) -> np.ndarray:
    """The synthetic four-branch chip as a float image (channels 1.0, solid 0.0)."""
    width = int(round(CHIP_SIZE_UM[0] / pixel_size_um))
    height = int(round(CHIP_SIZE_UM[1] / pixel_size_um))
    y, x = (np.mgrid[0:height, 0:width] + 0.5) * pixel_size_um
    channel = np.zeros((height, width), dtype=bool)
    for line in _CHANNELS:
        for (ax, ay), (bx, by) in zip(line[:-1], line[1:]):
            channel |= _distance_to_segment(x, y, ax, ay, bx, by) <= channel_width_um / 2
    (cx0, cy0), (cx1, cy1) = _CHAMBER
    channel |= (x >= cx0) & (x <= cx1) & (y >= cy0) & (y <= cy1)
    for px, py, radius in _PILLARS:
        channel &= np.hypot(x - px, y - py) > radius
    return channel.astype(np.float64)


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


def _distance_to_segment(x, y, ax, ay, bx, by):
    dx, dy = bx - ax, by - ay
    t = np.clip(((x - ax) * dx + (y - ay) * dy) / (dx * dx + dy * dy), 0.0, 1.0)
    return np.hypot(x - (ax + t * dx), y - (ay + t * dy))
