"""Signed distance field of a chip's side walls, for wall contact and van der Waals.

The wall is the 0.5 iso-line of the chip image under bilinear interpolation of the
pixel centres (marching squares, ``skimage.measure.find_contours``), so anti-aliased
images give sub-pixel walls. The image is padded with solid, so the image border is a
wall too (bodies stay on the chip; flow still enters and leaves through the ports).
The distance of each pixel centre is the Euclidean distance to that polyline, sampled
densely and queried with a k-d tree; the sign is + in the fluid (gray > 0.5). The
unit normal (wall -> fluid) is the normalised gradient of that field.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree
from skimage.measure import find_contours
from skimage.morphology import skeletonize

from otgym.sim.chip import Chip

CONTOUR_SAMPLE_PX = 0.05
"""Spacing of the points sampled along the wall polyline, in pixels."""


def wall_points_px(image: np.ndarray) -> np.ndarray:
    """Dense points (K, 2) as (row, col) pixel-centre coordinates on the wall."""
    padded = np.pad(image, 1, constant_values=0.0)
    pieces = []
    for contour in find_contours(padded, 0.5):
        start, end = contour[:-1], contour[1:]
        length = np.linalg.norm(end - start, axis=1)
        counts = np.maximum(np.ceil(length / CONTOUR_SAMPLE_PX).astype(int), 1)
        owner = np.repeat(np.arange(start.shape[0]), counts)
        fraction = (np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)) / counts[owner]
        pieces.append(start[owner] + fraction[:, None] * (end - start)[owner])
    return np.concatenate(pieces) - 1.0


def signed_distance_um(chip: Chip) -> np.ndarray:
    """(H, W) signed distance in um at the pixel centres, positive in the fluid."""
    rows, cols = chip.shape
    centres = np.stack(np.meshgrid(np.arange(rows), np.arange(cols), indexing="ij"), axis=-1).reshape(-1, 2)
    distance, _ = cKDTree(wall_points_px(chip.image)).query(centres)
    sign = np.where(chip.fluid.reshape(-1), 1.0, -1.0)
    return (sign * distance * chip.pixel_size_um).reshape(rows, cols)


def wall_normals(distance_um: np.ndarray) -> np.ndarray:
    """(H, W, 2) unit (x, y) normals pointing from the wall into the fluid; where the
    gradient vanishes (on a ridge of the field) the normal is +x."""
    d_row, d_col = np.gradient(distance_um)
    normal = np.stack([d_col, d_row], axis=-1)
    norm = np.linalg.norm(normal, axis=-1, keepdims=True)
    return np.where(norm > 1e-9, normal / np.maximum(norm, 1e-9), np.array([1.0, 0.0]))


def channel_widths_um(chip: Chip, distance_um: np.ndarray) -> np.ndarray:
    """Local channel widths: twice the wall distance along the fluid's skeleton
    (medial axis), one value per skeleton pixel. Skeleton pixels nearer the image
    border than to a wall are left out (there the border, open at the ports, would
    count as a wall), unless that leaves none."""
    skeleton = skeletonize(chip.fluid)
    rows, cols = np.indices(chip.shape)
    to_border = chip.pixel_size_um * (
        np.minimum(np.minimum(rows, chip.shape[0] - 1 - rows), np.minimum(cols, chip.shape[1] - 1 - cols)) + 0.5
    )
    inner = skeleton & (to_border > distance_um)
    return 2.0 * distance_um[inner if inner.any() else skeleton]
