"""JAX samplers: agree with scipy's linear interpolation, jit/vmap, never NaN."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.interpolate import RegularGridInterpolator

from otgym.sim.fields import fields_from

pytestmark = pytest.mark.slow  # module fixtures that compile or solve for seconds


def _interpolator(grid, origin, spacing):
    rows, cols = grid.shape[:2]
    return RegularGridInterpolator((origin + spacing * np.arange(rows), origin + spacing * np.arange(cols)), grid)


def test_samplers_agree_with_scipy(default_chip, default_fields):
    flow, walls = fields_from(default_fields, default_chip.fluid)
    dx = default_chip.pixel_size_um
    rng = np.random.default_rng(1)
    xy = rng.uniform([dx, dx], np.array(default_chip.size_um) - dx, (5000, 2))
    yx = xy[:, ::-1]
    velocity = _interpolator(np.asarray(flow.velocity, float), 0.0, dx)(yx)
    vorticity = _interpolator(np.asarray(flow.vorticity, float), 0.0, dx)(yx)
    distance = _interpolator(np.asarray(walls.distance, float), 0.5 * dx, dx)(yx)
    xy32 = jnp.asarray(xy, jnp.float32)
    assert np.allclose(flow.velocity_um_s(xy32), velocity, atol=1e-4 * np.abs(velocity).max())
    assert np.allclose(flow.vorticity_per_s(xy32), vorticity, atol=1e-4 * np.abs(vorticity).max())
    sampled_distance, normal = walls.distance_and_normal(xy32)
    assert np.allclose(sampled_distance, distance, atol=1e-4)
    assert np.allclose(np.linalg.norm(normal, axis=-1), 1.0, atol=1e-5)


def test_outside_the_image_is_solid_and_finite(default_chip, default_fields):
    flow, walls = fields_from(default_fields, default_chip.fluid)
    width, height = default_chip.size_um
    far = jnp.array(
        [
            [-1e6, 50.0],
            [width + 0.01, 40.0],
            [150.0, -0.3],
            [150.0, 1e9],
            [jnp.inf, 0.0],
            [-0.01, 40.0],
            [width / 2, height + 3.0],
        ],
        jnp.float32,
    )
    distance, normal = jax.jit(walls.distance_and_normal)(far)
    assert np.all(np.asarray(distance[:4]) < 0) and np.all(np.asarray(distance[5:]) < 0)
    assert np.all(np.isfinite(np.asarray(normal)))
    assert np.all(np.asarray(flow.velocity_um_s(far)) == 0.0)
    assert np.all(np.asarray(flow.vorticity_per_s(far)) == 0.0)


def test_jit_vmap_and_batch_shapes(default_chip, default_fields):
    flow, walls = fields_from(default_fields, default_chip.fluid)
    xy = jnp.asarray(np.random.default_rng(2).uniform(-20, 320, (8, 16, 2)), jnp.float32)

    @jax.jit
    def sample(flow, walls, points):
        distance, normal = jax.vmap(walls.distance_and_normal)(points)
        return jax.vmap(flow.velocity_um_s)(points), jax.vmap(flow.vorticity_per_s)(points), distance, normal

    velocity, vorticity, distance, normal = sample(flow, walls, xy)
    assert velocity.shape == (8, 16, 2) and vorticity.shape == (8, 16) and distance.shape == (8, 16)
    assert velocity.dtype == jnp.float32 and normal.dtype == jnp.float32
    for array in (velocity, vorticity, distance, normal):
        assert np.all(np.isfinite(np.asarray(array)))
    direct, _ = walls.distance_and_normal(xy.reshape(-1, 2))
    assert np.allclose(distance.reshape(-1), direct)


def test_distance_is_continuous_across_the_border(default_chip, default_fields):
    _, walls = fields_from(default_fields, default_chip.fluid)
    y = 40.0  # the top inlet: fluid reaches the border
    xy = jnp.array([[x, y] for x in np.linspace(-1.0, 1.0, 201)], jnp.float32)
    distance, _ = walls.distance_and_normal(xy)
    assert np.max(np.abs(np.diff(np.asarray(distance)))) <= 0.011


def test_plugs_into_the_physics_core(default_chip, default_fields):
    """A free 1 um bead on the centre line of the top inlet branch drifts with the
    sampled flow: over T = 2 s its mean x velocity must equal the local flow speed
    within 4 Brownian standard deviations, sqrt(2 D T) / T with D = kT / (6 pi eta a)
    (0.5 um/s); it stays in the fluid and nothing is NaN."""
    from otgym import physics as ph
    from otgym.physics.constants import ROOM_TEMPERATURE_K, WATER_VISCOSITY_PA_S, thermal_energy_pn_um

    flow, walls = fields_from(default_fields, default_chip.fluid)
    config = ph.PhysicsConfig(dt_s=1e-3, substeps=100)
    model = ph.build_model([ph.bead("bead", radius_um=1.0)], config, traps=[], flow=flow, walls=walls)
    state = ph.initial_state(model, [[20.0, 40.0, 0.0]])
    final, poses, _, _ = ph.rollout(model, state, ph.Controls.zeros(model), jax.random.PRNGKey(0), 20)
    duration = 20 * 100 * 1e-3
    diffusion = thermal_energy_pn_um(ROOM_TEMPERATURE_K) / (6 * np.pi * WATER_VISCOSITY_PA_S * 1.0)
    sigma_velocity = np.sqrt(2 * diffusion * duration) / duration
    expected = float(flow.velocity_um_s(jnp.array([20.0, 40.0]))[0])
    assert expected > 5.0
    measured = (float(final.pose[0, 0]) - 20.0) / duration
    assert abs(measured - expected) <= 4 * sigma_velocity
    distance, _ = walls.distance_and_normal(jnp.asarray(poses[:, 0, :2]))
    assert np.all(np.isfinite(np.asarray(poses))) and np.all(np.asarray(distance) > 1.0)
