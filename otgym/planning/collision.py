"""Exact collision test of a polyline against a pixel free map.

A point (x, y) in pixel units (x = x_um / pixel size, y = y_um / pixel size) lies in
pixel ``(floor(y), floor(x))``. A segment is free when every pixel square it passes
through is free. The squares are found with the grid traversal of Amanatides & Woo
("A fast voxel traversal algorithm for ray tracing", Eurographics 1987), so no pixel a
segment crosses is missed, however short the crossing. A segment that goes exactly
through a pixel corner is taken to touch only the two squares it enters and leaves,
matching the diagonal steps of the 8-connected A* (see ``astar``); ties are judged to
within 1e-9 of the segment's parameter.
"""

from __future__ import annotations

import math

import numba
import numpy as np

_CORNER_TOLERANCE = 1e-9


def segments_free(free: np.ndarray, points_px: np.ndarray) -> np.ndarray:
    """For each segment of a polyline (``(n, 2)`` x, y in pixel units), whether it is free.

    Returns a boolean array of length ``n - 1``. Points outside the map are blocked.
    """
    points_px = np.ascontiguousarray(points_px, dtype=np.float64)
    if points_px.ndim != 2 or points_px.shape[1] != 2:
        raise ValueError(f"points must have shape (n, 2), got {points_px.shape}")
    return _segments_free(np.ascontiguousarray(free, dtype=np.bool_), points_px)


@numba.njit(cache=True)
def _segments_free(free, points):
    n = points.shape[0]
    result = np.empty(max(n - 1, 0), dtype=np.bool_)
    for i in range(n - 1):
        result[i] = _segment_free(free, points[i, 0], points[i, 1], points[i + 1, 0], points[i + 1, 1])
    return result


@numba.njit(cache=True)
def _is_free(free, row, col):
    height, width = free.shape
    return 0 <= row < height and 0 <= col < width and free[row, col]


@numba.njit(cache=True)
def _segment_free(free, x0, y0, x1, y1):
    col = math.floor(x0)
    row = math.floor(y0)
    end_col = math.floor(x1)
    end_row = math.floor(y1)
    if not _is_free(free, row, col) or not _is_free(free, end_row, end_col):
        return False
    dx = x1 - x0
    dy = y1 - y0
    step_col = 1 if dx > 0 else -1
    step_row = 1 if dy > 0 else -1
    # parameter t in [0, 1] along the segment at which the next column / row boundary is crossed
    if dx != 0.0:
        t_delta_x = abs(1.0 / dx)
        t_next_x = ((col + 1 - x0) if dx > 0 else (x0 - col)) * t_delta_x
    else:
        t_delta_x = np.inf
        t_next_x = np.inf
    if dy != 0.0:
        t_delta_y = abs(1.0 / dy)
        t_next_y = ((row + 1 - y0) if dy > 0 else (y0 - row)) * t_delta_y
    else:
        t_delta_y = np.inf
        t_next_y = np.inf
    remaining = abs(end_col - col) + abs(end_row - row)
    while remaining > 0:
        if abs(t_next_x - t_next_y) <= _CORNER_TOLERANCE:
            col += step_col
            row += step_row
            t_next_x += t_delta_x
            t_next_y += t_delta_y
            remaining -= 2
        elif t_next_x < t_next_y:
            col += step_col
            t_next_x += t_delta_x
            remaining -= 1
        else:
            row += step_row
            t_next_y += t_delta_y
            remaining -= 1
        if not _is_free(free, row, col):
            return False
    return True
