"""Vision-based force sensor (paper section II-D): from a microscope image alone,
locate each trap handle with sub-pixel precision, then turn the trap-to-handle vector
into a force with the trap law.

The sensor knows what a real set-up knows: where it put its traps (the handle of
trap k is near trap k), the handles' radius, the image's pixel size and origin.

Localisation, per handle (vectorised over frames and handles):

1. Detection: among candidate centres on a one-pixel lattice within
   ``search_radius_um`` of the trap, take the darkest point of the image averaged
   over a box about one handle radius wide (ties broken towards the trap).
2. Edge points: cast ``n_rays`` rays from that point and find on each, by linear
   interpolation, where the intensity first rises through half-way between the
   body's dark level and the background (the handle's outline).
3. Robust circle fit: a least-squares circle (algebraic fit, Kasa 1976) through the
   edge points; rays whose point is far from the circle (more than 3 robust standard
   deviations) are dropped and the fit repeated. A handle is part of a rigid cluster
   of spheres, so rays that run into a neighbouring sphere of its body, or into
   another body, find no edge or an edge off the circle: this local model of the
   handle, a circle seen over the free part of its outline, needs no model of the
   rest of the robot. Rays next to a ray that found no outline are dropped as well
   (the blurred neck between touching spheres moves their edge outwards). Blur and threshold shift every edge point radially by the
   same amount, which the free radius absorbs, so the centre is unbiased.
4. Steps 2-3 are repeated from the fitted centre (rays then cross the edge at
   right angles).

Forces: ``TrapLaw.force_pn(trap - handle)``, evaluated in numpy by ``trap_force_pn``
(the same formula).

Cost: the interactive loop senses a few 48 x 48 crops each tick, where the cost is
per-call overhead, not pixels. So the constant arrays (detection lattice, ray and
ring offsets) are built once per sensor and pixel size, the bilinear samples, medians
and the trap law are plain numpy (no ``map_coordinates`` over a frame axis, no
``numpy.ma``, no eager jax dispatch), and the per-handle work is vectorised over all
handles: about 1.5-2 ms per call for four handles on this project's CPU, against
7-8 ms before (same results up to float round-off).
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np
from scipy import ndimage

from otgym.physics.traps import TrapLaw
from otgym.physics.validation import require_positive_scalar

OUTLIER_SIGMAS = 3.0
MIN_CONTRAST = 0.2
"""A handle must be darker than its surroundings by this fraction of the background."""
RADIUS_TOLERANCE = 0.25
"""The fitted outline's radius must be within 25 % of the handle radius (blur and the
half-way threshold move it by a few per cent)."""
RAY_REACH = 1.4
"""Rays end at 1.4 handle radii: past the handle's own outline, short of the far side
of a touching sphere."""
BLOCKED_MARGIN_DEG = 20.0
"""Rays this close in angle to a ray that found no outline (it ran into a touching
sphere) are dropped too: there the blurred neck between the spheres moves the edge."""
MIN_EDGE_POINTS = 8
RING_POINTS = 48
"""Samples of the background ring."""


@dataclasses.dataclass(frozen=True)
class SensorReading:
    """Estimates per frame and trap: handle positions (B, K, 2) um, forces (B, K, 2) pN,
    and ``valid`` (B, K): False where no handle outline was found near the trap (too
    little contrast, too few edge points, or an outline of the wrong size); the force
    is NaN there."""

    handle_xy_um: np.ndarray
    force_pn: np.ndarray
    valid: np.ndarray


@dataclasses.dataclass(frozen=True)
class VisionForceSensor:
    trap_law: TrapLaw = TrapLaw.paper()
    handle_radius_um: float = 1.25
    search_radius_um: float = 1.0
    n_rays: int = 64
    ray_step_px: float = 0.5

    def __post_init__(self):
        require_positive_scalar("handle_radius_um", self.handle_radius_um)
        require_positive_scalar("search_radius_um", self.search_radius_um)
        require_positive_scalar("ray_step_px", self.ray_step_px)
        if self.n_rays < MIN_EDGE_POINTS:
            raise ValueError(f"n_rays must be at least {MIN_EDGE_POINTS}, got {self.n_rays}")

    def measure(self, images, origin_um, pixel_size_um: float, trap_xy_um) -> SensorReading:
        """images: (B, h, w) or (h, w); origin_um: (B, 2) or (2,) top-left corners;
        trap_xy_um: (B, K, 2) or (K, 2) trap centres in the same um frame."""
        single = np.ndim(images) == 2
        images = np.asarray(images, np.float32)[None] if single else np.asarray(images, np.float32)
        origin = np.asarray(origin_um, np.float64).reshape(-1, 2)
        traps = np.asarray(trap_xy_um, np.float64)
        traps = traps[None] if traps.ndim == 2 else traps
        require_positive_scalar("pixel_size_um", pixel_size_um)
        if traps.shape[0] != images.shape[0] or origin.shape[0] != images.shape[0]:
            raise ValueError(f"got {images.shape[0]} images, {origin.shape[0]} origins, {traps.shape[0]} trap sets")
        # everything below works in pixel-index coordinates (col, row) of the frame
        traps_px = (traps - origin[:, None, :]) / pixel_size_um - 0.5
        handle_px, valid = self._locate(images, traps_px, pixel_size_um)
        handle_um = (handle_px + 0.5) * pixel_size_um + origin[:, None, :]
        force = trap_force_pn(self.trap_law, traps - handle_um)
        return SensorReading(handle_um, np.where(valid[..., None], force, np.nan), valid)

    def _geometry(self, pixel_size_um: float) -> "_Geometry":
        return _geometry(self.handle_radius_um, self.search_radius_um, self.n_rays, self.ray_step_px,
                         float(pixel_size_um))

    def _locate(self, images, traps_px, pixel_size_um):
        frames, k = traps_px.shape[:2]
        geometry = self._geometry(pixel_size_um)
        frame_of = np.repeat(np.arange(frames), k)
        sampler = _Sampler(images, frame_of)
        smoothed = _Sampler(ndimage.uniform_filter(images, size=(1, geometry.box, geometry.box), mode="nearest"),
                            frame_of)
        start, dark = self._detect(smoothed, traps_px.reshape(-1, 2), geometry)
        bright = _background(sampler, start, geometry)
        contrast_ok = bright - dark > MIN_CONTRAST * bright
        threshold = 0.5 * (dark + bright)
        radius_px = geometry.radius_px
        centre, valid = start, contrast_ok
        for _ in range(2):
            points, ok = self._edges(sampler, centre, threshold, geometry)
            fitted, radius, fit_ok = _robust_circle(points, ok)
            shift = fitted - start
            valid = (contrast_ok & fit_ok & (np.abs(radius - radius_px) < RADIUS_TOLERANCE * radius_px)
                     & (np.sqrt(shift[:, 0] ** 2 + shift[:, 1] ** 2) < 0.5 * radius_px))
            centre = np.where(valid[:, None], fitted, centre)
        return centre.reshape(frames, k, 2), valid.reshape(frames, k)

    def _detect(self, smoothed, traps_px, geometry):
        """Darkest point of the box-filtered image (box side about the handle radius)
        on a one-pixel lattice within the search radius of each trap; returns it and
        the filtered image's value there."""
        lattice = geometry.lattice
        values = smoothed(traps_px[:, 0, None] + lattice[:, 0], traps_px[:, 1, None] + lattice[:, 1])  # (M, C)
        best = np.argmin(values + geometry.lattice_penalty, axis=1)
        rows = np.arange(len(best))
        return traps_px + lattice[best], values[rows, best]

    def _edges(self, sampler, centre, threshold, geometry):
        """Outline points (M, 2, R) along the rays from ``centre`` (M, 2), where the
        profile first rises through ``threshold`` (M,), and which rays found one
        away from any ray that did not (M, R)."""
        steps = len(geometry.ray_s)
        profile = sampler(centre[:, 0, None, None] + geometry.ray_dx, centre[:, 1, None, None] + geometry.ray_dy)
        threshold = threshold[:, None, None]  # (M, R, S) profile, (M, 1, 1) threshold
        rising = (profile[..., :-1] < threshold) & (profile[..., 1:] >= threshold)
        found = rising.any(axis=-1)
        first = np.argmax(rising, axis=-1)
        flat = profile.reshape(-1)
        at = np.arange(first.size).reshape(first.shape) * steps + first
        low = flat[at]
        high = flat[at + 1]
        fraction = (threshold[..., 0] - low) / np.where(high > low, high - low, 1.0)
        distance = geometry.ray_s[first] + fraction * self.ray_step_px
        points = centre[:, :, None] + distance[:, None, :] * geometry.directions.T  # (M, 2, R): columns, rows
        # drop rays within BLOCKED_MARGIN_DEG of a ray that found no outline (circularly):
        # the count of blocked rays near each ray, as a product with a 0/1 band matrix
        blocked_near = np.matmul((~found).astype(float), geometry.near_rays)
        return points, found & (blocked_near == 0)


