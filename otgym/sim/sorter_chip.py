"""The sorting chip of the ``sort-cells`` task, generated in code: one inlet channel on
the left edge, 40 um wide, that splits at a Y junction into two branches, 30 um wide,
ending in two outlets on the right edge; channels 50 um tall; 240 x 120 um at 1 um per
pixel. The inlet carries 20,000 um^3/s (1.2 nL/min, a mean speed of 10 um/s in the
inlet channel) and each outlet takes half, so the flow divides on the inlet's axis: a
cell above it leaves by the top outlet (``outlet_a``), one below by the bottom one
(``outlet_b``). The sidecar names the junction as the site ``junction``.

The shipped ``otgym/data/chips/sorter.png`` and ``sorter.json`` are
``save_chip(sorter_chip(), CHIP_DATA_DIR)`` (``otgym.sim.chip``); a test checks that they
match this generator.
"""

from __future__ import annotations

import numpy as np

from otgym.sim.chip import Chip, Port
from otgym.sim.default_chip import _segment_distance

NAME = "sorter"
SIZE_UM = (240.0, 120.0)
PIXEL_SIZE_UM = 1.0
CHANNEL_HEIGHT_UM = 50.0
INLET_WIDTH_UM = 40.0
BRANCH_WIDTH_UM = 30.0
INLET_FLOW_UM3_S = 20000.0
JUNCTION_UM = (130.0, 60.0)
INLET_UM = (0.0, 60.0)
BRANCHES_UM = (((175.0, 25.0), (240.0, 25.0)), ((175.0, 95.0), (240.0, 95.0)))
"""Each branch: a diagonal from the junction to a bend, then straight to its outlet."""


def sorter_distance_um(points_um: np.ndarray) -> np.ndarray:
    """Signed distance (positive in the fluid) of the sorter's channels."""
    inside = INLET_WIDTH_UM / 2 - _segment_distance(points_um, INLET_UM, JUNCTION_UM)
    for bend, port in BRANCHES_UM:
        inside = np.maximum(inside, BRANCH_WIDTH_UM / 2 - _segment_distance(points_um, JUNCTION_UM, bend))
        inside = np.maximum(inside, BRANCH_WIDTH_UM / 2 - _segment_distance(points_um, bend, port))
    return inside


def sorter_chip(pixel_size_um: float = PIXEL_SIZE_UM) -> Chip:
    """Rasterise the sorter, anti-aliased (gray = 0.5 + distance / pixel)."""
    cols, rows = int(round(SIZE_UM[0] / pixel_size_um)), int(round(SIZE_UM[1] / pixel_size_um))
    x = (np.arange(cols) + 0.5) * pixel_size_um
    y = (np.arange(rows) + 0.5) * pixel_size_um
    image = np.clip(0.5 + sorter_distance_um(np.stack(np.meshgrid(x, y), axis=-1)) / pixel_size_um, 0.0, 1.0)
    ports = (
        Port("inlet", "inlet", INLET_UM, INLET_FLOW_UM3_S),
        Port("outlet_a", "outlet", BRANCHES_UM[0][1], INLET_FLOW_UM3_S / 2),
        Port("outlet_b", "outlet", BRANCHES_UM[1][1], INLET_FLOW_UM3_S / 2),
    )
    return Chip(NAME, image, pixel_size_um, CHANNEL_HEIGHT_UM, ports, (("junction", JUNCTION_UM),))
