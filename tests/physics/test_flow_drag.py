"""A rigid body in a flow and under a force, through the multiblob weights and the
anisotropic mobility (issue 10): motions whose answer is known exactly at T = 0.

* A flow that moves like a rigid body carries any free body along with it: the
  uniform flow translates it, a rigid rotation about a point turns it about that
  point at the flow's angular velocity (half its vorticity). This holds for any shape
  with or without hydrodynamic interaction, so it checks that the weights, the
  vorticity term and the body-frame rotations fit together.
* A force on a turned elongated body moves it with R A^-1 R^T F: at an angle the
  velocity leaves the force's direction, with a sign fixed by the turn.
Tolerances: float32 positions of order 10 um carry 1e-6 um of rounding per step;
explicit Euler of the rotation over 100 steps of 1e-4 rad errs by O((w t)^2) = 1e-4
of the displacement.
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from flax import struct

from otgym import physics as ph
from tests.physics.helpers import step


@struct.dataclass
class RigidRotation:
    """u(x) = w e_z x (x - centre): vorticity 2 w everywhere."""

    centre: jnp.ndarray
    angular_velocity_per_s: float

    def velocity_um_s(self, xy_um):
        rel = xy_um - self.centre.astype(xy_um.dtype)
        return self.angular_velocity_per_s * jnp.stack([-rel[..., 1], rel[..., 0]], axis=-1)

    def vorticity_per_s(self, xy_um):
        return jnp.full(xy_um.shape[:-1], 2 * self.angular_velocity_per_s, xy_um.dtype)


CONFIG = ph.PhysicsConfig(dt_s=1e-3, substeps=100, temperature_k=0.0, adhesion=ph.Adhesion.none())


@pytest.mark.parametrize(
    "body",
    [
        ph.two_handle_robot(),
        ph.custom_body("lopsided", [[0.0, 0.0], [2.2, 0.4], [3.5, 2.0], [1.0, -1.6]], [1.0, 0.7, 1.2, 0.5]),
    ],
)
def test_a_free_body_rides_a_rigidly_rotating_flow(body):
    omega = 0.2  # rad/s: 0.02 rad over the 0.1 s step
    centre = np.array([3.0, -4.0])
    model = ph.build_model([body], CONFIG, traps=[], flow=RigidRotation(jnp.asarray(centre, jnp.float32), omega))
    start = np.array([10.0, 5.0, 0.7])
    state, _ = step(model, ph.initial_state(model, [start]), ph.Controls.zeros(model), jax.random.PRNGKey(0))
    turn = omega * CONFIG.control_period_s
    rotation = np.array([[np.cos(turn), -np.sin(turn)], [np.sin(turn), np.cos(turn)]])
    expected_xy = centre + rotation @ (start[:2] - centre)
    pose = np.asarray(state.pose)[0]
    moved = np.linalg.norm(expected_xy - start[:2])  # 0.26 um
    assert np.linalg.norm(pose[:2] - expected_xy) < 2e-3 * moved
    assert pose[2] - start[2] == pytest.approx(turn, rel=2e-3)


def test_a_free_turned_robot_moves_with_a_uniform_flow_without_turning():
    model = ph.build_model([ph.two_handle_robot()], CONFIG, traps=[], flow=ph.UniformFlow(jnp.array([3.0, -1.0])))
    state, _ = step(model, ph.initial_state(model, [[0.0, 0.0, 0.9]]), ph.Controls.zeros(model), jax.random.PRNGKey(0))
    assert np.asarray(state.pose)[0] == pytest.approx([0.3, -0.1, 0.9], abs=1e-5)


def test_a_force_on_a_turned_robot_moves_it_with_the_rotated_mobility():
    """The robot drags 14 % more across its bar than along it; pushed along lab x while
    turned by 45 degrees it also drifts in y, by -(m_along - m_across)/2 per unit force,
    the sign set by the turn."""
    robot = ph.two_handle_robot()
    model = ph.build_model([robot], CONFIG, traps=[])
    hydro = ph.mobility.body_hydrodynamics(robot.offsets_um, robot.radii_um, CONFIG.viscosity_pa_s)
    mobility = hydro.translational_mobility_um_per_pn_s
    force = np.array([0.5, 0.0])
    controls = ph.Controls.zeros(model).replace(external_force=jnp.array([[force[0], force[1], 0.0]]))
    for theta in (np.pi / 4, -np.pi / 4):
        state, _ = step(model, ph.initial_state(model, [[0.0, 0.0, theta]]), controls, jax.random.PRNGKey(0))
        rotation = np.array([[np.cos(theta), -np.sin(theta)], [np.sin(theta), np.cos(theta)]])
        expected = rotation @ mobility @ rotation.T @ force * CONFIG.control_period_s
        moved = np.asarray(state.pose)[0]
        np.testing.assert_allclose(moved[:2], expected, rtol=1e-4, atol=1e-6)
        assert abs(moved[1]) > 0.05 * abs(moved[0])  # the anisotropy is visible
        assert moved[2] == pytest.approx(theta, abs=1e-6)  # no torque about the hydrodynamic centre
