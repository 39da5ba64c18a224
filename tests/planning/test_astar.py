"""A* returns shortest 8-connected paths: same cost as scikit-image's MCP_Geometric."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from skimage.graph import MCP_Geometric

from otgym.planning.astar import astar


def _mcp_cost(free, start, goal):
    costs, _ = MCP_Geometric(np.where(free, 1.0, np.inf)).find_costs([start], [goal])
    return costs[goal]


def _check_path(free, path, start, goal, cost):
    assert tuple(path[0]) == start and tuple(path[-1]) == goal
    assert free[path[:, 0], path[:, 1]].all()
    steps = np.abs(np.diff(path, axis=0))
    assert np.all(steps.max(axis=1) == 1)  # 8-neighbour steps only
    assert cost == pytest.approx(np.sum(np.where(steps.sum(axis=1) == 2, math.sqrt(2), 1.0)), rel=1e-12)


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1), height=st.integers(1, 40), width=st.integers(1, 40), fraction=st.floats(0.0, 0.45)
)
def test_cost_equals_mcp_geometric_on_random_maps(seed, height, width, fraction):
    rng = np.random.default_rng(seed)
    free = rng.random((height, width)) >= fraction
    cells = np.argwhere(free)
    if len(cells) == 0:
        return
    start, goal = (tuple(int(v) for v in cells[i]) for i in rng.integers(0, len(cells), 2))
    reference = _mcp_cost(free, start, goal)
    if not np.isfinite(reference):
        with pytest.raises(ValueError, match="not reachable"):
            astar(free, start, goal)
        return
    path, cost = astar(free, start, goal)
    # both sum the same 1 and sqrt(2) steps; 1e-6 relative (the bar) leaves
    # room only for floating-point summation order
    assert cost == pytest.approx(reference, rel=1e-6)
    _check_path(free, path, start, goal, cost)


def test_large_random_map_is_optimal():
    rng = np.random.default_rng(7)
    free = rng.random((300, 300)) >= 0.25
    free[0, 0] = free[-1, -1] = True
    path, cost = astar(free, (0, 0), (299, 299))
    assert cost == pytest.approx(_mcp_cost(free, (0, 0), (299, 299)), rel=1e-6)
    _check_path(free, path, (0, 0), (299, 299), cost)


def test_empty_map_cost_is_the_octile_distance():
    free = np.ones((20, 30), dtype=bool)
    _, cost = astar(free, (2, 1), (17, 28))
    assert cost == pytest.approx(15 * math.sqrt(2) + 12)


def test_start_equal_goal_and_errors():
    free = np.ones((5, 5), dtype=bool)
    path, cost = astar(free, (2, 2), (2, 2))
    assert path.tolist() == [[2, 2]] and cost == 0.0
    free[:, 2] = False
    with pytest.raises(ValueError, match="not reachable"):
        astar(free, (0, 0), (4, 4))
    with pytest.raises(ValueError, match="start .* not free"):
        astar(free, (0, 2), (4, 4))
    with pytest.raises(ValueError, match="goal .* outside"):
        astar(free, (0, 0), (5, 0))
    with pytest.raises(ValueError, match="boolean"):
        astar(free.astype(int), (0, 0), (1, 1))
