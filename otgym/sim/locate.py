"""The vision force sensor's localisation of trap handles (``otgym.sim.sensor``, steps
1-4 of its method), compiled with numba: one call locates every handle of a batch.

The interactive loop senses four 48 x 48 crops a tick, where numpy's cost is per call
(some 330 calls on small arrays), not per pixel; here each handle costs a few
thousand bilinear samples and four 3 x 3 solves. The arithmetic is numpy's and
scipy's (``uniform_filter``'s running sum, ``map_coordinates``' bilinear sample in
float64 rounded to float32, the float32 profile, threshold and median, the float64
circle fit), so the readings are those of the numpy implementation this replaced to
float round-off (tests/sim/test_sensor.py). Compiled once per machine
(``cache=True``).

Coordinates are pixel indices (column, row) of a frame: pixel (r, c) has its centre
at column c, row r.
"""

from __future__ import annotations

import numba
import numpy as np

OUTLIER_SIGMAS = 3.0
MAD_TO_SIGMA = 1.4826
"""Median absolute deviation to standard deviation for normal residuals."""
MIN_OUTLIER_CUT_PX = 0.1
"""Edge points within this many pixels of the circle are never outliers."""
MIN_CONTRAST = 0.2
"""A handle must be darker than its surroundings by this fraction of the background."""
RADIUS_TOLERANCE = 0.25
"""The fitted outline's radius must be within 25 % of the handle radius (blur and the
half-way threshold move it by a few per cent)."""
MAX_START_SHIFT = 0.5
"""The fitted centre must lie within half a handle radius of the detected point."""
MIN_EDGE_POINTS = 8
FIT_REGULARISATION = 1e-9
"""Added to the diagonal of the circle fit's 3 x 3 normal matrix."""
ROBUST_ROUNDS = 3
"""Fits with outliers dropped, after the first."""
LOCATE_ROUNDS = 2
"""Rays cast from the detected point, then again from the fitted centre."""


@numba.njit(cache=True)
def locate_handles(
    images,
    frame_of,
    traps_px,
    box,
    lattice,
    lattice_penalty,
    ring,
    ray_s,
    ray_dx,
    ray_dy,
    directions,
    blocked_margin,
    ray_step_px,
    radius_px,
):
    """Handle centres (M, 2) (column, row) and whether each was found (M,), for the
    handle of trap m (``traps_px[m]``, column and row) in frame ``frame_of[m]`` of
    ``images`` (B, h, w) float32. ``box``: side of the detection's box filter;
    ``lattice`` (C, 2) and ``lattice_penalty`` (C,): candidate offsets of detection and
    their tie-break; ``ring`` (Q, 2): the background ring's offsets; ``ray_s`` (S,),
    ``ray_dx`` and ``ray_dy`` (R, S): distances and offsets of the samples along each
    ray; ``directions`` (R, 2); rays within ``blocked_margin`` rays of a ray that found
    no outline are dropped."""
    count = traps_px.shape[0]
    smoothed = np.empty(images.shape, np.float32)
    for frame in range(images.shape[0]):
        _box_filter(images[frame], box, smoothed[frame])
    centres = np.empty((count, 2))
    valid = np.zeros(count, np.bool_)
    n_rays, steps = ray_dx.shape
    profile = np.empty(steps, np.float32)
    points = np.empty((n_rays, 2))
    found = np.empty(n_rays, np.bool_)
    usable = np.empty(n_rays, np.bool_)
    for m in range(count):
        image = images[frame_of[m]]
        start_x, start_y, dark = _detect(
            smoothed[frame_of[m]], traps_px[m, 0], traps_px[m, 1], lattice, lattice_penalty
        )
        bright = _ring_median(image, start_x, start_y, ring)
        contrast_ok = bright - dark > np.float32(MIN_CONTRAST) * bright
        threshold = np.float32(0.5) * (dark + bright)
        centre_x, centre_y = start_x, start_y
        ok = False
        for _ in range(LOCATE_ROUNDS):
            _edges(
                image,
                centre_x,
                centre_y,
                threshold,
                ray_s,
                ray_dx,
                ray_dy,
                directions,
                ray_step_px,
                profile,
                points,
                found,
            )
            _unblocked(found, blocked_margin, usable)
            fitted_x, fitted_y, radius, fit_ok = _robust_circle(points, usable)
            shift_x = fitted_x - start_x
            shift_y = fitted_y - start_y
            ok = (
                contrast_ok
                and fit_ok
                and abs(radius - radius_px) < RADIUS_TOLERANCE * radius_px
                and np.sqrt(shift_x**2 + shift_y**2) < MAX_START_SHIFT * radius_px
            )
            if ok:
                centre_x, centre_y = fitted_x, fitted_y
        centres[m, 0] = centre_x
        centres[m, 1] = centre_y
        valid[m] = ok
    return centres, valid


