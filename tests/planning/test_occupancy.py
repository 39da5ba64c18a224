"""Binarisation, disk dilation, coordinate convention and start/goal errors."""

import math

import numpy as np
import pytest

from otgym.planning.occupancy import binarise, build_occupancy, dilate_obstacles, pixels_to_um


def test_binarise_fixed_and_otsu_separate_two_noisy_levels():
    rng = np.random.default_rng(0)
    truth = rng.random((30, 30)) > 0.4
    image = np.where(truth, 0.8, 0.2) + rng.normal(0, 0.05, truth.shape)
    assert np.array_equal(binarise(image, 0.5), truth)
    assert np.array_equal(binarise(image, "otsu"), truth)
    assert binarise(truth) is truth  # a boolean mask is already a free mask


@pytest.mark.parametrize(
    "image, threshold, message",
    [
        (np.full((5, 5), 0.3), "otsu", "uniform"),
        (np.array([[np.nan, 1.0]]), 0.5, "NaN"),
        (np.zeros((0, 3)), 0.5, "non-empty"),
        (np.ones((4, 4)), "mean", "otsu"),
    ],
)
def test_binarise_rejects_bad_input(image, threshold, message):
    with pytest.raises(ValueError, match=message):
        binarise(image, threshold)


@pytest.mark.parametrize("seed", range(4))
def test_dilation_equals_brute_force_disk(seed):
    rng = np.random.default_rng(seed)
    free = rng.random((25, 31)) > 0.1
    radius = rng.uniform(0.5, 4.0)
    rows, cols = np.nonzero(~free)
    grid_r, grid_c = np.mgrid[0:25, 0:31]
    nearest = np.min(np.hypot(grid_r[..., None] - rows, grid_c[..., None] - cols), axis=-1)
    assert np.array_equal(dilate_obstacles(free, radius), nearest > radius)


def _distance_to_squares(point, rows, cols):
    """Exact distance from a point (x, y in pixel units) to the unit squares of pixels."""
    dx = np.maximum(np.maximum(cols - point[0], point[0] - (cols + 1)), 0.0)
    dy = np.maximum(np.maximum(rows - point[1], point[1] - (rows + 1)), 0.0)
    return np.hypot(dx, dy).min()


def test_default_margin_keeps_the_robot_off_every_obstacle_pixel():
    # the module's claim: with margin sqrt(2) pixels, a robot disk centred anywhere in a
    # free pixel of the dilated map never overlaps an obstacle pixel's square
    rng = np.random.default_rng(1)
    free = rng.random((40, 40)) > 0.03
    pixel, radius = 0.5, 2.0
    occupancy = build_occupancy(free, pixel, radius)
    assert occupancy.clearance_um == pytest.approx(radius + math.sqrt(2) * pixel)
    rows, cols = np.nonzero(~free)
    free_rows, free_cols = np.nonzero(occupancy.planning)
    pick = rng.choice(free_rows.size, 300)
    for r, c in zip(free_rows[pick], free_cols[pick]):
        corner = np.array([c, r]) + rng.choice([0.0, 1.0], 2)  # the worst points are the corners
        assert _distance_to_squares(corner, rows, cols) * pixel >= radius - 1e-12


def test_pixel_centres_in_um_origin_top_left_y_down():
    assert np.allclose(pixels_to_um([[2, 3]], 0.5), [[1.75, 1.25]])  # row 2 -> y, col 3 -> x


def test_start_and_goal_errors_name_the_problem(corridor):
    occupancy = build_occupancy(corridor, 1.0, 2.0, 0.0)
    assert occupancy.require_free((10.5, 10.5), "start") == (10, 10)
    with pytest.raises(ValueError, match="start .* outside the image"):
        occupancy.require_free((-1.0, 5.0), "start")
    with pytest.raises(ValueError, match="goal .* inside an obstacle"):
        occupancy.require_free((1.0, 1.0), "goal")
    with pytest.raises(ValueError, match="goal .* closer to a wall"):
        occupancy.require_free((10.5, 3.5), "goal")
    with pytest.raises(ValueError, match="two finite numbers"):
        occupancy.require_free((np.nan, 1.0), "start")


def test_robot_larger_than_every_channel_and_no_channel(corridor):
    with pytest.raises(ValueError, match="larger than every channel.*at most 8.485"):
        build_occupancy(corridor, 1.0, 9.0, 0.0)
    with pytest.raises(ValueError, match="no channel"):
        build_occupancy(np.zeros((10, 10)), 1.0, 1.0, threshold=0.5)
    with pytest.raises(ValueError, match="pixel size"):
        build_occupancy(corridor, 0.0, 1.0)
