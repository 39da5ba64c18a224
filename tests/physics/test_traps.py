"""Trap force laws: the paper's piecewise law, the Gaussian beam, the harmonic spring."""

import math

import jax.numpy as jnp
import numpy as np
import pytest

from otgym.physics.traps import TrapLaw


def test_paper_law_matches_equation_3_within_its_capture_radius():
    law = TrapLaw.paper()
    r = np.array([0.1, 0.3, 0.446, 0.6, 0.85])
    expected = np.where(r < 0.446, 0.455 * r, 0.01 + 0.058 / r**2)
    assert np.allclose(np.asarray(law.magnitude_pn(r)), expected, rtol=1e-6)


def test_paper_law_lets_a_lost_handle_go():
    law = TrapLaw.paper()
    assert law.capture_radius == pytest.approx(law.escape_distance)
    beyond = np.array([law.escape_distance * 1.001, 2.0, 50.0])
    assert np.all(np.asarray(law.magnitude_pn(beyond)) == 0.0)
    assert np.all(np.asarray(law.force_pn(np.stack([beyond, beyond], axis=1))) == 0.0)
    wider = TrapLaw.paper(capture_radius_um=3.0)
    assert float(wider.magnitude_pn(2.0)) == pytest.approx(0.01 + 0.058 / 4.0, rel=1e-6)
    assert float(wider.magnitude_pn(3.01)) == 0.0


def test_capture_radius_is_validated():
    with pytest.raises(ValueError, match="capture_radius_um"):
        TrapLaw.paper(capture_radius_um=-1.0)
    with pytest.raises(ValueError, match="paper law only"):
        TrapLaw("gaussian", 10.0, 0.5, capture_radius_um=1.0)


@pytest.mark.parametrize(
    "law", [TrapLaw.paper(), TrapLaw("gaussian", 40.0, 0.7), TrapLaw("harmonic", 10.0, escape_distance_um=1.0)]
)
def test_force_points_to_trap_and_max_force_is_the_true_maximum(law):
    vectors = np.array([[0.3, -0.2], [-0.05, 0.01], [0.0, 0.0]])
    force = np.asarray(law.force_pn(vectors))
    assert np.allclose(force[2], 0.0)
    cosine = np.sum(force[:2] * vectors[:2], axis=1) / (
        np.linalg.norm(force[:2], axis=1) * np.linalg.norm(vectors[:2], axis=1)
    )
    assert np.allclose(cosine, 1.0, atol=1e-6)
    r = np.linspace(1e-4, law.escape_distance, 20001)
    assert float(jnp.max(law.magnitude_pn(r))) == pytest.approx(law.max_force_pn, rel=1e-3)


def test_gaussian_stiffness_at_centre():
    law = TrapLaw("gaussian", 25.0, 0.5)
    r = 1e-4
    assert float(law.magnitude_pn(r)) / r == pytest.approx(25.0, rel=1e-6)


def test_escape_distance_defaults():
    assert TrapLaw.paper().escape_distance == pytest.approx(2 * 0.446)
    assert TrapLaw("gaussian", 1.0, 0.8).escape_distance == pytest.approx(0.8)
    assert math.isinf(TrapLaw("harmonic", 1.0).escape_distance)


@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"name": "laser"}, "trap law name"),
        ({"stiffness_pn_per_um": -1.0}, "stiffness_pn_per_um"),
        ({"stiffness_pn_per_um": float("nan")}, "stiffness_pn_per_um"),
        ({"waist_um": 0.0}, "waist_um"),
        ({"escape_distance_um": -2.0}, "escape_distance_um"),
    ],
)
def test_bad_trap_parameters_are_named(kwargs, name):
    with pytest.raises(ValueError, match=name):
        TrapLaw(**kwargs)
