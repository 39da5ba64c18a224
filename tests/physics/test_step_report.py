"""The step's report describes the state it returns (the integrator carries each body's
cos and sin of its angle through its loop, so a stale pair would show here)."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from otgym import physics as ph
from tests.physics.helpers import step

SPIN_TORQUE_PN_UM = 40.0


@pytest.mark.slow
@pytest.mark.parametrize("cap", [None, 0.02])
def test_reported_trap_distances_are_those_of_the_returned_pose(cap):
    """Two robots beside each other spun by an external torque (with and without the
    overlap projection): the handle-to-trap distances in the report equal those
    computed from the returned pose. The robots turn by more than 0.02 rad in the
    control step, so an angle one substep stale (over 2e-4 rad, the handles 3.5 um
    from the centre) would be off by about 7e-4 um, against the 2e-5 um allowed (float32
    positions of a few um)."""
    bodies = [ph.two_handle_robot("a"), ph.two_handle_robot("b")]
    config = ph.PhysicsConfig(dt_s=1e-4, substeps=100, temperature_k=0.0, contact_overlap_cap=cap)
    model = ph.build_model(bodies, config)
    state = ph.initial_state(model, np.array([[0.0, -3.0, 0.0], [0.0, 3.0, 0.0]]))
    torque = jnp.zeros((2, 3)).at[:, 2].set(SPIN_TORQUE_PN_UM)
    new_state, report = step(
        model, state, ph.Controls.zeros(model).replace(external_force=torque), jax.random.PRNGKey(0)
    )
    turned = np.abs(np.asarray(new_state.pose)[:, 2] - np.asarray(state.pose)[:, 2])
    assert np.all(turned > 0.02)
    handles = np.asarray(ph.sphere_positions_um(model, new_state.pose))[np.asarray(model.trap_sphere)]
    distance = np.linalg.norm(np.asarray(new_state.trap_xy_um) - handles, axis=-1)
    np.testing.assert_allclose(np.asarray(report.trap_distance_um), distance, atol=2e-5)
