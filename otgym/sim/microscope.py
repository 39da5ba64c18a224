"""Bright-field-like microscope images of a scene, for the vision sensor and for users.

Image model (phenomenological, per pixel of a chosen size; Murphy & Davidson,
Fundamentals of Light Microscopy, 2nd ed., ch. 6 and 7):

1. Illumination: ``background`` in the channel and ``wall_level`` over the chip's
   solid (PDMS walls scatter and look darker), following the chip image.
2. Bodies: the union of the scene's spheres transmits a fraction ``body_transmission``
   (dark bodies; light is scattered out of the objective's aperture), anti-aliased
   over one pixel at the sphere's equator.
3. Halo: a bright rim just outside each body, ``halo_strength * (d/w) exp(1 - d/w)``
   at distance d from the body (peak at d = w = ``halo_width_um``), as the phase
   halo of a slightly defocused refractile object.
4. Defocus: a Gaussian point-spread function of standard deviation
   ``defocus_sigma_um``.
5. Camera: shot noise for ``photons_at_background`` photo-electrons at the background
   level (Poisson, in its Gaussian limit), Gaussian read noise ``read_noise`` (fraction of background),
   quantised to ``bit_depth`` bits; values in [0, 1]. Seeded.

Inputs are plain numpy (positions in um, origin at the chip's top-left corner, x right,
y down; pixel centres at +0.5 pixel), so this module does not depend on the physics
state.

``microscope_images`` renders a batch of frames in one call of a numba kernel
(``cache=True``: compiled once per machine, about 3 s of CPU). The interactive loop
renders four 48 x 48 crops a tick, where numpy's cost was per call rather than per
pixel. The kernel does numpy's float32 arithmetic per pixel, and the blur and the chip
lookup in float64 as ``scipy.ndimage.gaussian_filter`` and ``map_coordinates`` do, so
its frames are those of the numpy and scipy formulation to float round-off
(tests/sim/test_microscope.py keeps that formulation as the reference). Only the
spheres that can be the nearest body somewhere in a frame are visited there.
"""

from __future__ import annotations

import dataclasses
import functools

import numba
import numpy as np

from otgym.physics.validation import require_positive_scalar
from otgym.sim.chip import Chip


@dataclasses.dataclass(frozen=True)
class MicroscopeParams:
    pixel_size_um: float = 0.1
    background: float = 0.75
    wall_level: float = 0.45
    body_transmission: float = 0.35
    halo_strength: float = 0.25
    halo_width_um: float = 0.25
    defocus_sigma_um: float = 0.12
    photons_at_background: float = 3000.0
    read_noise: float = 0.005
    bit_depth: int = 12

    def __post_init__(self):
        for name in ("pixel_size_um", "background", "halo_width_um", "photons_at_background"):
            require_positive_scalar(name, getattr(self, name))
        for name in ("wall_level", "body_transmission", "halo_strength", "defocus_sigma_um", "read_noise"):
            value = getattr(self, name)
            if not np.isfinite(value) or value < 0:
                raise ValueError(f"{name} must be non-negative, got {value!r}")
        if not 1 <= self.bit_depth <= 16:
            raise ValueError(f"bit_depth must be within 1..16, got {self.bit_depth!r}")


def microscope_images(
    sphere_xy_um,
    sphere_radius_um,
    origin_um,
    shape: tuple[int, int],
    params: MicroscopeParams = MicroscopeParams(),
    rng: np.random.Generator | int = 0,
    chip: Chip | None = None,
) -> np.ndarray:
    """Render B frames (B, h, w) float32 in [0, 1].

    sphere_xy_um: (B, N, 2) sphere centres per frame; sphere_radius_um: (N,) or (B, N);
    origin_um: (B, 2) top-left corner of each frame; chip: the background (None: an
    open channel everywhere)."""
    rng = np.random.default_rng(rng)
    centres = np.asarray(sphere_xy_um, np.float32)
    if centres.ndim != 3 or centres.shape[-1] != 2:
        raise ValueError(f"sphere_xy_um must have shape (B, N, 2), got {centres.shape}")
    radii = np.broadcast_to(np.asarray(sphere_radius_um, np.float32), centres.shape[:2])
    origin = np.asarray(origin_um, np.float32).reshape(-1, 2)
    if origin.shape[0] != centres.shape[0]:
        raise ValueError(f"origin_um gives {origin.shape[0]} frames but sphere_xy_um {centres.shape[0]}")
    height, width = (int(n) for n in shape)
    chip_image = _NO_CHIP if chip is None else _read_only(chip.image)
    chip_pixel_um = np.float32(1.0 if chip is None else chip.pixel_size_um)
    p = params
    noise = rng.standard_normal((origin.shape[0], height, width), dtype=np.float32)
    return _render(
        _read_only(centres),
        _read_only(radii),
        _read_only(origin),
        np.float32(p.pixel_size_um),
        chip_image,
        chip_pixel_um,
        chip is not None,
        np.float32(p.background),
        np.float32(p.wall_level),
        np.float32(p.background - p.wall_level),
        np.float32(1.0 - p.body_transmission),
        np.float32(p.halo_strength),
        np.float32(p.halo_width_um),
        _gaussian_weights(p.defocus_sigma_um / p.pixel_size_um),
        np.float32(p.photons_at_background / p.background),
        np.float32((p.read_noise * p.background) ** 2),
        np.float32(2**p.bit_depth - 1),
        noise,
    )


