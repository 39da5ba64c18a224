"""The default chip, generated in code (paper section II-B): four branches, two inlets
on the left edge and two outlets on the right edge, channels 25 um wide and 50 um tall,
meeting in a central chamber that holds four static pillars. 300 x 200 um at 0.5 um
per pixel.

Each inlet carries 5000 um^3/s (0.3 nL/min): a mean speed of 4 um/s in a branch
(5000 / (25 * 50)), gentle enough for the paper's trap law (escape force about 0.3 pN
per handle). The flow is linear in the rates, so a scene can rescale it.

The shipped ``otgym/data/chips/default.png`` and ``default.json`` are
``save_chip(default_chip(), CHIP_DATA_DIR)`` (``otgym.sim.chip``); a test checks that they
match this generator.
"""

from __future__ import annotations

import numpy as np

from otgym.sim.chip import Chip, Port

SIZE_UM = (300.0, 200.0)
PIXEL_SIZE_UM = 0.5
CHANNEL_WIDTH_UM = 25.0
CHANNEL_HEIGHT_UM = 50.0
INLET_FLOW_UM3_S = 5000.0
CHAMBER_CENTRE_UM = (150.0, 100.0)
CHAMBER_RADIUS_UM = 40.0
PILLARS_UM = ((150.0, 72.0, 5.0), (150.0, 128.0, 5.0), (122.0, 100.0, 4.0), (178.0, 100.0, 4.0))
"""(x, y, radius) of the static pillars in the chamber. They stand between the branch
mouths, not in them, so the cooperative-transport assembly (two robots and a cell,
about 17.4 um across) can pass from any branch to any other: every pillar is at least
12.8 um from every branch axis. The layout keeps the chip mirror-symmetric."""
BRANCHES_UM = (
    ((0.0, 40.0), (70.0, 40.0)),
    ((0.0, 160.0), (70.0, 160.0)),
    ((300.0, 40.0), (230.0, 40.0)),
    ((300.0, 160.0), (230.0, 160.0)),
)
"""Each branch: a straight run from its port, then a diagonal into the chamber."""
TRANSPORT_START_UM = (15.0, 40.0)
TRANSPORT_GOAL_UM = (285.0, 160.0)
"""The chip's sites ``start`` and ``goal``: 15 um into the top-left inlet branch and the
bottom-right outlet branch, so a route crosses the chamber between the pillars."""


def _segment_distance(points: np.ndarray, start, end) -> np.ndarray:
    start, end = np.asarray(start), np.asarray(end)
    direction = end - start
    t = np.clip(((points - start) @ direction) / (direction @ direction), 0.0, 1.0)
    return np.linalg.norm(points - (start + t[..., None] * direction), axis=-1)


def default_chip_distance_um(points_um: np.ndarray) -> np.ndarray:
    """Exact signed distance (positive in the fluid) of the default geometry."""
    half_width = CHANNEL_WIDTH_UM / 2
    centre = np.asarray(CHAMBER_CENTRE_UM)
    inside = CHAMBER_RADIUS_UM - np.linalg.norm(points_um - centre, axis=-1)
    for port_end, bend in BRANCHES_UM:
        inside = np.maximum(inside, half_width - _segment_distance(points_um, port_end, bend))
        inside = np.maximum(inside, half_width - _segment_distance(points_um, bend, centre))
    for x, y, radius in PILLARS_UM:
        inside = np.minimum(inside, np.linalg.norm(points_um - (x, y), axis=-1) - radius)
    return inside


def default_chip(pixel_size_um: float = PIXEL_SIZE_UM) -> Chip:
    """Rasterise the default geometry, anti-aliased (gray = 0.5 + distance / pixel)."""
    cols, rows = int(round(SIZE_UM[0] / pixel_size_um)), int(round(SIZE_UM[1] / pixel_size_um))
    x = (np.arange(cols) + 0.5) * pixel_size_um
    y = (np.arange(rows) + 0.5) * pixel_size_um
    points = np.stack(np.meshgrid(x, y), axis=-1)
    image = np.clip(0.5 + default_chip_distance_um(points) / pixel_size_um, 0.0, 1.0)
    names = ("inlet_top", "inlet_bottom", "outlet_top", "outlet_bottom")
    ports = tuple(
        Port(name, name.split("_")[0], port_end, INLET_FLOW_UM3_S) for name, (port_end, _) in zip(names, BRANCHES_UM)
    )
    sites = (("start", TRANSPORT_START_UM), ("goal", TRANSPORT_GOAL_UM))
    return Chip("default", image, pixel_size_um, CHANNEL_HEIGHT_UM, ports, sites)