@dataclasses.dataclass(frozen=True)
class _Geometry:
    """Constant arrays of one sensor at one pixel size (read-only, cached)."""

    radius_px: float
    box: int
    lattice: np.ndarray  # (C, 2) candidate offsets of detection
    lattice_penalty: np.ndarray  # (C,) the tie-break towards the trap
    ring: np.ndarray  # (RING_POINTS, 2) background ring offsets
    directions: np.ndarray  # (R, 2) ray directions
    ray_s: np.ndarray  # (S,) distances along a ray
    ray_dx: np.ndarray  # (R, S) ray sample offsets, col
    ray_dy: np.ndarray  # (R, S) ray sample offsets, row
    near_rays: np.ndarray  # (R, R) 1.0 where two rays are within BLOCKED_MARGIN_DEG


@functools.lru_cache(maxsize=64)
def _geometry(handle_radius_um, search_radius_um, n_rays, ray_step_px, pixel_size_um) -> _Geometry:
    """The constant arrays of a sensor at one pixel size, built on its first call."""
    radius_px = handle_radius_um / pixel_size_um
    reach = search_radius_um / pixel_size_um
    lattice = _disc_points(reach)
    angles = np.linspace(0.0, 2 * np.pi, RING_POINTS, endpoint=False)
    ring = 1.6 * radius_px * np.stack([np.cos(angles), np.sin(angles)], axis=-1)
    angles = np.linspace(0.0, 2 * np.pi, n_rays, endpoint=False)
    directions = np.stack([np.cos(angles), np.sin(angles)], axis=-1)
    s = np.arange(0.3 * radius_px, RAY_REACH * radius_px, ray_step_px)
    offsets = s[None, :, None] * directions[:, None, :]
    margin = int(np.ceil(BLOCKED_MARGIN_DEG / (360.0 / n_rays)))
    ray = np.arange(n_rays)
    apart = np.abs(ray[:, None] - ray[None])
    near = (np.minimum(apart, n_rays - apart) <= margin).astype(float)
    geometry = _Geometry(
        radius_px=radius_px, box=max(int(round(radius_px)) | 1, 1), lattice=lattice,
        lattice_penalty=1e-3 * np.linalg.norm(lattice, axis=-1) / max(reach, 1.0), ring=ring, directions=directions,
        ray_s=s, ray_dx=np.ascontiguousarray(offsets[..., 0]), ray_dy=np.ascontiguousarray(offsets[..., 1]),
        near_rays=near)
    for field in dataclasses.fields(geometry):
        value = getattr(geometry, field.name)
        if isinstance(value, np.ndarray):
            value.flags.writeable = False
    return geometry