def microscope_image(sphere_xy_um, sphere_radius_um, origin_um, shape, params=MicroscopeParams(), rng=0, chip=None):
    """One frame (h, w): ``microscope_images`` with B = 1."""
    centres = np.asarray(sphere_xy_um, np.float32)[None]
    return microscope_images(centres, sphere_radius_um, np.asarray(origin_um)[None], shape, params, rng, chip)[0]


TRUNCATE_SIGMAS = 4.0
"""The defocus kernel is cut at 4 standard deviations (scipy.ndimage.gaussian_filter's
default)."""


def _read_only(array) -> np.ndarray:
    """A C-contiguous float32 read-only view (a copy only where needed): the kernel's
    arguments have one numba type whatever the caller passed, so it compiles once."""
    view = np.ascontiguousarray(array, np.float32).view()
    view.flags.writeable = False
    return view


_NO_CHIP = _read_only(np.zeros((1, 1)))


@functools.lru_cache(maxsize=16)
def _gaussian_weights(sigma_px: float) -> np.ndarray:
    """The normalised Gaussian of ``sigma_px`` cut at TRUNCATE_SIGMAS, as
    ``scipy.ndimage.gaussian_filter`` builds it, from its centre outwards (weights[k]
    at +-k pixels); empty for no blur (sigma_px 0)."""
    if sigma_px <= 1e-15:  # gaussian_filter skips such axes too
        weights = np.zeros(0)
    else:
        radius = int(TRUNCATE_SIGMAS * sigma_px + 0.5)
        x = np.arange(-radius, radius + 1)
        phi = np.exp(-0.5 / (sigma_px * sigma_px) * x**2)
        weights = (phi / phi.sum())[radius:].copy()
    weights.flags.writeable = False
    return weights


@numba.njit(cache=True)
def _render(
    centres,
    radii,
    origin,
    pixel_um,
    chip_image,
    chip_pixel_um,
    has_chip,
    background,
    wall_level,
    wall_to_background,
    absorbed,
    halo_strength,
    halo_width_um,
    blur,
    photons_scale,
    read_variance,
    levels,
    noise,
):
    """Steps 1-5 of the image model for every frame (B, h, w) float32: per pixel the
    distance to the nearest body surface, its coverage and halo, the illumination
    (the chip's gray level, or the background without one), the defocus blur and the
    camera, which adds ``noise`` (B, h, w) standard normal draws scaled to the shot
    and read noise and quantises to ``levels``. Scalars are float32, ``blur`` the
    kernel of ``_gaussian_weights``."""
    frames, height, width = noise.shape
    half = np.float32(0.5)
    zero = np.float32(0.0)
    one = np.float32(1.0)
    images = np.empty((frames, height, width), np.float32)
    if height == 0 or width == 0:
        return images
    x = np.empty(width, np.float32)
    y = np.empty(height, np.float32)
    distance = np.empty(width, np.float32)
    light = np.empty(width, np.float32)
    for j in range(width):
        light[j] = background
    chip_x = (np.zeros(width, np.int64), np.zeros(width, np.int64), np.zeros(width), np.zeros(width, np.bool_))
    chip_y = (np.zeros(height, np.int64), np.zeros(height, np.int64), np.zeros(height), np.zeros(height, np.bool_))
    for b in range(frames):
        for j in range(width):
            x[j] = origin[b, 0] + (np.float32(j) + half) * pixel_um
        for i in range(height):
            y[i] = origin[b, 1] + (np.float32(i) + half) * pixel_um
        if has_chip:
            _chip_axis(x, chip_pixel_um, chip_image.shape[1], *chip_x)
            _chip_axis(y, chip_pixel_um, chip_image.shape[0], *chip_y)
        nearest = _candidates(centres[b], radii[b], x[0], x[width - 1], y[0], y[height - 1])
        intensity = images[b]
        for i in range(height):
            for j in range(width):
                distance[j] = np.inf
            for n in nearest:
                cx = centres[b, n, 0]
                dy = y[i] - centres[b, n, 1]
                dy2 = dy * dy
                r = radii[b, n]
                for j in range(width):
                    dx = x[j] - cx
                    distance[j] = min(distance[j], np.sqrt(dx * dx + dy2) - r)
            if has_chip:
                if chip_y[3][i]:
                    _chip_row(
                        chip_image[chip_y[0][i]],
                        chip_image[chip_y[1][i]],
                        chip_y[2][i],
                        chip_x,
                        wall_level,
                        wall_to_background,
                        light,
                    )
                else:
                    for j in range(width):
                        light[j] = wall_level
            for j in range(width):
                d = distance[j]
                coverage = min(max(half - d / pixel_um, zero), one)
                halo_d = min(max(d / halo_width_um, zero), np.float32(50.0))
                halo = halo_strength * halo_d * np.exp(one - halo_d)
                intensity[i, j] = light[j] * (one - absorbed * coverage) + background * halo
        if len(blur):
            _blur_rows(intensity, blur)
            _blur_columns(intensity, blur)
        for i in range(height):
            for j in range(width):
                value = intensity[i, j]
                variance = max(value, zero) / photons_scale + read_variance
                electrons = value + np.sqrt(variance) * noise[b, i, j]
                intensity[i, j] = np.rint(min(max(electrons, zero), one) * levels) / levels
    return images