@numba.njit(cache=True)
def _box_filter(image, box, out):
    """``scipy.ndimage.uniform_filter(image, box, mode="nearest")`` of one frame (h, w)
    float32 into ``out``: along columns, then rows, each pass scipy's running sum in
    float64 (the sum of the window, updated by the entering and the leaving pixel,
    divided by the box for each output) rounded to float32."""
    height, width = image.shape
    half = box // 2
    line = np.empty(max(height, width) + box - 1)
    for j in range(width):
        for k in range(height + box - 1):
            line[k] = image[min(max(k - half, 0), height - 1), j]
        total = 0.0
        for k in range(box):
            total += line[k]
        out[0, j] = total / box
        for i in range(1, height):
            total += line[i + box - 1] - line[i - 1]
            out[i, j] = total / box
    for i in range(height):
        for k in range(width + box - 1):
            line[k] = out[i, min(max(k - half, 0), width - 1)]
        total = 0.0
        for k in range(box):
            total += line[k]
        out[i, 0] = total / box
        for j in range(1, width):
            total += line[j + box - 1] - line[j - 1]
            out[i, j] = total / box


@numba.njit(cache=True)
def sample(image, x, y):
    """Bilinear sample at column x, row y of a frame (h, w) float32, clamped to the
    frame (``map_coordinates(order=1, mode="nearest")``), in float64, rounded to
    float32. Indices are clamped too, so a NaN coordinate reads a pixel of the frame
    (and gives a meaningless value), never memory outside it."""
    height, width = image.shape
    if x < 0.0:
        x = 0.0
    elif x > width - 1.0:
        x = width - 1.0
    if y < 0.0:
        y = 0.0
    elif y > height - 1.0:
        y = height - 1.0
    x0 = np.floor(x)
    y0 = np.floor(y)
    fx = x - x0
    fy = y - y0
    c0 = min(max(int(x0), 0), width - 1)
    r0 = min(max(int(y0), 0), height - 1)
    c1 = min(c0 + 1, width - 1)
    r1 = min(r0 + 1, height - 1)
    left = 1.0 - fx
    top = left * np.float64(image[r0, c0]) + fx * np.float64(image[r0, c1])
    bottom = left * np.float64(image[r1, c0]) + fx * np.float64(image[r1, c1])
    return np.float32((1.0 - fy) * top + fy * bottom)


@numba.njit(cache=True)
def _detect(smoothed, trap_x, trap_y, lattice, lattice_penalty):
    """Step 1: the darkest point of the box-filtered frame on the lattice around the
    trap (numpy's argmin: the first minimum, a NaN before any number); returns it and
    the filtered value there."""
    best = -1
    best_score = np.inf
    dark = np.float32(np.nan)
    for c in range(lattice.shape[0]):
        value = sample(smoothed, trap_x + lattice[c, 0], trap_y + lattice[c, 1])
        score = value + lattice_penalty[c]
        if best < 0 or score < best_score or (np.isnan(score) and not np.isnan(best_score)):
            best, best_score, dark = c, score, value
    return trap_x + lattice[best, 0], trap_y + lattice[best, 1], dark