SAMPLER_FLOAT64_PIXELS = 1 << 22
"""Frames up to this many pixels in all are copied to float64 once (the interpolation
then needs no conversions); larger batches stay float32 to save memory. The samples
are the same either way."""


class _Sampler:
    """Bilinear samples of image ``frame_of[m]`` at columns x and rows y (M, ...), as
    ``scipy.ndimage.map_coordinates(images, order=1, mode="nearest")`` gives them: the
    same arithmetic in float64, so the same numbers, returned in the images' dtype;
    without map_coordinates' per-point cost (it interpolates along the frame axis too)."""

    def __init__(self, images, frame_of):
        frames, self.h, self.w = images.shape
        # one more row and column repeating the last (mode "nearest"), so that the
        # neighbours x0 + 1, y0 + 1 of a clamped point stay inside
        dtype = np.float64 if images.size <= SAMPLER_FLOAT64_PIXELS else images.dtype
        padded = np.empty((frames, self.h + 1, self.w + 1), dtype)
        padded[:, :-1, :-1] = images
        padded[:, -1, :-1] = images[:, -1]
        padded[:, :, -1] = padded[:, :, -2]
        self.flat = padded.reshape(-1)
        self.row = self.w + 1
        self.base = frame_of * ((self.h + 1) * self.row)
        self.dtype = images.dtype

    def __call__(self, x, y):
        """Samples at x, y (M, ...) float64; overwrites x and y."""
        base = self.base.reshape((-1,) + (1,) * (x.ndim - 1))
        np.clip(x, 0, self.w - 1, out=x)
        np.clip(y, 0, self.h - 1, out=y)
        x0 = np.floor(x)
        y0 = np.floor(y)
        x -= x0  # the fractional parts
        y -= y0
        index = (y0 * self.row + x0).astype(np.intp)
        index += base
        flat = self.flat
        top_left = flat[index]
        top_right = flat[index + 1]
        index += self.row
        bottom_left = flat[index]
        bottom_right = flat[index + 1]
        left = 1 - x
        values = (1 - y) * (left * top_left + x * top_right) + y * (left * bottom_left + x * bottom_right)
        return values.astype(self.dtype)


def _disc_points(radius_px: float) -> np.ndarray:
    steps = np.arange(-np.floor(radius_px), np.floor(radius_px) + 1)
    grid = np.stack(np.meshgrid(steps, steps), axis=-1).reshape(-1, 2)
    return grid[np.linalg.norm(grid, axis=-1) <= radius_px]


