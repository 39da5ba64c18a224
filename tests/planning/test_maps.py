"""Random benchmark maps: seeded, with connected corners."""

import numpy as np
import pytest

from otgym.planning.maps import random_obstacle_map


def test_random_map_is_seeded_with_the_requested_density():
    free = random_obstacle_map((200, 200), 0.25, seed=1)
    assert np.array_equal(free, random_obstacle_map((200, 200), 0.25, seed=1))
    assert free[0, 0] and free[-1, -1]
    assert abs((~free).mean() - 0.25) < 0.01  # binomial sd is 0.003 for 40 000 pixels


def test_disconnected_corners_are_reported():
    with pytest.raises(ValueError, match="not connected"):
        random_obstacle_map((50, 50), 0.8, seed=0)
