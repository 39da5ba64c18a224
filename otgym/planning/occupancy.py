"""Occupancy maps: chip image -> binary free map -> map dilated by the robot's size.

Conventions used by the whole ``otgym.planning`` package:

* A chip image is grayscale with channels bright and solid dark. A *free mask* is a
  boolean array, True where the robot may be (channel), indexed ``[row, column]``.
* Physical coordinates are in micrometres with the origin at the image's top-left
  corner, x to the right (x = column * pixel size) and y downward
  (y = row * pixel size). Pixel ``(row, col)`` covers the square
  ``[col, col + 1) x [row, row + 1)`` in pixel units, so its centre is at
  ``((col + 0.5) * pixel_size_um, (row + 0.5) * pixel_size_um)``.

The dilation follows the paper (section II-C): obstacles grow by the robot's radius
plus a safety margin so that the planner can treat the robot as a point. It is exact
Euclidean (disk) dilation measured between pixel centres, computed from the distance
transform (scipy.ndimage.distance_transform_edt): a pixel stays free when its centre is
farther than ``clearance`` from the centre of every obstacle pixel. Any point of a free
pixel's square is then at least ``clearance - sqrt(2)`` pixels from every obstacle
pixel's square (half a diagonal on each side), which is why the default margin is
``sqrt(2)`` pixels: with it, a robot disk centred anywhere in a free pixel never
overlaps an obstacle pixel.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from scipy import ndimage
from skimage.filters import threshold_otsu


def binarise(image: np.ndarray, threshold: float | str = "otsu") -> np.ndarray:
    """Free mask of a grayscale chip image (True = channel).

    ``threshold`` is a grey level (pixels strictly brighter are free) or ``"otsu"``
    for Otsu's method (Otsu, IEEE Trans. SMC 9, 62, 1979), which picks the level that
    maximises the between-class variance of channel and solid. A boolean array is
    taken as a free mask already and returned as is.
    """
    image = np.asarray(image)
    if image.ndim != 2 or image.size == 0:
        raise ValueError(f"chip image must be a non-empty 2-D array, got shape {image.shape}")
    if image.dtype == bool:
        return image
    image = image.astype(np.float64)
    if not np.all(np.isfinite(image)):
        raise ValueError("chip image contains NaN or infinite values")
    if isinstance(threshold, str):
        if threshold != "otsu":
            raise ValueError(f"threshold must be a number or 'otsu', got {threshold!r}")
        if image.min() == image.max():
            raise ValueError(
                f"chip image is uniform (every pixel {image.min():g}): Otsu cannot separate "
                "channels from solid; pass a fixed threshold"
            )
        threshold = float(threshold_otsu(image))
    elif not math.isfinite(threshold):
        raise ValueError(f"threshold must be finite, got {threshold!r}")
    return image > threshold


def dilate_obstacles(free: np.ndarray, clearance_px: float) -> np.ndarray:
    """Free mask with obstacles grown by a disk of radius ``clearance_px`` pixels.

    A pixel stays free when the distance from its centre to the nearest obstacle
    pixel centre is larger than ``clearance_px``. Outside the image is not an
    obstacle (the image is all that is known of the chip).
    """
    if clearance_px < 0 or not math.isfinite(clearance_px):
        raise ValueError(f"clearance must be a finite non-negative number of pixels, got {clearance_px!r}")
    if free.all():
        return free.copy()
    return ndimage.distance_transform_edt(free) > clearance_px


@dataclasses.dataclass(frozen=True)
class OccupancyMap:
    """A chip's free space at pixel resolution, before and after dilation.

    ``free`` is the binarised chip, ``planning`` the free mask after dilating the
    obstacles by ``clearance_um`` = robot radius + margin. Coordinates: um, origin at
    the image's top-left corner, x right, y down, pixel centres at +0.5 pixel.
    """

    free: np.ndarray
    planning: np.ndarray
    pixel_size_um: float
    clearance_um: float

    @property
    def shape(self) -> tuple[int, int]:
        return self.free.shape

    def to_pixel(self, point_um, name: str = "point") -> tuple[int, int]:
        """(row, col) of the pixel containing a point given in um; error if outside."""
        x_um, y_um = _as_point(point_um, name)
        col = math.floor(x_um / self.pixel_size_um)
        row = math.floor(y_um / self.pixel_size_um)
        height, width = self.free.shape
        if not (0 <= row < height and 0 <= col < width):
            raise ValueError(
                f"{name} ({x_um:g}, {y_um:g}) um is outside the image "
                f"(0..{width * self.pixel_size_um:g} x 0..{height * self.pixel_size_um:g} um)"
            )
        return row, col

    def require_free(self, point_um, name: str) -> tuple[int, int]:
        """Pixel of a start or goal point; a clear error if it is not plannable."""
        row, col = self.to_pixel(point_um, name)
        x_um, y_um = _as_point(point_um, name)
        if not self.free[row, col]:
            raise ValueError(f"{name} ({x_um:g}, {y_um:g}) um is inside an obstacle")
        if not self.planning[row, col]:
            raise ValueError(
                f"{name} ({x_um:g}, {y_um:g}) um is closer to a wall than the robot radius plus "
                f"margin ({self.clearance_um:g} um): inside the dilated obstacles"
            )
        return row, col


def build_occupancy(
    image: np.ndarray,
    pixel_size_um: float,
    robot_radius_um: float,
    margin_um: float | None = None,
    threshold: float | str = "otsu",
) -> OccupancyMap:
    """Binarise a chip image and dilate its obstacles by robot radius + margin.

    ``margin_um`` defaults to sqrt(2) pixels, the discretisation bound explained in
    the module docstring. Raises ``ValueError`` when the image has no channel, or
    when the robot is larger than every channel (nothing stays free after dilation),
    naming the widest clearance the chip allows.
    """
    pixel_size_um = _positive("pixel size (um)", pixel_size_um)
    robot_radius_um = _non_negative("robot radius (um)", robot_radius_um)
    margin_um = math.sqrt(2.0) * pixel_size_um if margin_um is None else _non_negative("margin (um)", margin_um)
    free = binarise(image, threshold)
    if not free.any():
        raise ValueError("chip image has no channel: every pixel is solid after binarisation")
    clearance_um = robot_radius_um + margin_um
    planning = dilate_obstacles(free, clearance_um / pixel_size_um)
    if not planning.any():
        widest_um = float(ndimage.distance_transform_edt(free).max()) * pixel_size_um
        raise ValueError(
            f"robot radius plus margin ({clearance_um:g} um) is larger than every channel: "
            f"the widest channel leaves room for at most {widest_um:g} um"
        )
    return OccupancyMap(free=free, planning=planning, pixel_size_um=pixel_size_um, clearance_um=clearance_um)


def pixels_to_um(rows_cols: np.ndarray, pixel_size_um: float) -> np.ndarray:
    """Pixel (row, col) indices -> (x_um, y_um) of the pixel centres."""
    rows_cols = np.asarray(rows_cols, dtype=np.float64).reshape(-1, 2)
    return (rows_cols[:, ::-1] + 0.5) * pixel_size_um


def _as_point(point, name: str) -> tuple[float, float]:
    values = np.asarray(point, dtype=np.float64).ravel()
    if values.shape != (2,) or not np.all(np.isfinite(values)):
        raise ValueError(f"{name} must be two finite numbers x,y in um, got {point!r}")
    return float(values[0]), float(values[1])


def _positive(name: str, value: float) -> float:
    value = float(value)
    if not math.isfinite(value) or value <= 0:
        raise ValueError(f"{name} must be a positive number, got {value!r}")
    return value


def _non_negative(name: str, value: float) -> float:
    value = float(value)
    if not math.isfinite(value) or value < 0:
        raise ValueError(f"{name} must be a non-negative number, got {value!r}")
    return value
