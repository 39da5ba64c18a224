"""The observation a node rebuilds from what a simulator publishes
(``otgym.task.layout.observation_from_spheres``) against the task's own."""

import jax
import numpy as np

from otgym import physics as ph
from otgym.autonomy.navigator import RouteNavigator
from otgym.task.layout import layout_of, observation_from_spheres
from tests.task import fast_scenario, shared_task


def test_rebuilt_observation_matches_the_tasks_own():
    """Half a second into a trial (the traps moved by the route navigator, obstacles on
    their tracks): cell, arc, handles, traps, obstacles, their gaps to the assembly and
    the handle-trap distances agree with the task's observation to float32 round-off.
    Fails if a body is taken from the wrong spheres or a gap from the wrong radii."""
    task = shared_task()
    state = task.reset([fast_scenario(7)], jax.random.PRNGKey(0))
    navigator = RouteNavigator(task.route_um, task.route_arc_um, task.offsets_um, task.config.tick_s)
    navigator.reset(1)
    obs = state.observation
    for tick in range(25):
        obs = task.step(state, navigator.increments(obs), jax.random.PRNGKey(tick))
    spheres = np.asarray(ph.sphere_positions_um(task.scene.model, state.scene.physics.pose[0]), float)
    rebuilt, route_index = observation_from_spheres(
        layout_of(task), spheres, obs.trap_xy_um[0], int(obs.phase[0]), float(obs.time_s[0]), 0
    )
    assert route_index == state.route_index[0]
    for name in (
        "time_s",
        "phase",
        "cell_xy_um",
        "cell_arc_um",
        "trap_xy_um",
        "handle_xy_um",
        "obstacle_xy_um",
        "obstacle_gap_um",
        "trap_distance_um",
    ):
        np.testing.assert_allclose(getattr(rebuilt, name), getattr(obs, name), atol=2e-4, err_msg=name)
    assert np.isnan(rebuilt.contact_force_pn).all()  # not published: never a made-up zero
