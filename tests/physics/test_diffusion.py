"""Free Brownian motion: the noise must match the mobility (fluctuation-dissipation).

Each test measures displacement variances over one control step in many independent
environments. With n independent Gaussian increments per axis the relative standard
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
    """Sphere-sum drag computed here from first principles (Stokes, Faxen)."""
    a = body.radii_um
    gamma = 6 * np.pi * ETA * a
    gamma_rot = 8 * np.pi * ETA * a**3
    if height is not None:
        x = a / height
        gamma = gamma / (1 - 9 / 16 * x + x**3 / 8 - 45 / 256 * x**4 - x**5 / 16)
        gamma_rot = gamma_rot / (1 - x**3 / 8)
    centre = (gamma[:, None] * body.offsets_um).sum(0) / gamma.sum()
    lever2 = np.sum((body.offsets_um - centre) ** 2, axis=1)
    return gamma.sum(), np.sum(gamma_rot + gamma * lever2)


def measured_variances(body, config):
    model = ph.build_model([body], config, traps=[])
    state = batch_state(model, np.zeros((1, 3)), N_ENV)
    controls = ph.Controls.zeros(model, N_ENV)
    _, (states, _) = run_batch(model, state, controls, jax.random.PRNGKey(7), N_STEPS)
    poses = np.concatenate([np.zeros((1, N_ENV, 1, 3)), np.asarray(states.pose, float)])
    steps = np.diff(poses[:, :, 0, :], axis=0)
    return steps.reshape(-1, 3).var(axis=0), config.control_period_s


@pytest.mark.parametrize("body, height", [
    (ph.bead(radius_um=0.5), None),
    (ph.two_handle_robot(), None),
    (ph.four_arm_robot(), 4.0),  # near the chip floor: Faxen-corrected
])
def test_translational_and_rotational_diffusion_match_mobility(body, height):
    config = ph.PhysicsConfig(dt_s=2e-4, substeps=5, height_above_floor_um=height)
    variances, duration = measured_variances(body, config)
    gamma_t, gamma_r = independent_drag(body, height)
    kt = 1.380649e-5 * 298.15
    d_t = variances[:2].mean() / (2 * duration)
    d_r = variances[2] / (2 * duration)
    assert d_t == pytest.approx(kt / gamma_t, rel=0.03)
    assert d_r == pytest.approx(kt / gamma_r, rel=0.03)
