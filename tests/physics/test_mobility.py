"""Mobility of multi-sphere bodies: drag centre, decoupling, near-wall corrections."""

import numpy as np
import pytest

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
def test_drag_centre_decouples_translation_and_rotation(design):
    drag = mobility.body_drag(design.offsets_um, design.radii_um, ETA)
    matrix = resistance_matrix(design.offsets_um, design.radii_um, ETA, drag.drag_centre_um)
    assert np.allclose(matrix[:2, 2], 0, atol=1e-12)
    assert matrix[0, 0] == pytest.approx(drag.translational_pn_s_per_um, rel=1e-12)
    assert matrix[2, 2] == pytest.approx(drag.rotational_pn_s_um, rel=1e-12)


def test_asymmetric_cluster_drag_centre_is_drag_weighted():
    offsets = np.array([[0.0, 0.0], [3.0, 0.0]])
    radii = np.array([1.0, 2.0])
    drag = mobility.body_drag(offsets, radii, ETA)
    assert drag.drag_centre_um == pytest.approx([2.0, 0.0])
    matrix = resistance_matrix(offsets, radii, ETA, np.zeros(2))
    assert abs(matrix[1, 2]) > 1e-3  # about the first sphere the coupling is real


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
