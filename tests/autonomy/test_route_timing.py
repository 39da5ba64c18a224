"""The earliest passage along a route among moving obstacles (``otgym.autonomy.route_timing``),
on straight routes and hand-made tracks whose answers are known in closed form."""

import numpy as np
import pytest

from otgym.autonomy.route_timing import AssemblyShape, earliest_passage
from otgym.tasks.transport.scenario import Scenario

LENGTH_UM, SPEED_UM_S = 100.0, 5.0
ARC_STEP_UM = 0.25
GRID_S = 2 * ARC_STEP_UM / SPEED_UM_S  # the grid's resolution in arrival time
POINT = AssemblyShape(np.zeros((1, 2)), np.array([1.0]))  # one sphere of 1 um at the cell
OBSTACLE_RADIUS_UM = 1.0  # contact at 2 um between centres


def straight_route(direction=(1.0, 0.0)):
    arc = np.linspace(0.0, LENGTH_UM, 401)
    return arc[:, None] * np.asarray(direction), arc


def track(start, direction, depart_s, end_s, speed_um_s=100.0) -> Scenario:
    """One obstacle at ``start`` until ``depart_s``, then moving along ``direction``
    until ``end_s``."""
    one = lambda value: np.array([value], float)  # noqa: E731
    return Scenario(
        0,
        one(0.0),
        one(depart_s),
        np.array([start], float),
        np.array([direction], float),
        one(speed_um_s),
        one(depart_s),
        one(end_s),
    )


def passage(scenario, route=None, shape=POINT, speed_um_s=SPEED_UM_S, **kwargs):
    route_um, arc_um = route if route is not None else straight_route()
    return earliest_passage(
        scenario, route_um, arc_um, shape, OBSTACLE_RADIUS_UM, 0.0, 0.0, speed_um_s, arc_step_um=ARC_STEP_UM, **kwargs
    )


@pytest.mark.parametrize("speed_um_s", [SPEED_UM_S, 8.0, 13.0])
def test_an_obstacle_far_from_the_route_costs_nothing(speed_um_s):
    """Unobstructed, the assembly arrives at the speed limit, whatever it is."""
    result = passage(track((50.0, 30.0), (0.0, 1.0), 0.0, 1.0), speed_um_s=speed_um_s)
    assert result.free_s == pytest.approx(LENGTH_UM / speed_um_s)
    assert result.free_s <= result.arrival_s <= result.free_s + 2 * ARC_STEP_UM / speed_um_s


def test_an_obstacle_standing_on_the_route_is_waited_out_until_it_leaves():
    """An obstacle on the route at arc 50 until 20 s, then gone sideways at 100 um/s:
    the assembly can get within 2 um of it (arc 48) by 9.6 s and must wait there, so it
    arrives at 20 s + (100 - 48) / 5 = 30.4 s."""
    leaves_s = 20.0 + 2.0 / 100.0
    result = passage(track((50.0, 0.0), (0.0, 1.0), 20.0, 21.0))
    expected_s = leaves_s + (LENGTH_UM - 48.0) / SPEED_UM_S
    assert expected_s - GRID_S <= result.arrival_s <= expected_s + GRID_S
    assert result.lost_s == pytest.approx(expected_s - LENGTH_UM / SPEED_UM_S, abs=GRID_S)


def test_an_obstacle_that_arrives_after_the_assembly_has_passed_costs_nothing():
    """The obstacle moves onto the route at arc 50 at 20 s and stays: the assembly
    passes arc 52 at 10.4 s, before it comes."""
    result = passage(track((50.0, -40.0), (0.0, 1.0), 19.6, 19.99))
    assert result.arrival_s <= result.free_s + GRID_S


def test_an_obstacle_that_parks_on_the_route_before_the_assembly_gets_there_blocks_it():
    result = passage(track((50.0, -40.0), (0.0, 1.0), 4.6, 4.99), time_limit_s=60.0)
    assert result.arrival_s == np.inf


@pytest.mark.parametrize("side, blocked", [(-1.0, True), (1.0, False)])
def test_the_assembly_is_posed_with_the_route_heading(side, blocked):
    """A route along +y, an assembly whose one sphere sits 5 um to the route's left
    (route frame +y, which is -x here): an obstacle parked 5 um left of the route
    blocks it, one parked 5 um right of it does not."""
    shape = AssemblyShape(np.array([[0.0, 5.0]]), np.array([1.0]))
    parked = track((side * 5.0, 50.0), (1.0, 0.0), 1e3, 1e3 + 1.0)
    result = passage(parked, route=straight_route((0.0, 1.0)), shape=shape, time_limit_s=60.0)
    assert (result.arrival_s == np.inf) == blocked


def test_bad_grids_are_refused():
    with pytest.raises(ValueError, match="positive"):
        passage(track((50.0, 30.0), (0.0, 1.0), 0.0, 1.0), time_limit_s=-1.0)
    with pytest.raises(ValueError, match="positive"):
        passage(track((50.0, 30.0), (0.0, 1.0), 0.0, 1.0), speed_um_s=0.0)


@pytest.mark.slow
def test_the_tasks_assembly_is_taken_whole_and_across_the_route():
    """The task's gripped assembly in the route frame: the cell at the origin, one robot
    on each side of the route (their spheres more across than along it: the formation
    straddles the route, as the task grips, each robot's handles in a line along it),
    and its reach the scene's assembly radius. Fails if a body is left out or the frame
    is turned the wrong way."""
    from otgym.autonomy.route_timing import task_assembly_shape
    from tests.task import shared_task

    task = shared_task()
    shape = task_assembly_shape(task)
    cell = np.argmax(shape.radii_um)
    np.testing.assert_allclose(shape.offsets_um[cell], 0.0, atol=1e-4)
    robots = np.delete(shape.offsets_um, cell, axis=0)
    assert len(robots) == len(shape.radii_um) - 1 > 0
    assert np.all(np.abs(robots[:, 1]) > np.abs(robots[:, 0]))
    assert (robots[:, 1] > 0).sum() == (robots[:, 1] < 0).sum()
    handles = shape.offsets_um[shape.radii_um == 1.25]  # each robot's two handles lie along the route
    for side in (handles[handles[:, 1] > 0], handles[handles[:, 1] < 0]):
        assert len(side) == 2 and abs(side[0, 1] - side[1, 1]) < 0.1  # 0.8 um apart if turned the wrong way
    reach_um = np.max(np.linalg.norm(shape.offsets_um, axis=1) + shape.radii_um)
    assert reach_um == pytest.approx(task.scene.assembly_radius_um, abs=0.5)
