"""B-spline smoothing of a grid path that provably stays out of the dilated obstacles.

Model, in three steps (all in pixel units internally; um at the interface, origin at
the image's top-left corner, x right, y down, pixel centres at +0.5 pixel):

1. **String pulling.** The A* path zig-zags between 0 and 45 degree steps. Its points
   are pruned greedily: from an anchor point, the path is followed while the straight
   segment from the anchor stays free in the dilated map (exact grid traversal,
   ``collision.segments_free``); the last visible point becomes the next vertex. The
   resulting polyline is free, no longer than the A* path (triangle inequality) and
   close to the Euclidean shortest path.
2. **B-spline.** A clamped uniform cubic B-spline (scipy.interpolate.BSpline; de Boor,
   *A Practical Guide to Splines*, 1978) is built on a control polygon made from the
   polyline: each interior vertex V is replaced by five control points V - 2d u1,
   V - d u1, V, V + d u2, V + 2d u2 (u1, u2 the unit directions of the incoming and
   outgoing edges, d the corner's rounding distance, at most a quarter of the shorter
   adjacent edge). A cubic B-spline lies in the convex hull of every 4 consecutive
   control points, so the curve runs exactly along the polyline's edges (four
   collinear control points) and leaves them only inside the triangle
   (V - 2d u1, V, V + 2d u2) around each vertex, where it rounds the corner with
   continuous curvature.
3. **Guarantee.** The curve is sampled at uniform arc length (step ``step_um``) and
   the polyline through the samples -- the output -- is checked segment by segment
   against the dilated map. Corners whose rounding collides are re-fitted with half
   the rounding distance (a tighter corner: less smoothing, control points closer
   together), repeatedly; below 0.05 pixel the corner is kept sharp (d = 0, five
   coincident control points, the curve passes through V). With d <= 0.25 pixel the
   corner's triangle lies within V's own free pixel, and with d = 0 the curve is the
   free polyline itself, so the refitting always ends with a collision-free path.

The smoothed path is thus shorter than the A* path and has the same start and end.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from otgym.planning.collision import _segment_free, segments_free

_MIN_ROUNDING_PX = 0.05
_SAMPLES_PER_STEP = 8


def smooth_path(
    path_um: np.ndarray,
    free: np.ndarray,
    pixel_size_um: float,
    *,
    step_um: float | None = None,
    max_refits: int = 40,
) -> np.ndarray:
    """Collision-free B-spline smoothing of a free polyline, resampled by arc length.

    ``path_um``: ``(n, 2)`` points (x_um, y_um), typically the A* path; every segment
    must be free in ``free`` (the dilated map, True = free). ``step_um`` is the
    spacing of the output samples along the arc (default: a quarter pixel; uniform to
    within 1 %, as arc length is inverted on a grid 8 times finer). Returns
    the ``(m, 2)`` samples in um, starting and ending exactly at the path's ends.
    """
    pixel_size_um = float(pixel_size_um)
    step_px = 0.25 if step_um is None else float(step_um) / pixel_size_um
    if not (step_px > 0 and math.isfinite(step_px)):
        raise ValueError(f"resampling step must be a positive number of um, got {step_um!r}")
    points = _drop_repeats(np.asarray(path_um, dtype=np.float64) / pixel_size_um)
    free = np.ascontiguousarray(free, dtype=np.bool_)
    if not segments_free(free, points).all():
        raise ValueError("the path to smooth crosses an obstacle of the dilated map")
    if points.shape[0] == 1:
        return points * pixel_size_um
    vertices = string_pull(free, points)
    if vertices.shape[0] == 2:
        return _resample_line(vertices, step_px) * pixel_size_um
    edges = np.linalg.norm(np.diff(vertices, axis=0), axis=1)
    rounding = np.minimum(edges[:-1], edges[1:]) / 4.0
    for _ in range(max_refits):
        samples = _sample_curve(vertices, rounding, step_px)
        clear = segments_free(free, samples)
        if clear.all():
            return samples * pixel_size_um
        bad = np.concatenate((samples[:-1][~clear], samples[1:][~clear]))
        rounding = _tighten(vertices[1:-1], rounding, bad, step_px)
    rounding[:] = 0.0
    samples = _sample_curve(vertices, rounding, step_px)
    if not segments_free(free, samples).all():
        raise RuntimeError("B-spline smoothing could not clear the path even with sharp corners")
    return samples * pixel_size_um


def string_pull(free: np.ndarray, points_px: np.ndarray) -> np.ndarray:
    """Greedy line-of-sight pruning of a free polyline (pixel units); keeps both ends."""
    keep = _string_pull(np.ascontiguousarray(free, dtype=np.bool_), np.ascontiguousarray(points_px, dtype=np.float64))
    return points_px[keep]


@numba.njit(cache=True)
def _string_pull(free, points):
    n = points.shape[0]
    keep = np.zeros(n, dtype=np.bool_)
    keep[0] = True
    keep[n - 1] = True
    anchor = 0
    for j in range(1, n - 1):
        if not _segment_free(free, points[anchor, 0], points[anchor, 1], points[j + 1, 0], points[j + 1, 1]):
            keep[j] = True
            anchor = j
    return keep


def _tighten(corners: np.ndarray, rounding: np.ndarray, bad: np.ndarray, step_px: float) -> np.ndarray:
    """Halve the rounding of every corner that a colliding sample is close to."""
    distance = np.linalg.norm(bad[:, None, :] - corners[None, :, :], axis=2)
    hit = (distance <= 2.0 * rounding[None, :] + step_px).any(axis=0)
    if not hit.any():  # only rounding error on a straight edge can get here: tighten the nearest corners
        hit[np.argmin(distance, axis=1)] = True
    rounding = rounding.copy()
    rounding[hit] *= 0.5
    rounding[rounding < _MIN_ROUNDING_PX] = 0.0
    return rounding


def _control_points(vertices: np.ndarray, rounding: np.ndarray) -> np.ndarray:
    incoming = vertices[1:-1] - vertices[:-2]
    outgoing = vertices[2:] - vertices[1:-1]
    incoming /= np.linalg.norm(incoming, axis=1, keepdims=True)
    outgoing /= np.linalg.norm(outgoing, axis=1, keepdims=True)
    d = rounding[:, None]
    corners = vertices[1:-1]
    per_corner = np.stack(
        (
            corners - 2 * d * incoming,
            corners - d * incoming,
            corners,
            corners + d * outgoing,
            corners + 2 * d * outgoing,
        ),
        axis=1,
    ).reshape(-1, 2)
    return np.concatenate((vertices[:1], per_corner, vertices[-1:]))


def _sample_curve(vertices: np.ndarray, rounding: np.ndarray, step_px: float) -> np.ndarray:
    """Points every ``step_px`` of arc length along the B-spline of the control polygon."""
    control = _control_points(vertices, rounding)
    m = control.shape[0]
    n_spans = m - 3
    knots = np.concatenate((np.zeros(3), np.arange(n_spans + 1, dtype=np.float64), np.full(3, float(n_spans))))
    from scipy.interpolate import BSpline  # a second to import: only where a path is smoothed

    curve = BSpline(knots, control, 3)
    # sample each span in proportion to the length of its control polygon, which
    # bounds the span's arc length, so short tight corners are resolved as finely
    # as long straight edges
    span_length = np.array([np.linalg.norm(np.diff(control[j : j + 4], axis=0), axis=1).sum() for j in range(n_spans)])
    per_span = np.maximum(np.ceil(_SAMPLES_PER_STEP * span_length / step_px).astype(int), 2)
    fine_u = np.concatenate(
        [j + np.arange(count) / count for j, count in enumerate(per_span)] + [np.array([float(n_spans)])]
    )
    fine = curve(fine_u)
    arc = np.concatenate(([0.0], np.cumsum(np.linalg.norm(np.diff(fine, axis=0), axis=1))))
    count = max(int(math.ceil(arc[-1] / step_px)), 1)
    samples = curve(np.interp(np.linspace(0.0, arc[-1], count + 1), arc, fine_u))
    samples[0] = vertices[0]
    samples[-1] = vertices[-1]
    return samples


def _resample_line(ends: np.ndarray, step_px: float) -> np.ndarray:
    count = max(int(math.ceil(np.linalg.norm(ends[-1] - ends[0]) / step_px)), 1)
    return ends[0] + (np.arange(count + 1)[:, None] / count) * (ends[-1] - ends[0])


def _drop_repeats(points: np.ndarray) -> np.ndarray:
    if points.ndim != 2 or points.shape[1] != 2 or points.shape[0] == 0 or not np.all(np.isfinite(points)):
        raise ValueError(f"path must be a non-empty (n, 2) array of finite x, y in um, got shape {points.shape}")
    keep = np.concatenate(([True], np.any(np.diff(points, axis=0) != 0, axis=1)))
    return points[keep]
