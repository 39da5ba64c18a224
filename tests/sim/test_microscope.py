"""Microscope image model: levels, halo, noise statistics, seeding, chip background."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from otgym.sim.microscope import MicroscopeParams, microscope_image, microscope_images

SHAPE = (80, 80)


def _bead_frame(params, seed=0, chip=None, origin=(0.0, 0.0)):
    return microscope_image(np.array([[4.0, 4.0]]) + origin, np.array([1.5]), origin, SHAPE, params, seed, chip)


def test_dark_body_bright_halo_and_background():
    params = MicroscopeParams(pixel_size_um=0.1, read_noise=0.0, photons_at_background=1e9)
    image = _bead_frame(params)
    centre = image[38:42, 38:42].mean()
    halo = image[40, 40 + 15 + 3]  # 0.3 um outside the 1.5 um radius
    corner = image[:5, :5].mean()
    assert centre == pytest.approx(params.background * params.body_transmission, rel=0.02)
    assert corner == pytest.approx(params.background, rel=0.01)
    assert halo > corner * 1.1


def test_noise_matches_shot_plus_read_noise():
    """The background's pixel variance must be I/N + read^2 (N photo-electrons at the
    background); with 6400 pixels the sample standard deviation has a relative standard
    error of 1/sqrt(2 * 6400) = 0.9 %, so a 5 % tolerance is over 5 sigma."""
    params = MicroscopeParams(
        pixel_size_um=0.1, photons_at_background=1000.0, read_noise=0.01, defocus_sigma_um=0.0, bit_depth=16
    )
    image = microscope_image(np.zeros((0, 2)), np.zeros(0), (0.0, 0.0), SHAPE, params, rng=3)
    expected = np.sqrt(params.background / 1000.0 * params.background + (0.01 * params.background) ** 2)
    assert image.std() == pytest.approx(expected, rel=0.05)
    assert image.mean() == pytest.approx(params.background, abs=5 * expected / np.sqrt(image.size))


def test_seeded_and_batched():
    params = MicroscopeParams()
    assert np.array_equal(_bead_frame(params, seed=5), _bead_frame(params, seed=5))
    assert not np.array_equal(_bead_frame(params, seed=5), _bead_frame(params, seed=6))
    batch = microscope_images(
        np.array([[[4.0, 4.0]], [[2.0, 5.0]]]), np.array([1.5]), np.zeros((2, 2)), SHAPE, params, 0
    )
    assert batch.shape == (2,) + SHAPE and batch.dtype == np.float32
    assert 0.0 <= batch.min() and batch.max() <= 1.0


def test_chip_walls_look_darker(default_chip):
    params = MicroscopeParams(pixel_size_um=0.5, read_noise=0.0, photons_at_background=1e9, defocus_sigma_um=0.0)
    # a 40 um field across the top inlet branch: the channel spans y = 27.5..52.5 um
    image = microscope_image(np.zeros((0, 2)), np.zeros(0), (10.0, 20.0), SHAPE, params, chip=default_chip)
    assert image[40, 40] == pytest.approx(params.background, abs=0.01)
    assert image[5, 40] == pytest.approx(params.wall_level, abs=0.01)


def test_bad_parameters():
    with pytest.raises(ValueError, match="pixel_size_um"):
        MicroscopeParams(pixel_size_um=-0.1)
    with pytest.raises(ValueError, match="bit_depth"):
        MicroscopeParams(bit_depth=0)
    with pytest.raises(ValueError, match="sphere_xy_um"):
        microscope_images(np.zeros((3, 2)), np.ones(3), np.zeros((1, 2)), SHAPE)


def _reference_images(centres, radii, origin, shape, params, seed, chip):
    """The image model in numpy and scipy.ndimage, as it was written before the
    compiled kernel: float32 per pixel over every sphere, the chip by
    ``map_coordinates``, the blur by ``gaussian_filter``, the camera's draws from the
    same generator."""
    centres = np.asarray(centres, np.float32)
    radii = np.broadcast_to(np.asarray(radii, np.float32), centres.shape[:2])
    origin = np.asarray(origin, np.float32)
    columns = np.arange(shape[1], dtype=np.float32) + 0.5
    rows = np.arange(shape[0], dtype=np.float32) + 0.5
    x = origin[:, 0, None, None] + columns[None, None, :] * params.pixel_size_um
    y = origin[:, 1, None, None] + rows[None, :, None] * params.pixel_size_um
    distance = np.full((len(origin),) + shape, np.inf, np.float32)
    for n in range(centres.shape[1]):
        square = (x - centres[:, n, 0, None, None]) ** 2 + (y - centres[:, n, 1, None, None]) ** 2
        np.minimum(distance, np.sqrt(square) - radii[:, n, None, None], out=distance)
    light = np.float32(params.background)
    if chip is not None:
        chip_pixel_um = np.float32(chip.pixel_size_um)
        chip_rows, chip_cols = np.broadcast_arrays(y / chip_pixel_um - 0.5, x / chip_pixel_um - 0.5)
        gray = ndimage.map_coordinates(chip.image, [chip_rows.ravel(), chip_cols.ravel()], order=1, mode="constant")
        light = params.wall_level + (params.background - params.wall_level) * gray.reshape(chip_rows.shape)
    coverage = np.clip(0.5 - distance / params.pixel_size_um, 0.0, 1.0)
    halo_d = np.clip(distance / params.halo_width_um, 0.0, 50.0)
    halo = params.halo_strength * halo_d * np.exp(1.0 - halo_d)
    intensity = light * (1.0 - (1.0 - params.body_transmission) * coverage) + params.background * halo
    sigma_px = params.defocus_sigma_um / params.pixel_size_um
    if sigma_px > 0:
        intensity = ndimage.gaussian_filter(intensity, (0, sigma_px, sigma_px), mode="nearest")
    variance = np.maximum(intensity, 0.0) / (params.photons_at_background / params.background)
    variance += (params.read_noise * params.background) ** 2
    noise = np.random.default_rng(seed).standard_normal(intensity.shape, dtype=np.float32)
    levels = 2**params.bit_depth - 1
    return np.round(np.clip(intensity + np.sqrt(variance) * noise, 0.0, 1.0) * levels) / levels


def test_frames_match_the_numpy_reference(default_chip):
    """The compiled renderer against ``_reference_images`` on 60 random scenes (0-12
    spheres, pixels of 0.05-0.5 um, with and without blur, with the chip or without,
    frames inside the chip and across its border), with the camera's noise. The two
    compute the same float32 values up to a unit in the last place or two (numpy's
    float32 exp is not libm's), which moves a pixel by one grey level only where a
    quantisation threshold falls between them: for values below 1 (ulp <= 6e-8) and
    12-bit levels (2.4e-4) at most 2 x 6e-8 / 2.4e-4 = 5e-4 of the pixels even if
    every pixel differed, so about 75 of the ~150 000 here at worst (sd 9); the bound
    of 1e-3 is 8 sd above that. A wrong halo, coverage, blur or noise moves most
    pixels by many levels."""
    rng = np.random.default_rng(17)
    differing = total = 0
    for scene in range(60):
        frames, spheres = int(rng.integers(1, 4)), int(rng.integers(0, 13))
        shape = (int(rng.integers(8, 70)), int(rng.integers(8, 70)))
        params = MicroscopeParams(
            pixel_size_um=float(rng.choice([0.05, 0.1, 0.25, 0.5])),
            defocus_sigma_um=float(rng.choice([0.0, 0.05, 0.12, 0.4])),
        )
        chip = default_chip if scene % 4 else None
        corner = np.array(default_chip.image.shape[::-1]) * default_chip.pixel_size_um * rng.random(2)
        origin = corner + rng.uniform(-4.0, 4.0, (frames, 2)) if scene % 3 else rng.uniform(-6.0, 3.0, (frames, 2))
        span = np.array(shape[::-1]) * params.pixel_size_um
        centres = origin[:, None] + (1.4 * rng.random((frames, spheres, 2)) - 0.2) * span  # some beyond the frame
        radii = rng.uniform(0.3, 2.5, spheres)
        image = microscope_images(centres, radii, origin, shape, params, scene, chip)
        reference = _reference_images(centres, radii, origin, shape, params, scene, chip)
        assert image.shape == reference.shape and image.dtype == np.float32
        level = 1.0 / (2**params.bit_depth - 1)
        assert np.abs(image - reference).max() <= level * 1.0001
        differing += np.count_nonzero(image != reference)
        total += image.size
    assert total > 100_000
    assert differing <= 1e-3 * total
