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

Forces: ``TrapLaw.force_pn(trap - handle)``.
"""

from __future__ import annotations

import dataclasses

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
        force = np.asarray(self.trap_law.force_pn(traps - handle_um), np.float64)
        return SensorReading(handle_um, np.where(valid[..., None], force, np.nan), valid)

    def _locate(self, images, traps_px, pixel_size_um):
        frames, k = traps_px.shape[:2]
        frame_of = np.repeat(np.arange(frames), k)
        radius_px = self.handle_radius_um / pixel_size_um
        sampler = _Sampler(images, frame_of)
        box = max(int(round(radius_px)) | 1, 1)
        smoothed = _Sampler(ndimage.uniform_filter(images, size=(1, box, box), mode="nearest"), frame_of)
        start = self._detect(smoothed, traps_px.reshape(-1, 2), pixel_size_um)
        dark = smoothed(start[:, None, :])[:, 0]
        bright = _background(sampler, start, radius_px)
        contrast_ok = bright - dark > MIN_CONTRAST * bright
        centre, valid = start, contrast_ok
        for _ in range(2):
            points, ok = self._edges(sampler, centre, radius_px, dark, bright)
            fitted, radius, fit_ok = _robust_circle(points, ok)
            valid = (contrast_ok & fit_ok & (np.abs(radius - radius_px) < RADIUS_TOLERANCE * radius_px)
                     & (np.linalg.norm(fitted - start, axis=-1) < 0.5 * radius_px))
            centre = np.where(valid[:, None], fitted, centre)
        return centre.reshape(frames, k, 2), valid.reshape(frames, k)

    def _detect(self, smoothed, traps_px, pixel_size_um):
        """Darkest point of the box-filtered image (box side about the handle radius)
        on a one-pixel lattice within the search radius of each trap."""
        reach = self.search_radius_um / pixel_size_um
        lattice = _disc_points(reach)
        candidates = traps_px[:, None, :] + lattice[None]  # (M, C, 2)
        score = smoothed(candidates) + 1e-3 * np.linalg.norm(lattice, axis=-1) / max(reach, 1.0)
        return candidates[np.arange(candidates.shape[0]), np.argmin(score, axis=1)]

    def _edges(self, sampler, centre, radius_px, dark, bright):
        angles = np.linspace(0.0, 2 * np.pi, self.n_rays, endpoint=False)
        directions = np.stack([np.cos(angles), np.sin(angles)], axis=-1)
        s = np.arange(0.3 * radius_px, RAY_REACH * radius_px, self.ray_step_px)
        rays = centre[:, None, None, :] + s[None, None, :, None] * directions[None, :, None, :]
        profile = sampler(rays)  # (M, R, S)
        threshold = (0.5 * (dark + bright))[:, None, None]
        rising = (profile[..., :-1] < threshold) & (profile[..., 1:] >= threshold)
        found = rising.any(axis=-1)
        first = np.argmax(rising, axis=-1)
        low = np.take_along_axis(profile, first[..., None], -1)[..., 0]
        high = np.take_along_axis(profile, first[..., None] + 1, -1)[..., 0]
        fraction = (threshold[..., 0] - low) / np.where(high > low, high - low, 1.0)
        distance = s[first] + fraction * self.ray_step_px
        points = centre[:, None, :] + distance[..., None] * directions[None]
        return points, found & ~_near_blocked(~found, self.n_rays)


def _near_blocked(blocked, n_rays):
    """(M, R) rays within BLOCKED_MARGIN_DEG of a blocked ray (circularly)."""
    margin = int(np.ceil(BLOCKED_MARGIN_DEG / (360.0 / n_rays)))
    near = blocked.copy()
    for shift in range(1, margin + 1):
        near |= np.roll(blocked, shift, axis=1) | np.roll(blocked, -shift, axis=1)
    return near


class _Sampler:
    """Bilinear samples of image ``frame_of[m]`` at (col, row) points (M, ..., 2)."""

    def __init__(self, images, frame_of):
        self.images = images
        self.frame_of = frame_of

    def __call__(self, points):
        frame = np.broadcast_to(self.frame_of.reshape((-1,) + (1,) * (points.ndim - 2)), points.shape[:-1])
        coords = [frame.ravel(), points[..., 1].ravel(), points[..., 0].ravel()]
        values = ndimage.map_coordinates(self.images, coords, order=1, mode="nearest")
        return values.reshape(points.shape[:-1])


def _disc_points(radius_px: float) -> np.ndarray:
    steps = np.arange(-np.floor(radius_px), np.floor(radius_px) + 1)
    grid = np.stack(np.meshgrid(steps, steps), axis=-1).reshape(-1, 2)
    return grid[np.linalg.norm(grid, axis=-1) <= radius_px]


def _background(sampler, start, radius_px):
    """The local background: the median over a ring at 1.6 handle radii (the rest of
    the body covers a minority of it)."""
    angles = np.linspace(0.0, 2 * np.pi, 48, endpoint=False)
    ring = 1.6 * radius_px * np.stack([np.cos(angles), np.sin(angles)], axis=-1)
    return np.median(sampler(start[:, None, :] + ring[None]), axis=-1)


def _circle_fit(points, weights):
    """Weighted algebraic circle fit x^2 + y^2 + D x + E y + F = 0 per row of points
    (M, R, 2); returns centres (M, 2) and radii (M,)."""
    reference = (points * weights[..., None]).sum(1) / np.maximum(weights.sum(1), 1)[:, None]
    p = points - reference[:, None, :]
    design = np.stack([p[..., 0], p[..., 1], np.ones_like(p[..., 0])], axis=-1)
    target = -(p[..., 0] ** 2 + p[..., 1] ** 2)
    w = weights[..., None]
    normal = np.einsum("mri,mrj->mij", design * w, design) + 1e-9 * np.eye(3)
    rhs = np.einsum("mri,mr->mi", design * w, target)
    d, e, f = np.moveaxis(np.linalg.solve(normal, rhs[..., None])[..., 0], -1, 0)
    centre = np.stack([-d / 2, -e / 2], axis=-1)
    radius = np.sqrt(np.maximum(centre[:, 0] ** 2 + centre[:, 1] ** 2 - f, 0.0))
    return centre + reference, radius


def _robust_circle(points, found):
    keep = found.astype(float)
    for _ in range(3):
        centre, radius = _circle_fit(points, keep)
        residual = np.linalg.norm(points - centre[:, None, :], axis=-1) - radius[:, None]
        kept_residual = np.where(keep > 0, np.abs(residual), np.nan)
        kept_residual[keep.sum(axis=1) == 0] = 0.0
        mad = 1.4826 * np.nanmedian(kept_residual, axis=1)
        keep = (found & (np.abs(residual) <= np.maximum(OUTLIER_SIGMAS * mad, 0.1)[:, None])).astype(float)
    centre, radius = _circle_fit(points, keep)
    return centre, radius, keep.sum(axis=1) >= MIN_EDGE_POINTS


def sensor_errors(reading: SensorReading, true_handle_xy_um, true_force_pn) -> dict[str, np.ndarray]:
    """Per-handle position error (um) and relative force error |F_est - F| / |F| against
    the simulator's truth, over the valid readings."""
    valid = reading.valid
    position = np.linalg.norm(reading.handle_xy_um - np.asarray(true_handle_xy_um), axis=-1)[valid]
    true_force = np.asarray(true_force_pn)
    force = np.linalg.norm(reading.force_pn - true_force, axis=-1)[valid]
    return {"position_um": position, "relative_force": force / np.linalg.norm(true_force, axis=-1)[valid]}
