"""The smoothed path never enters the dilated obstacles and is no longer than A*."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from otgym.planning.astar import astar
from otgym.planning.collision import segments_free
from otgym.planning.metrics import path_length, turning_angles
from otgym.planning.occupancy import build_occupancy, pixels_to_um
from otgym.planning.smoothing import smooth_path, string_pull


def _astar_um(free, pixel, start=None, goal=None):
    start = start or (0, 0)
    goal = goal or (free.shape[0] - 1, free.shape[1] - 1)
    path, _ = astar(free, start, goal)
    return pixels_to_um(path, pixel)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), fraction=st.floats(0.05, 0.3), pixel=st.sampled_from([0.5, 1.0, 2.0]))
def test_smoothed_path_is_free_shorter_and_keeps_its_ends(seed, fraction, pixel):
    rng = np.random.default_rng(seed)
    free = rng.random((50, 50)) >= fraction
    free[0, 0] = free[-1, -1] = True
    try:
        grid_path = _astar_um(free, pixel)
    except ValueError:
        return  # corners not connected on this map
    smooth = smooth_path(grid_path, free, pixel)
    assert segments_free(free, smooth / pixel).all()  # the guarantee, on the output itself
    assert np.array_equal(smooth[0], grid_path[0]) and np.array_equal(smooth[-1], grid_path[-1])
    assert path_length(smooth) <= path_length(grid_path) + 1e-9
    spacing = np.linalg.norm(np.diff(smooth, axis=0), axis=1)
    # arc length is inverted on a grid 8 times finer than the step, so spacing is
    # uniform to a fraction of a percent (tight corners), not exactly
    assert spacing.max() <= 0.25 * pixel * 1.01


def test_corner_of_a_channel_is_rounded(corridor):
    occupancy = build_occupancy(corridor, 1.0, 2.0, 0.0)
    grid_path = np.vstack(((5.5, 9.5), _astar_um(occupancy.planning, 1.0, (9, 5), (33, 69))))
    smooth = smooth_path(grid_path, occupancy.planning, 1.0, step_um=0.1)
    assert segments_free(occupancy.planning, smooth).all()
    # a grid path turns by 45 degrees at once; the spline spreads the channel's 90 degree
    # turn over many small steps: no turn above 10 degrees per 0.1 um
    assert np.degrees(np.abs(turning_angles(grid_path, 0.1))).max() >= 44
    assert np.degrees(np.abs(turning_angles(smooth, 0.1))).max() < 10
    assert path_length(smooth) < path_length(grid_path)


def test_string_pull_keeps_ends_and_stays_free():
    rng = np.random.default_rng(3)
    free = rng.random((60, 60)) >= 0.2
    free[0, 0] = free[-1, -1] = True
    grid = _astar_um(free, 1.0)
    pulled = string_pull(free, grid)
    assert np.array_equal(pulled[[0, -1]], grid[[0, -1]])
    assert segments_free(free, pulled).all()
    assert len(pulled) < len(grid) and path_length(pulled) <= path_length(grid)


def test_straight_path_stays_straight_and_bad_paths_are_rejected():
    free = np.ones((10, 20), dtype=bool)
    smooth = smooth_path(np.array([[0.5, 5.5], [19.5, 5.5]]), free, 1.0)
    assert np.allclose(smooth[:, 1], 5.5) and smooth[-1, 0] == 19.5
    free[:, 10] = False
    with pytest.raises(ValueError, match="crosses an obstacle"):
        smooth_path(np.array([[0.5, 5.5], [19.5, 5.5]]), free, 1.0)
    with pytest.raises(ValueError, match="step"):
        smooth_path(np.array([[0.5, 5.5], [5.5, 5.5]]), free, 1.0, step_um=0.0)
    with pytest.raises(ValueError, match="finite"):
        smooth_path(np.array([[0.5, np.nan]]), free, 1.0)
