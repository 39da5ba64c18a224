"""The grid traversal never misses a pixel a segment crosses."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from otgym.planning.collision import segments_free


def _dense_check(free, a, b, samples=20001):
    """Brute force: the pixels of many points along the segment."""
    t = np.linspace(0.0, 1.0, samples)[:, None]
    points = a + t * (b - a)
    rows, cols = np.floor(points[:, 1]).astype(int), np.floor(points[:, 0]).astype(int)
    inside = (rows >= 0) & (rows < free.shape[0]) & (cols >= 0) & (cols < free.shape[1])
    return bool(inside.all() and free[rows, cols].all())


@settings(max_examples=200, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_traversal_agrees_with_dense_sampling(seed):
    rng = np.random.default_rng(seed)
    free = rng.random((12, 12)) > 0.2
    a, b = rng.uniform(0, 12, (2, 2))
    exact = bool(segments_free(free, np.array([a, b]))[0])
    dense = _dense_check(free, a, b)
    if dense is False:
        assert exact is False  # never misses a blocked pixel found by sampling
    if exact is False:
        # the blocked pixel it found is real: sampling finds it too, unless the segment
        # only clips it over less than the sampling interval (checked by finer sampling)
        assert dense is False or _dense_check(free, a, b, samples=2_000_001) is False


def test_corner_touch_between_diagonal_free_pixels_is_free():
    free = np.array([[True, False], [False, True]])
    assert segments_free(free, np.array([[0.5, 0.5], [1.5, 1.5]])).all()
    # slightly off the corner, the segment clips a blocked pixel
    assert not segments_free(free, np.array([[0.5, 0.5], [1.5, 1.52]])).any()


def test_points_outside_the_map_are_blocked():
    free = np.ones((3, 3), dtype=bool)
    assert segments_free(free, np.array([[0.5, 0.5], [2.5, 2.5], [3.5, 2.5]])).tolist() == [True, False]
