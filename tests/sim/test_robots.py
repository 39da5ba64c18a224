"""A scene's robot is a registered ``RobotSpec`` (``otgym.physics.robots``): the
navigation scene takes any design, its traps on the design's handles; the transport
scene refuses a design that cannot grip; a design registered at run time is one
``register`` call."""

import numpy as np
import pytest

from otgym import physics as ph
from otgym import registry
from otgym.physics.robots import RobotSpec
from otgym.sim import scene as sc


def _navigation(robot: str) -> sc.Scene:
    return sc.build_scene(sc.SceneConfig(kind="navigation", robot=robot, n_obstacles=0))


@pytest.mark.slow
@pytest.mark.parametrize("robot, handles", [("two-handle", 2), ("four-arm", 4)])
def test_the_navigation_scene_traps_every_handle_of_the_design(robot, handles):
    scene = _navigation(robot)
    assert len(scene.model.trap_sphere) == handles
    state = sc.reset_at(scene, np.zeros(2, np.uint32), np.array([150.0, 100.0]), 0.0)
    handle_xy = np.asarray(ph.sphere_positions_um(scene.model, state.physics.pose))[list(scene.model.trap_sphere)]
    np.testing.assert_allclose(np.asarray(state.physics.trap_xy_um), handle_xy, atol=1e-5)


def test_transport_refuses_a_design_without_a_grip_and_an_unknown_name_is_an_error():
    with pytest.raises(ValueError, match="cannot carry a cell"):
        sc.build_scene(sc.SceneConfig(robot="four-arm"))
    with pytest.raises(ValueError, match="unknown robot 'tripod'"):
        sc.SceneConfig(robot="tripod")


def _tripod(name):
    angles = np.deg2rad([90.0, 210.0, 330.0])
    offsets = [(0.0, 0.0)] + [(4 * np.cos(a), 4 * np.sin(a)) for a in angles]
    return ph.custom_body(name, offsets, [1.5, 1.0, 1.0, 1.0], handle_indices=(1, 2, 3))


TRIPOD = RobotSpec(_tripod)


@pytest.mark.slow
def test_a_design_registered_at_run_time_is_used_by_name():
    registry.register("robots", "tripod", f"{__name__}:TRIPOD", "three handles on a hub")
    try:
        assert len(_navigation("tripod").model.trap_sphere) == 3
    finally:
        registry.unregister("robots", "tripod")
