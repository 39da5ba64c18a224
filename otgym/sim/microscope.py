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
state. ``microscope_images`` renders a batch of frames with one vectorised pass.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy import ndimage

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


def pixel_centres_um(origin_um, shape: tuple[int, int], pixel_size_um: float) -> np.ndarray:
    """(B, h, w, 2) centres (x, y) in um of frames whose top-left corners are
    ``origin_um`` (B, 2)."""
    origin = np.asarray(origin_um, np.float32).reshape(-1, 1, 1, 2)
    rows, cols = np.meshgrid(np.arange(shape[0]), np.arange(shape[1]), indexing="ij")
    local = np.stack([cols, rows], axis=-1).astype(np.float32) + 0.5
    return origin + local * np.float32(pixel_size_um)


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
    x = origin[:, 0, None, None] + (np.arange(shape[1], dtype=np.float32) + 0.5)[None, None, :] * params.pixel_size_um
    y = origin[:, 1, None, None] + (np.arange(shape[0], dtype=np.float32) + 0.5)[None, :, None] * params.pixel_size_um
    distance = np.full((origin.shape[0],) + tuple(shape), np.inf, np.float32)
    for index in range(centres.shape[1]):
        dx2 = (x - centres[:, index, 0, None, None]) ** 2
        dy2 = (y - centres[:, index, 1, None, None]) ** 2
        np.minimum(distance, np.sqrt(dx2 + dy2) - radii[:, index, None, None], out=distance)
    illumination = _illumination(origin, shape, params, chip)
    coverage = np.clip(0.5 - distance / params.pixel_size_um, 0.0, 1.0)
    halo_d = np.clip(distance / params.halo_width_um, 0.0, 50.0)
    halo = params.halo_strength * halo_d * np.exp(1.0 - halo_d)
    intensity = illumination * (1.0 - (1.0 - params.body_transmission) * coverage) + params.background * halo
    sigma_px = params.defocus_sigma_um / params.pixel_size_um
    if sigma_px > 0:
        intensity = ndimage.gaussian_filter(intensity, (0, sigma_px, sigma_px), mode="nearest")
    return _camera(intensity, params, rng)


def microscope_image(sphere_xy_um, sphere_radius_um, origin_um, shape, params=MicroscopeParams(), rng=0, chip=None):
    """One frame (h, w): ``microscope_images`` with B = 1."""
    centres = np.asarray(sphere_xy_um, np.float32)[None]
    return microscope_images(centres, sphere_radius_um, np.asarray(origin_um)[None], shape, params, rng, chip)[0]


def _illumination(origin, shape, params: MicroscopeParams, chip: Chip | None) -> np.ndarray:
    if chip is None:
        return np.full((origin.shape[0],) + tuple(shape), params.background, np.float32)
    points = pixel_centres_um(origin, shape, params.pixel_size_um)
    index = points / np.float32(chip.pixel_size_um) - 0.5
    gray = ndimage.map_coordinates(chip.image, [index[..., 1].ravel(), index[..., 0].ravel()], order=1,
                                   mode="constant", cval=0.0).reshape(points.shape[:3])
    return (params.wall_level + (params.background - params.wall_level) * gray).astype(np.float32)


def _camera(intensity, params: MicroscopeParams, rng: np.random.Generator) -> np.ndarray:
    """Shot noise in its Gaussian limit (variance = mean; exact to well under 1 % at
    the hundreds of photo-electrons per pixel used here) plus read noise."""
    scale = params.photons_at_background / params.background
    variance = np.maximum(intensity, 0.0) / scale + (params.read_noise * params.background) ** 2
    electrons = intensity + np.sqrt(variance) * rng.standard_normal(intensity.shape, dtype=np.float32)
    levels = 2**params.bit_depth - 1
    return (np.round(np.clip(electrons, 0.0, 1.0) * levels) / levels).astype(np.float32)
