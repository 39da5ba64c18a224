"""Bad input is refused with a ValueError naming the parameter; hooks and kinematic
bodies behave as documented."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from otgym import physics as ph
from tests.physics.helpers import step


@pytest.mark.parametrize(
    "make, name",
    [
        (lambda: ph.custom_body("b", [[0, 0]], [-1.0]), "radii_um"),
        (lambda: ph.custom_body("b", [[0, 0]], [float("nan")]), "radii_um"),
        (lambda: ph.custom_body("b", [[0, 0], [1, 0]], [1.0]), "offsets_um"),
        (lambda: ph.custom_body("b", [[0, 0]], [1.0], handle_indices=(3,)), "handle_indices"),
        (lambda: ph.PhysicsConfig(viscosity_pa_s=-1.0), "viscosity_pa_s"),
        (lambda: ph.PhysicsConfig(viscosity_pa_s=float("nan")), "viscosity_pa_s"),
        (lambda: ph.PhysicsConfig(temperature_k=-5.0), "temperature_k"),
        (lambda: ph.PhysicsConfig(temperature_k=float("nan")), "temperature_k"),
        (lambda: ph.PhysicsConfig(dt_s=0.0), "dt_s"),
        (lambda: ph.PhysicsConfig(substeps=0), "substeps"),
        (lambda: ph.TrapLaw("gaussian", stiffness_pn_per_um=-2.0), "stiffness_pn_per_um"),
        (lambda: ph.build_model([ph.two_handle_robot()], ph.PhysicsConfig(dt_s=1e-2)), "dt_s"),
        (lambda: ph.build_model([ph.bead("a"), ph.bead("a")]), "unique"),
        (lambda: ph.build_model([ph.bead()], traps=[(0, 1)]), "traps"),
        (lambda: ph.build_model([ph.bead()], traps=[(2, 0)]), "traps"),
        (lambda: ph.initial_state(ph.build_model([ph.bead()]), np.zeros((2, 3))), "pose"),
        (lambda: ph.initial_state(ph.build_model([ph.bead()]), [[0, 0, float("nan")]]), "pose"),
        (lambda: ph.initial_state(ph.build_model([ph.bead()]), [[0, 0, 0]], np.zeros((3, 2))), "trap_xy_um"),
    ],
)
def test_bad_input_raises_value_error_naming_the_parameter(make, name):
    with pytest.raises(ValueError, match=name):
        make()


def test_mismatched_control_shapes_are_refused():
    model = ph.build_model([ph.bead()])
    state = ph.initial_state(model, [[0, 0, 0]])
    controls = ph.Controls.zeros(model).replace(trap_velocity_um_s=jnp.zeros((2, 2)))
    with pytest.raises(ValueError, match="trap_velocity_um_s"):
        ph.control_step(model, state, controls, jax.random.PRNGKey(0))


def test_max_stable_dt_is_the_documented_limit():
    bodies = [ph.two_handle_robot()]
    limit = ph.max_stable_dt_s(bodies, ph.PhysicsConfig())
    ph.build_model(bodies, ph.PhysicsConfig(dt_s=0.99 * limit))
    with pytest.raises(ValueError, match="dt_s"):
        ph.build_model(bodies, ph.PhysicsConfig(dt_s=1.01 * limit))


def test_uniform_flow_advects_a_free_bead_and_kinematic_bodies_follow_their_velocity():
    """At T = 0 a free bead moves with the fluid; an obstacle ignores the flow and
    moves at its prescribed velocity."""
    flow = ph.UniformFlow(jnp.array([3.0, -1.0]))
    config = ph.PhysicsConfig(dt_s=1e-3, substeps=100, temperature_k=0.0)
    model = ph.build_model([ph.bead(radius_um=1.0), ph.obstacle(radius_um=1.0)], config, traps=[], flow=flow)
    state = ph.initial_state(model, [[0, 0, 0], [50, 0, 0]])
    controls = ph.Controls.zeros(model).replace(body_velocity=jnp.array([[9, 9, 9], [0, 2.0, 0.5]]))
    state, _ = step(model, state, controls, jax.random.PRNGKey(0))
    pose = np.asarray(state.pose)
    assert pose[0] == pytest.approx([0.3, -0.1, 0.0], abs=1e-5)
    assert pose[1] == pytest.approx([50.0, 0.2, 0.05], abs=1e-5)


@pytest.mark.slow
def test_simulation_runs_in_float64_when_enabled():
    with jax.enable_x64(True):
        model = ph.build_model([ph.two_handle_robot()], ph.PhysicsConfig(dtype="float64", substeps=4))
        state = ph.initial_state(model, [[1.0, 2.0, 0.3]])
        state, report = step(model, state, ph.Controls.zeros(model), jax.random.PRNGKey(0))  # one compile, not op by op
        assert state.pose.dtype == jnp.float64
        assert np.all(np.isfinite(np.asarray(state.pose)))


@pytest.mark.slow
def test_vmap_of_control_step_runs_the_batched_kernel_with_the_same_physics():
    """vmap over states and keys goes through control_step_batch (custom batching rule):
    at T = 0 it must give exactly the deterministic motion of separate calls, and with
    noise each environment still gets its own noise."""
    config = ph.PhysicsConfig(dt_s=1e-4, substeps=20, temperature_k=0.0)
    model = ph.build_model([ph.two_handle_robot(), ph.cell()], config)
    poses = np.array([[[0, 0, 0], [0, 8, 0]], [[1, 2, 0.3], [1, 10, 0]], [[5, 5, 1.0], [5, 14, 0]]], float)
    states = jax.tree.map(lambda *a: jnp.stack(a), *[ph.initial_state(model, p) for p in poses])
    controls = ph.Controls.zeros(model).replace(trap_velocity_um_s=jnp.ones((2, 2)) * 50.0)
    keys = jax.random.split(jax.random.PRNGKey(0), 3)
    vmapped = jax.jit(jax.vmap(ph.control_step, in_axes=(None, 0, None, 0)))
    batched, _ = vmapped(model, states, controls, keys)
    for index in range(3):
        single, _ = step(model, jax.tree.map(lambda a: a[index], states), controls, keys[index])
        assert np.allclose(np.asarray(batched.pose[index]), np.asarray(single.pose), atol=1e-5)
    noisy = ph.build_model([ph.two_handle_robot(), ph.cell()], ph.PhysicsConfig(dt_s=1e-4, substeps=20))
    same = jax.tree.map(lambda a: jnp.stack([a[0]] * 3), states)
    moved, _ = vmapped(noisy, same, controls, keys)  # the same program: only the noise's scale differs
    assert len({float(moved.pose[i, 0, 0]) for i in range(3)}) == 3
