"""Mobility of multi-sphere bodies: hydrodynamic centre, decoupling, flow weights, near-wall corrections."""

import numpy as np
import pytest

from otgym.physics import hydrodynamics as hy
from otgym.physics import mobility
from otgym.physics.bodies import four_arm_robot, two_handle_robot

ETA = 8.9e-4


def resistance_matrix(offsets, radii, eta, origin):
    """Planar 3x3 resistance about ``origin`` built sphere by sphere (independent of the
    module's closed forms): force and torque of each sphere moving rigidly."""
    matrix = np.zeros((3, 3))
    for r, a in zip(offsets - origin, radii):
        g = 6 * np.pi * eta * a
        perp = np.array([-r[1], r[0]])
        matrix[:2, :2] += g * np.eye(2)
        matrix[:2, 2] += g * perp
        matrix[2, :2] += g * perp
        matrix[2, 2] += g * perp @ perp + 8 * np.pi * eta * a**3
    return matrix


@pytest.mark.parametrize("design", [two_handle_robot(), four_arm_robot()])
def test_free_draining_centre_decouples_translation_and_rotation(design):
    hydro = mobility.body_hydrodynamics(design.offsets_um, design.radii_um, ETA, interaction=False)
    matrix = resistance_matrix(design.offsets_um, design.radii_um, ETA, hydro.centre_um)
    assert np.allclose(matrix[:2, 2], 0, atol=1e-12)
    np.testing.assert_allclose(hydro.translational_resistance_pn_s_per_um, matrix[:2, :2], rtol=1e-12)
    assert matrix[2, 2] == pytest.approx(hydro.rotational_resistance_pn_s_um, rel=1e-12)


def test_asymmetric_cluster_free_draining_centre_is_drag_weighted():
    offsets = np.array([[0.0, 0.0], [3.0, 0.0]])
    radii = np.array([1.0, 2.0])
    hydro = mobility.body_hydrodynamics(offsets, radii, ETA, interaction=False)
    assert hydro.centre_um == pytest.approx([2.0, 0.0])
    matrix = resistance_matrix(offsets, radii, ETA, np.zeros(2))
    assert abs(matrix[1, 2]) > 1e-3  # about the first sphere the coupling is real


ASYMMETRIC = (np.array([[0.0, 0.0], [2.2, 0.4], [3.5, 2.0], [1.0, -1.6]]), np.array([1.0, 0.7, 1.2, 0.5]))


@pytest.mark.parametrize(
    "offsets, radii, asymmetric",
    [
        (two_handle_robot().offsets_um, two_handle_robot().radii_um, True),
        (four_arm_robot().offsets_um, four_arm_robot().radii_um, False),  # centres coincide by symmetry
        (*ASYMMETRIC, True),
    ],
)
def test_hydrodynamic_centre_decouples_the_interacting_resistance(offsets, radii, asymmetric):
    """About the returned centre the RPY resistance (``resistance_matrix``, validated in
    test_hydrodynamics) has no translation-rotation coupling, while about the
    free-draining centre of an asymmetric body (for the robot 0.10 um away) it has."""
    hydro = mobility.body_hydrodynamics(offsets, radii, ETA)
    about_centre = hy.resistance_matrix(offsets - hydro.centre_um, radii, ETA)
    assert np.abs(about_centre[:2, 2]).max() < 1e-9 * about_centre[2, 2]
    np.testing.assert_allclose(hydro.translational_resistance_pn_s_per_um, about_centre[:2, :2], rtol=1e-12)
    assert hydro.rotational_resistance_pn_s_um == pytest.approx(about_centre[2, 2], rel=1e-12)
    free_centre = mobility.body_hydrodynamics(offsets, radii, ETA, interaction=False).centre_um
    about_free_centre = hy.resistance_matrix(offsets - free_centre, radii, ETA)
    assert (np.abs(about_free_centre[:2, 2]).max() > 1e-4 * about_free_centre[2, 2]) == asymmetric


@pytest.mark.parametrize("interaction", [True, False])
def test_flow_weights_give_the_resistance_for_uniform_and_rigidly_rotating_flow(interaction):
    """A flow that moves like a rigid body exerts on the body held still the force the
    body would feel moving the opposite way through still fluid: a uniform flow U gives
    R [U, 0], a rigid rotation u = w x r (vorticity 2w, spheres spinning at w) gives
    R [0, w]. Both through the weights, summed sphere by sphere."""
    offsets, radii = ASYMMETRIC
    hydro = mobility.body_hydrodynamics(offsets, radii, ETA, interaction=interaction)
    lever = offsets - hydro.centre_um
    uniform = np.tile([0.7, -0.3, 0.0], (len(radii), 1))
    force = np.einsum("sij,sj->i", hydro.flow_weights, uniform)
    np.testing.assert_allclose(force[:2], hydro.translational_resistance_pn_s_per_um @ [0.7, -0.3], rtol=1e-10)
    assert abs(force[2]) < 1e-10 * np.abs(force[:2]).max()
    omega = 0.4
    rotating = np.column_stack([-omega * lever[:, 1], omega * lever[:, 0], np.full(len(radii), omega)])
    force = np.einsum("sij,sj->i", hydro.flow_weights, rotating)
    assert np.abs(force[:2]).max() < 1e-9 * abs(force[2])
    assert force[2] == pytest.approx(hydro.rotational_resistance_pn_s_um * omega, rel=1e-10)


def test_point_mobility_is_the_largest_over_sphere_centres():
    """A force F through sphere i moves that centre by (A^-1 + (J l)(J l)^T / r) F: the
    reported bound is the largest eigenvalue over the spheres, checked by brute force
    over force directions."""
    offsets, radii = ASYMMETRIC
    hydro = mobility.body_hydrodynamics(offsets, radii, ETA)
    lever = offsets - hydro.centre_um
    best = 0.0
    for angle in np.linspace(0, np.pi, 721):
        force = np.array([np.cos(angle), np.sin(angle)])
        for arm in lever:
            spin = (arm[0] * force[1] - arm[1] * force[0]) / hydro.rotational_resistance_pn_s_um
            velocity = hydro.translational_mobility_um_per_pn_s @ force + spin * np.array([-arm[1], arm[0]])
            best = max(best, velocity @ force)
    assert hydro.max_point_mobility_um_per_pn_s == pytest.approx(best, rel=1e-5)


def test_floor_height_needs_the_free_draining_model():
    robot = two_handle_robot()
    with pytest.raises(ValueError, match="free-draining"):
        mobility.body_hydrodynamics(robot.offsets_um, robot.radii_um, ETA, height_above_floor_um=4.0)


def test_faxen_factor_limits_and_known_value():
    assert mobility.faxen_parallel_factor(1.0, 1e6) == pytest.approx(1.0, abs=1e-6)
    # a/h = 1/2: 1 / (1 - 0.28125 + 0.015625 - 0.010986 - 0.001953) = 1 / 0.721436
    assert mobility.faxen_parallel_factor(1.0, 2.0) == pytest.approx(1.386125, rel=1e-5)
    heights = np.linspace(1.1, 20, 50)
    assert np.all(np.diff(mobility.faxen_parallel_factor(1.0, heights)) < 0)
    assert mobility.wall_normal_rotation_factor(1.0, 2.0) == pytest.approx(1 / (1 - 1 / 64))


def test_sphere_below_its_radius_is_rejected():
    with pytest.raises(ValueError, match="height_above_floor_um"):
        mobility.sphere_drag([1.0, 2.0], ETA, height_above_floor_um=1.5)
