"""Tests of the shared-control arbitration (``otgym.shared.arbitration``): the three
alpha(d) laws, the modes and the blend dP_s = tau (alpha dP_h + (1 - alpha) dP_r).

Every expected value is written out from the paper's equation 4 (0.5 near, 0.1 far,
linear between d1 and d2) or the release's step law, not recomputed with the code's own
helpers; float tolerances are a few ulps of double precision unless stated."""

import numpy as np
import pytest

from otgym import registry
from otgym.shared import (
    MODES,
    ArbitrationConfig,
    alpha_for_mode,
    blend,
    paper_alpha,
    smooth_alpha,
    step_alpha,
)

D1, D2 = 10.0, 20.0


def test_paper_alpha_is_half_at_and_below_d1():
    """Catches a near-obstacle share other than 0.5, or a ramp that starts before d1."""
    np.testing.assert_allclose(paper_alpha(np.array([0.0, 3.0, 9.999, D1]), D1, D2), 0.5, rtol=0, atol=1e-12)


def test_paper_alpha_is_a_tenth_at_and_beyond_d2():
    """Catches a far share other than 0.1, a ramp that does not stop at d2 (it would go
    below 0.1 beyond d2) or one that ends early."""
    np.testing.assert_allclose(paper_alpha(np.array([D2, 20.001, 35.0, 1e6]), D1, D2), 0.1, rtol=0, atol=1e-12)


def test_paper_alpha_is_linear_between_d1_and_d2():
    """Midpoint 0.3 and quarter point 0.4: catches a ramp that is not linear (e.g. the
    smoothstep, 0.5 - 0.4 * 0.15625 = 0.4375 at the quarter point), reversed, or with
    d1 and d2 swapped."""
    np.testing.assert_allclose(paper_alpha(15.0, D1, D2), 0.3, atol=1e-12)
    np.testing.assert_allclose(paper_alpha(12.5, D1, D2), 0.4, atol=1e-12)
    np.testing.assert_allclose(paper_alpha(17.5, D1, D2), 0.2, atol=1e-12)
    # the distances are honoured, not hard-coded: the same fractions on another scale
    np.testing.assert_allclose(paper_alpha(np.array([1.0, 1.5, 1.25, 2.0]), 1.0, 2.0), [0.5, 0.3, 0.4, 0.1], atol=1e-12)


def test_paper_alpha_broadcasts_over_arrays():
    """Catches a scalar-only implementation (the trials call it on an (E,) array)."""
    distance = np.array([[0.0, 15.0], [12.5, 40.0]])
    np.testing.assert_allclose(paper_alpha(distance, D1, D2), [[0.5, 0.3], [0.4, 0.1]], atol=1e-12)


@pytest.mark.parametrize(
    "distance, expected",
    [(0.0, 0.5), (5.0, 0.5), (9.9, 0.5), (10.1, 0.3), (15.0, 0.3), (19.9, 0.3), (20.1, 0.1), (50.0, 0.1)],
)
def test_step_alpha_has_three_bands(distance, expected):
    """Inside each band: 0.5 below d1, 0.3 between, 0.1 beyond d2. Catches swapped
    bands, a missing middle step, or a linear ramp (which gives 0.496 at 10.1)."""
    assert step_alpha(distance, D1, D2) == pytest.approx(expected, abs=1e-12)


def test_smooth_alpha_matches_paper_law_at_d1_d2_and_midpoint():
    """The smoothstep has the same ends and, by symmetry, the same midpoint as the ramp:
    catches a smoothing with other end values or an asymmetric curve."""
    for d in (0.0, D1, 15.0, D2, 30.0):
        assert smooth_alpha(d, D1, D2) == pytest.approx(paper_alpha(d, D1, D2), abs=1e-12)
    assert smooth_alpha(15.0, D1, D2) == pytest.approx(0.3, abs=1e-12)