@numba.njit(cache=True)
def _candidates(centres, radii, x_min, x_max, y_min, y_max):
    """Indices of the spheres that can be the nearest body surface somewhere in the
    rectangle of pixel centres: a sphere whose nearest possible distance exceeds
    another's farthest is never the minimum there (bounds in float64, with a margin
    far above float32 round-off), so dropping it changes no pixel."""
    count = centres.shape[0]
    low = np.empty(count)
    best_high = np.inf
    for n in range(count):
        cx = np.float64(centres[n, 0])
        cy = np.float64(centres[n, 1])
        gap_x = max(np.float64(x_min) - cx, 0.0, cx - np.float64(x_max))
        gap_y = max(np.float64(y_min) - cy, 0.0, cy - np.float64(y_max))
        far_x = max(abs(cx - np.float64(x_min)), abs(cx - np.float64(x_max)))
        far_y = max(abs(cy - np.float64(y_min)), abs(cy - np.float64(y_max)))
        low[n] = np.sqrt(gap_x * gap_x + gap_y * gap_y) - radii[n]
        best_high = min(best_high, np.sqrt(far_x * far_x + far_y * far_y) - radii[n])
    kept = np.empty(count, np.int64)
    n_kept = 0
    for n in range(count):
        if low[n] <= best_high + 1e-3:
            kept[n_kept] = n
            n_kept += 1
    return kept[:n_kept]


@numba.njit(cache=True)
def _chip_axis(centres_um, chip_pixel_um, chip_size, start, end, fraction, inside):
    """Where pixel centres fall along one axis of the chip image, for bilinear lookups
    as ``scipy.ndimage.map_coordinates(order=1, mode="constant", cval=0)`` makes them:
    the two chip pixels around each centre, the fraction towards the second, and
    whether the centre lies within [0, n - 1] (outside, the value is 0). Fills the
    last four arguments."""
    for k in range(len(centres_um)):
        index = np.float64(centres_um[k] / chip_pixel_um - np.float32(0.5))
        inside[k] = 0.0 <= index <= chip_size - 1
        first = min(max(int(np.floor(index)), 0), chip_size - 1)
        start[k] = first
        end[k] = min(first + 1, chip_size - 1)
        fraction[k] = index - first


@numba.njit(cache=True)
def _chip_row(top, bottom, tr, columns, wall_level, wall_to_background, light):
    """Illumination (step 1) along one row of pixels between chip rows ``top`` and
    ``bottom`` (fraction ``tr`` towards the second): the chip image's bilinear gray
    level mapped from wall_level (solid, 0) to the background (channel, 1)."""
    start, end, fraction, inside = columns
    for j in range(len(light)):
        gray = np.float32(0.0)
        if inside[j]:
            c0 = start[j]
            c1 = end[j]
            tc = fraction[j]
            gray = np.float32(
                top[c0] * (1.0 - tr) * (1.0 - tc)
                + top[c1] * (1.0 - tr) * tc
                + bottom[c0] * tr * (1.0 - tc)
                + bottom[c1] * tr * tc
            )
        light[j] = wall_level + wall_to_background * gray


@numba.njit(cache=True)
def _blur_rows(frame, weights):
    """Correlate each column of ``frame`` (h, w) in place with the symmetric kernel
    (weights[0] the centre), edges extended with the nearest pixel; sums in float64,
    the result rounded to float32 (scipy.ndimage.correlate1d, mode "nearest")."""
    height, width = frame.shape
    source = frame.copy()
    total = np.empty(width)
    for i in range(height):
        for j in range(width):
            total[j] = source[i, j] * weights[0]
        for k in range(len(weights) - 1, 0, -1):
            above = max(i - k, 0)
            below = min(i + k, height - 1)
            for j in range(width):
                total[j] += (np.float64(source[above, j]) + np.float64(source[below, j])) * weights[k]
        for j in range(width):
            frame[i, j] = np.float32(total[j])


@numba.njit(cache=True)
def _blur_columns(frame, weights):
    """The same along each row of ``frame`` (through its transpose, where the sums run
    over contiguous memory)."""
    height, width = frame.shape
    transposed = np.empty((width, height), np.float32)
    for i in range(height):
        for j in range(width):
            transposed[j, i] = frame[i, j]
    _blur_rows(transposed, weights)
    for i in range(height):
        for j in range(width):
            frame[i, j] = transposed[j, i]
