"""The model-predictive navigator's route frame (``otgym.autonomy.route_frame``)."""

import jax.numpy as jnp
import numpy as np

from otgym.autonomy import route_frame as rf

OFFSETS_UM = np.array([[-3.5, -6.5], [3.5, -6.5], [3.5, 6.5], [-3.5, 6.5]])


def _arc_route(radius_um=60.0, points=400):
    """A quarter circle: heading turns with the arc, so frame errors show."""
    angle = np.linspace(0.0, np.pi / 2, points)
    route = np.stack([radius_um * np.sin(angle), radius_um * (1 - np.cos(angle))], axis=-1)
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(route, axis=0), axis=1))])
    return route, arc


def _straight_channel_distance(half_width_um):
    """Wall distance of a straight channel along x, |y| < half width."""
    return lambda points: half_width_um - np.abs(np.asarray(points)[:, 1])


def test_pose_fit_inverts_the_formation_places():
    route, arc = _arc_route()
    data = rf.route_data(route, arc, lambda p: np.full(len(p), 100.0), clearance_um=5.0)
    rng = np.random.default_rng(0)
    s = jnp.asarray(rng.uniform(10, 80, 16), jnp.float32)
    lateral = jnp.asarray(rng.uniform(-5, 5, 16), jnp.float32)
    rotation = jnp.asarray(rng.uniform(-0.4, 0.4, 16), jnp.float32)
    places = rf.formation_places(data, OFFSETS_UM, s, lateral, rotation)
    fitted = rf.formation_pose(data, OFFSETS_UM, places, s + 1.5)  # the guess 1.5 um off
    # two projections leave (1.5 um x (5 um / 60 um)) x (5 / 60) = 0.01 um of arc error
    np.testing.assert_allclose(np.asarray(fitted[0]), np.asarray(s), atol=0.02)
    np.testing.assert_allclose(np.asarray(fitted[1]), np.asarray(lateral), atol=0.02)
    np.testing.assert_allclose(np.asarray(fitted[2]), np.asarray(rotation), atol=2e-3)


def test_left_normal_is_left_of_the_heading():
    route = np.stack([np.linspace(0, 50, 101), np.zeros(101)], axis=-1)
    arc = route[:, 0].copy()
    data = rf.route_data(route, arc, _straight_channel_distance(12.5), clearance_um=9.0)
    places = rf.formation_places(data, np.zeros((1, 2)), jnp.array([20.0]), jnp.array([2.0]), jnp.array([0.0]))
    np.testing.assert_allclose(np.asarray(places)[0, 0], [20.0, 2.0], atol=1e-5)  # (-sin 0, cos 0) = +y


def test_room_in_a_straight_channel_is_its_half_width_less_the_clearance():
    route = np.stack([np.linspace(0, 50, 101), np.full(101, 1.0)], axis=-1)  # 1 um off the centre line
    arc = route[:, 0].copy()
    grid, left, right = rf.lateral_room_um(
        route, arc, _straight_channel_distance(12.5), clearance_um=9.0, resolution_um=0.25
    )
    # towards +y the wall is 12.5 - 1 = 11.5 um away: room 2.5; towards -y 13.5: room 4.5 (on a 0.25 um grid)
    assert np.all(np.abs(left - 2.5) <= 0.25) and np.all(np.abs(right - 4.5) <= 0.25)
    clipped = rf.clip_lateral(
        rf.route_data(route, arc, _straight_channel_distance(12.5), 9.0),
        jnp.array([25.0, 25.0]),
        jnp.array([10.0, -10.0]),
    )
    assert np.asarray(clipped)[0] <= 2.5 and np.asarray(clipped)[1] >= -4.5


def test_cell_arc_is_its_projection_on_the_route():
    route = np.stack([np.linspace(0, 50, 101), np.zeros(101)], axis=-1)
    data = rf.route_data(route, route[:, 0].copy(), lambda p: np.full(len(p), 100.0), clearance_um=5.0)
    arc = rf.cell_arc_um(data, jnp.array([[31.0, 4.0]]), jnp.array([29.0]))
    np.testing.assert_allclose(np.asarray(arc), [31.0], atol=1e-4)