def test_smooth_alpha_is_monotone_non_increasing():
    """On a 0.001 um grid from 0 to 30 um: catches a smoothing that overshoots (e.g. a
    cubic with the wrong coefficients) or an increasing law. Allowance 1e-15 for
    rounding in 3s^2 - 2s^3."""
    d = np.linspace(0.0, 30.0, 30001)
    assert np.all(np.diff(smooth_alpha(d, D1, D2)) <= 1e-15)


def test_smooth_alpha_has_zero_slope_at_d1_and_d2():
    """Finite differences with h = 1e-4 um. The smoothstep's one-sided slope there is
    about 0.4 * 3 h / (d2 - d1)^2 = 1.2e-6 /um; the linear ramp's is 0.04 /um, so a
    bound of 1e-4 /um catches the ramp (a C0 law) by a factor 400. The midpoint slope,
    -0.4 * 1.5 / 10 = -0.06 /um, catches a flat or wrongly scaled curve."""
    h = 1e-4
    for d in (D1, D2):
        right = (smooth_alpha(d + h, D1, D2) - smooth_alpha(d, D1, D2)) / h
        left = (smooth_alpha(d, D1, D2) - smooth_alpha(d - h, D1, D2)) / h
        assert abs(right) < 1e-4 and abs(left) < 1e-4, (d, left, right)
    mid = (smooth_alpha(15.0 + h, D1, D2) - smooth_alpha(15.0 - h, D1, D2)) / (2 * h)
    assert mid == pytest.approx(-0.06, rel=1e-6)


def test_alpha_for_mode_manual_and_autonomous_ignore_distance():
    """manual -> 1 and autonomous -> 0 everywhere, shaped like the distances: catches
    swapped modes or a law applied in them."""
    distance = np.array([0.0, 12.0, 15.0, 100.0])
    manual = alpha_for_mode("manual", distance)
    autonomous = alpha_for_mode("autonomous", distance)
    assert manual.shape == autonomous.shape == distance.shape
    np.testing.assert_array_equal(manual, 1.0)
    np.testing.assert_array_equal(autonomous, 0.0)


@pytest.mark.parametrize(
    "law, expected",
    [("paper", [0.5, 0.4, 0.1]), ("step", [0.5, 0.3, 0.1]), ("smooth", [0.5, 0.5 - 0.4 * 0.15625, 0.1])],
)
def test_alpha_for_mode_shared_uses_the_configured_law_and_distances(law, expected):
    """Shared mode applies the config's law at the config's d1, d2 (here 2 and 6 um; 3 um
    is the quarter point): catches a law or distances ignored in favour of the
    defaults (at the defaults 3 um and 7 um would give 0.5 in every law)."""
    config = ArbitrationConfig(law=law, d1_um=2.0, d2_um=6.0)
    np.testing.assert_allclose(alpha_for_mode("shared", np.array([1.0, 3.0, 7.0]), config), expected, atol=1e-12)


def test_alpha_for_mode_shared_defaults_to_paper_law():
    """The default config is the paper law at 10 and 20 um."""
    np.testing.assert_allclose(alpha_for_mode("shared", np.array([5.0, 15.0, 25.0])), [0.5, 0.3, 0.1], atol=1e-12)
    assert set(MODES) == {"manual", "shared", "autonomous"}
    assert set(registry.names("laws")) == {"paper", "step", "smooth"}


@pytest.mark.parametrize("mode", ["Shared", "auto", "", "human"])
def test_alpha_for_mode_rejects_unknown_mode(mode):
    """Catches a silent fallback (e.g. to shared or autonomous) for a misspelt mode."""
    with pytest.raises(ValueError, match="unknown mode"):
        alpha_for_mode(mode, 5.0)


@pytest.mark.parametrize(
    "kwargs",
    [
        dict(d1_um=20.0, d2_um=20.0),
        dict(d1_um=25.0, d2_um=20.0),
        dict(d1_um=-1.0, d2_um=20.0),
        dict(law="linear"),
        dict(tau=0.0),
        dict(tau=-1.0),
        dict(d1_um=float("nan")),
        dict(d2_um=float("inf")),
    ],
)
def test_arbitration_config_rejects_invalid(kwargs):
    """d1 >= d2 (a zero-width or reversed ramp divides by zero or inverts), negative d1,
    an unknown law, tau <= 0 and non-finite distances must all raise."""
    with pytest.raises(ValueError):
        ArbitrationConfig(**kwargs)


