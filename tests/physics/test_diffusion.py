"""Free Brownian motion: the noise must match the mobility (fluctuation-dissipation).

Each test measures displacement variances over one control step in many independent
environments, along and across the body (its translational mobility is anisotropic). With n independent Gaussian increments per axis the relative standard
error of a variance estimate is sqrt(2/n); the sample sizes below make the 3 %
tolerance at least 4.5 standard errors wide.
"""

import jax
import numpy as np
import pytest

from otgym import physics as ph
from tests.physics.helpers import batch_state, run_batch

ETA = 8.9e-4
N_ENV, N_STEPS = 256, 200  # 51,200 increments per axis: sqrt(2/51200) = 0.63 %


def independent_drag(body, height=None):
    """Free-draining sphere-sum drag computed here from first principles (Stokes,
    Faxen): (x, y) translational and rotational drag."""
    a = body.radii_um
    gamma = 6 * np.pi * ETA * a
    gamma_rot = 8 * np.pi * ETA * a**3
    if height is not None:
        x = a / height
        gamma = gamma / (1 - 9 / 16 * x + x**3 / 8 - 45 / 256 * x**4 - x**5 / 16)
        gamma_rot = gamma_rot / (1 - x**3 / 8)
    centre = (gamma[:, None] * body.offsets_um).sum(0) / gamma.sum()
    lever2 = np.sum((body.offsets_um - centre) ** 2, axis=1)
    return np.array([gamma.sum(), gamma.sum()]), np.sum(gamma_rot + gamma * lever2)


def interacting_drag(body):
    """RPY rigid-multiblob drag (``resistance_matrix``, validated against classical
    results in test_hydrodynamics) about the hydrodynamic centre: the body-frame
    translational mobility's inverse diagonal and the rotational drag. For the robot
    the x and y drags differ by 14 %, far outside the tolerance."""
    centre = ph.mobility.body_hydrodynamics(body.offsets_um, body.radii_um, ETA).centre_um
    resistance = ph.resistance_matrix(body.offsets_um - centre, body.radii_um, ETA)
    mobility = np.linalg.inv(resistance)
    return 1 / np.diag(mobility)[:2], 1 / mobility[2, 2]


def measured_variances(body, config, theta=0.0):
    model = ph.build_model([body], config, traps=[])
    state = batch_state(model, np.array([[0.0, 0.0, theta]]), N_ENV)
    controls = ph.Controls.zeros(model, N_ENV)
    _, (states, _) = run_batch(model, state, controls, jax.random.PRNGKey(7), N_STEPS)
    poses = np.concatenate([np.full((1, N_ENV, 1, 3), [0.0, 0.0, theta]), np.asarray(states.pose, float)])
    steps = np.diff(poses[:, :, 0, :], axis=0)
    # into the body frame (the body turns by a few mrad per step)
    angle = poses[:-1, :, 0, 2]
    along = np.cos(angle) * steps[..., 0] + np.sin(angle) * steps[..., 1]
    across = -np.sin(angle) * steps[..., 0] + np.cos(angle) * steps[..., 1]
    return np.array([along.var(), across.var(), steps[..., 2].var()]), config.control_period_s


@pytest.mark.slow
@pytest.mark.parametrize(
    "body, height, theta",
    [
        (ph.bead(radius_um=0.5), None, 0.0),
        (ph.two_handle_robot(), None, 0.0),
        (ph.two_handle_robot(), None, 1.1),  # turned: the anisotropy must turn with the body
        (ph.four_arm_robot(), 4.0, 0.0),  # near the chip floor: free-draining and Faxen-corrected
    ],
)
def test_translational_and_rotational_diffusion_match_mobility(body, height, theta):
    interaction = height is None
    config = ph.PhysicsConfig(dt_s=2e-4, substeps=5, height_above_floor_um=height, hydrodynamic_interaction=interaction)
    variances, duration = measured_variances(body, config, theta)
    gamma_t, gamma_r = interacting_drag(body) if interaction else independent_drag(body, height)
    kt = 1.380649e-5 * 298.15
    d_t = variances[:2] / (2 * duration)
    d_r = variances[2] / (2 * duration)
    np.testing.assert_allclose(d_t, kt / gamma_t, rtol=0.03)
    assert d_r == pytest.approx(kt / gamma_r, rel=0.03)
