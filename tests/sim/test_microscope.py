"""Microscope image model: levels, halo, noise statistics, seeding, chip background."""

from __future__ import annotations

import numpy as np
import pytest

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
    params = MicroscopeParams(pixel_size_um=0.1, photons_at_background=1000.0, read_noise=0.01,
                              defocus_sigma_um=0.0, bit_depth=16)
    image = microscope_image(np.zeros((0, 2)), np.zeros(0), (0.0, 0.0), SHAPE, params, rng=3)
    expected = np.sqrt(params.background / 1000.0 * params.background + (0.01 * params.background) ** 2)
    assert image.std() == pytest.approx(expected, rel=0.05)
    assert image.mean() == pytest.approx(params.background, abs=5 * expected / np.sqrt(image.size))


def test_seeded_and_batched():
    params = MicroscopeParams()
    assert np.array_equal(_bead_frame(params, seed=5), _bead_frame(params, seed=5))
    assert not np.array_equal(_bead_frame(params, seed=5), _bead_frame(params, seed=6))
    batch = microscope_images(np.array([[[4.0, 4.0]], [[2.0, 5.0]]]), np.array([1.5]), np.zeros((2, 2)), SHAPE, params, 0)
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