def test_arbitration_config_at_d1_zero_shares_control_from_contact_on():
    """d1 = 0 is allowed (0 <= d1 < d2): a config that hands the human the near share only
    at contact. Built with law smooth, d1 0, d2 1 um and tau 0.5, it behaves so: alpha
    0.5 at and inside contact (d <= d1 = 0, an overlap gives a negative gap), the
    smoothstep's midpoint 0.5 - 0.4 / 2 = 0.3 halfway (0.5 um), 0.5 - 0.4 x 0.15625 at the
    quarter point, 0.1 at and beyond d2; the paper law at the same distances is the straight
    ramp (0.4 at 0.25 um); and the blend of the accepted config scales by its tau. Catches a
    validation that refuses d1 = 0, a ramp that divides by d1 or measures from a default
    d1, a law or tau of the config that is not the one applied."""
    config = ArbitrationConfig(law="smooth", d1_um=0.0, d2_um=1.0, tau=0.5)
    gaps = np.array([-0.5, 0.0, 0.25, 0.5, 1.0, 2.0])
    np.testing.assert_allclose(
        alpha_for_mode("shared", gaps, config), [0.5, 0.5, 0.5 - 0.4 * 0.15625, 0.3, 0.1, 0.1], atol=1e-12
    )
    paper = ArbitrationConfig(law="paper", d1_um=0.0, d2_um=1.0)
    np.testing.assert_allclose(alpha_for_mode("shared", gaps, paper), [0.5, 0.5, 0.4, 0.3, 0.1, 0.1], atol=1e-12)
    alpha = alpha_for_mode("shared", 0.5, config)
    np.testing.assert_allclose(
        blend(HUMAN, ROBOT, alpha, tau=config.tau), 0.5 * (0.3 * HUMAN + 0.7 * ROBOT), atol=1e-12
    )


HUMAN = np.array([[1.0, -2.0], [0.5, 3.0]])
ROBOT = np.array([[-4.0, 1.0], [2.0, 0.0]])


def test_blend_alpha_one_is_the_human_alpha_zero_the_robot():
    """With tau 2.5: catches swapped weights (alpha weighting the robot) and a tau that
    is ignored or applied to one term only."""
    np.testing.assert_allclose(blend(HUMAN, ROBOT, 1.0, tau=2.5), 2.5 * HUMAN, atol=1e-12)
    np.testing.assert_allclose(blend(HUMAN, ROBOT, 0.0, tau=2.5), 2.5 * ROBOT, atol=1e-12)


def test_blend_half_is_the_mean():
    """alpha 0.5, tau 1: the mean of the two increments."""
    np.testing.assert_allclose(blend(HUMAN, ROBOT, 0.5), [[-1.5, -0.5], [1.25, 1.5]], atol=1e-12)


def test_blend_broadcasts_alpha_per_environment():
    """alpha (E, 1, 1) over increments (E, T, 2): each environment gets its own share.
    Checked against a per-environment loop; catches broadcasting along the wrong axis
    (e.g. alpha applied per trap or per coordinate)."""
    rng = np.random.default_rng(0)
    human, robot = rng.normal(size=(2, 3, 4, 2))
    alpha = np.array([0.0, 0.3, 1.0])
    out = blend(human, robot, alpha[:, None, None], tau=1.5)
    assert out.shape == (3, 4, 2)
    for e in range(3):
        np.testing.assert_allclose(out[e], 1.5 * (alpha[e] * human[e] + (1 - alpha[e]) * robot[e]), atol=1e-12)
    np.testing.assert_allclose(out[0], 1.5 * robot[0], atol=1e-12)
    np.testing.assert_allclose(out[2], 1.5 * human[2], atol=1e-12)