def _background(sampler, start, geometry):
    """The local background: the median over a ring at 1.6 handle radii (the rest of
    the body covers a minority of it)."""
    ring = geometry.ring
    return _row_median(sampler(start[:, 0, None] + ring[:, 0], start[:, 1, None] + ring[:, 1]))


def _row_median(values):
    """np.median(values, axis=1) of a 2-D array (NaN where a row holds a NaN), by sorting."""
    ordered = np.sort(values, axis=1)
    n = values.shape[1]
    median = (ordered[:, (n - 1) // 2] + ordered[:, n // 2]) / 2
    last = ordered[:, -1]
    return np.where(np.isnan(last), last, median)


def _kept_median(values, keep, count):
    """Median of ``values`` (M, R) over the entries where ``keep``, per row (as
    np.nanmedian of the kept values computes it, without numpy.ma's per-call cost);
    ``count`` (M,) the number kept; 0 for a row that keeps none."""
    ordered = np.sort(np.where(keep, values, np.inf), axis=1)  # the kept values first
    rows = np.arange(len(values))
    median = (ordered[rows, (count - 1) // 2] + ordered[rows, count // 2]) / 2
    return np.where(count > 0, median, 0.0)


_EYE_3 = 1e-9 * np.eye(3)


def _circle_fit(points, weights):
    """Weighted algebraic circle fit x^2 + y^2 + D x + E y + F = 0 per row of points
    (M, 2, R) (columns, rows) with weights (M, R); returns centres (M, 2) and radii (M,)."""
    reference = np.matmul(points, weights[:, :, None])[..., 0] / np.maximum(weights.sum(axis=1), 1)[:, None]
    # rows x, y, 1 (the design) and the target -(x^2 + y^2): one product gives both
    # the normal matrix (design' W design) and the right-hand side (design' W target)
    design = np.empty((points.shape[0], 4, points.shape[2]))
    p = np.subtract(points, reference[:, :, None], out=design[:, :2])
    square = p * p
    np.negative(square[:, 0] + square[:, 1], out=design[:, 3])
    design[:, 2] = 1.0
    moments = np.matmul(design * weights[:, None, :], design.transpose(0, 2, 1))
    solution = np.linalg.solve(moments[:, :3, :3] + _EYE_3, moments[:, :3, 3:])[..., 0]  # (M, 3): D, E, F
    centre = solution[:, :2] / -2
    radius = np.sqrt(np.maximum(centre[:, 0] ** 2 + centre[:, 1] ** 2 - solution[:, 2], 0.0))
    return centre + reference, radius


def _robust_circle(points, found):
    """Robust circle fit to edge points (M, 2, R) of the rays that ``found`` one."""
    keep = found
    for _ in range(3):
        centre, radius = _circle_fit(points, keep.astype(float))
        square = points - centre[:, :, None]
        square *= square
        residual = np.abs(np.sqrt(square[:, 0] + square[:, 1]) - radius[:, None])
        mad = 1.4826 * _kept_median(residual, keep, keep.sum(axis=1))
        keep = found & (residual <= np.maximum(OUTLIER_SIGMAS * mad, 0.1)[:, None])
    centre, radius = _circle_fit(points, keep.astype(float))
    return centre, radius, keep.sum(axis=1) >= MIN_EDGE_POINTS


def trap_force_pn(law: TrapLaw, handle_to_trap_um) -> np.ndarray:
    """``law.force_pn`` (otgym.physics.traps) in plain numpy, the same formula term
    by term: force (..., 2) on a handle given the vector (..., 2) from handle to trap.
    For a few handles eager jax.numpy calls cost far more than the arithmetic. It
    computes in float64 where jax by default computes in float32, so the two differ
    by float32 round-off (tests/sim/test_sensor.py checks every law preset)."""
    vector = np.asarray(handle_to_trap_um, np.float64)
    distance = np.sqrt(np.sum(vector**2, axis=-1))
    safe = np.where(distance > 0, distance, 1.0)
    scale = np.where(distance > 0, law.magnitude_pn(distance, np) / safe, 0.0)
    return vector * scale[..., None]


def sensor_errors(reading: SensorReading, true_handle_xy_um, true_force_pn) -> dict[str, np.ndarray]:
    """Per-handle position error (um) and relative force error |F_est - F| / |F| against
    the simulator's truth, over the valid readings."""
    valid = reading.valid
    position = np.linalg.norm(reading.handle_xy_um - np.asarray(true_handle_xy_um), axis=-1)[valid]
    true_force = np.asarray(true_force_pn)
    force = np.linalg.norm(reading.force_pn - true_force, axis=-1)[valid]
    return {"position_um": position, "relative_force": force / np.linalg.norm(true_force, axis=-1)[valid]}