@numba.njit(cache=True)
def _ring_median(image, x, y, ring):
    """The local background: the median of the samples on the ring around (x, y),
    in float32 (NaN if one is NaN)."""
    values = np.empty(ring.shape[0], np.float32)
    for q in range(ring.shape[0]):
        values[q] = sample(image, x + ring[q, 0], y + ring[q, 1])
    _insertion_sort(values)
    n = len(values)
    if np.isnan(values[n - 1]):
        return values[n - 1]
    return (values[(n - 1) // 2] + values[n // 2]) / np.float32(2.0)


@numba.njit(cache=True)
def _edges(
    image, centre_x, centre_y, threshold, ray_s, ray_dx, ray_dy, directions, ray_step_px, profile, points, found
):
    """Step 2: along each ray from the centre, where the profile first rises through
    the threshold, by linear interpolation between the two samples around it. Fills
    ``points`` (R, 2) and ``found`` (R,); a ray that finds no rise gets the point of
    its first step (unused: it is not ``found``)."""
    n_rays, steps = ray_dx.shape
    step = np.float32(ray_step_px)
    for r in range(n_rays):
        # samples are taken up to the first rise only: the rest of the ray is not needed
        profile[0] = sample(image, centre_x + ray_dx[r, 0], centre_y + ray_dy[r, 0])
        first = 0
        found[r] = False
        for s in range(steps - 1):
            profile[s + 1] = sample(image, centre_x + ray_dx[r, s + 1], centre_y + ray_dy[r, s + 1])
            if profile[s] < threshold and profile[s + 1] >= threshold:
                first = s
                found[r] = True
                break
        if not found[r]:
            first = 0
        low = profile[first]
        high = profile[first + 1]
        rise = high - low if high > low else np.float32(1.0)
        fraction = (threshold - low) / rise
        distance = ray_s[first] + fraction * step
        points[r, 0] = centre_x + distance * directions[r, 0]
        points[r, 1] = centre_y + distance * directions[r, 1]


@numba.njit(cache=True)
def _unblocked(found, margin, usable):
    """Rays that found an outline with no ray within ``margin`` rays (circularly) that
    found none: there the blurred neck to a touching sphere moves the edge."""
    n_rays = len(found)
    for r in range(n_rays):
        ok = found[r]
        for k in range(-margin, margin + 1):
            if not found[(r + k) % n_rays]:
                ok = False
        usable[r] = ok


@numba.njit(cache=True)
def _robust_circle(points, usable):
    """Step 3: a circle through the usable edge points, refitted ROBUST_ROUNDS times
    without the points farther from it than OUTLIER_SIGMAS robust standard deviations
    (MAD, at least MIN_OUTLIER_CUT_PX); returns its centre, radius and whether at
    least MIN_EDGE_POINTS points were kept."""
    n_rays = points.shape[0]
    keep = usable.copy()
    residual = np.empty(n_rays)
    for _ in range(ROBUST_ROUNDS):
        centre_x, centre_y, radius = _circle_fit(points, keep)
        for r in range(n_rays):
            dx = points[r, 0] - centre_x
            dy = points[r, 1] - centre_y
            residual[r] = abs(np.sqrt(dx * dx + dy * dy) - radius)
        cut = max(OUTLIER_SIGMAS * (MAD_TO_SIGMA * kept_median(residual, keep)), MIN_OUTLIER_CUT_PX)
        for r in range(n_rays):
            keep[r] = usable[r] and residual[r] <= cut
    centre_x, centre_y, radius = _circle_fit(points, keep)
    kept = 0
    for r in range(n_rays):
        kept += keep[r]
    return centre_x, centre_y, radius, kept >= MIN_EDGE_POINTS


@numba.njit(cache=True)
def kept_median(values, keep):
    """Median of ``values`` (R,) where ``keep`` (np.median of ``values[keep]``); 0 when
    none is kept."""
    kept = np.empty(len(values))
    count = 0
    for r in range(len(values)):
        if keep[r]:
            kept[count] = values[r]
            count += 1
    if count == 0:
        return 0.0
    _insertion_sort(kept[:count])
    return (kept[(count - 1) // 2] + kept[count // 2]) / 2


@numba.njit(cache=True)
def _insertion_sort(values):
    """Sort a short array in place, NaN last (as np.sort); a few dozen values here,
    where this compiles far faster than numba's general sort and runs as fast."""
    for k in range(1, len(values)):
        value = values[k]
        j = k - 1
        while j >= 0 and (values[j] > value or (np.isnan(values[j]) and not np.isnan(value))):
            values[j + 1] = values[j]
            j -= 1
        values[j + 1] = value


@numba.njit(cache=True)
def _circle_fit(points, keep):
    """Algebraic least-squares circle x^2 + y^2 + D x + E y + F = 0 through the kept
    points (Kasa 1976), in coordinates relative to their mean; returns the centre and
    radius (the mean and 0 when none is kept)."""
    n_rays = points.shape[0]
    count = 0
    mean_x = 0.0
    mean_y = 0.0
    for r in range(n_rays):
        if keep[r]:
            count += 1
            mean_x += points[r, 0]
            mean_y += points[r, 1]
    mean_x /= max(count, 1)
    mean_y /= max(count, 1)
    # normal equations of the rows (x, y, 1) against the target -(x^2 + y^2)
    normal = np.zeros((3, 3))
    rhs = np.zeros(3)
    row = np.empty(3)
    for r in range(n_rays):
        if keep[r]:
            row[0] = points[r, 0] - mean_x
            row[1] = points[r, 1] - mean_y
            row[2] = 1.0
            target = -(row[0] * row[0] + row[1] * row[1])
            for a in range(3):
                rhs[a] += row[a] * target
                for b in range(3):
                    normal[a, b] += row[a] * row[b]
    for a in range(3):
        normal[a, a] += FIT_REGULARISATION
    d, e, f = _solve3(normal, rhs)
    centre_x = d / -2
    centre_y = e / -2
    radius = np.sqrt(max(centre_x * centre_x + centre_y * centre_y - f, 0.0))
    return centre_x + mean_x, centre_y + mean_y, radius


@numba.njit(cache=True)
def _solve3(matrix, rhs):
    """Solve a 3 x 3 system by Gaussian elimination with partial pivoting (LAPACK's
    gesv on three unknowns); overwrites its arguments."""
    for k in range(3):
        pivot = k
        for i in range(k + 1, 3):
            if abs(matrix[i, k]) > abs(matrix[pivot, k]):
                pivot = i
        if pivot != k:
            for j in range(3):
                matrix[k, j], matrix[pivot, j] = matrix[pivot, j], matrix[k, j]
            rhs[k], rhs[pivot] = rhs[pivot], rhs[k]
        for i in range(k + 1, 3):
            factor = matrix[i, k] / matrix[k, k]
            for j in range(k, 3):
                matrix[i, j] -= factor * matrix[k, j]
            rhs[i] -= factor * rhs[k]
    x2 = rhs[2] / matrix[2, 2]
    x1 = (rhs[1] - matrix[1, 2] * x2) / matrix[1, 1]
    x0 = (rhs[0] - matrix[0, 1] * x1 - matrix[0, 2] * x2) / matrix[0, 0]
    return x0, x1, x2
