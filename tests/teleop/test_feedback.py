"""Haptic feedback from force-sensor readings: sign, saturation, stiffening near the
trap's bend, contact cue, invalid readings, and a real microscope frame."""

from __future__ import annotations

import numpy as np
import pytest

from otgym.physics.bodies import two_handle_robot
from otgym.physics.traps import TrapLaw
from otgym.sim.microscope import MicroscopeParams, microscope_images
from otgym.sim.sensor import VisionForceSensor
from otgym.teleop.feedback import FeedbackConfig, FeedbackLaw, newtons_per_pn_for
from otgym.teleop.retarget import device_to_chip

TICK_HZ = 50.0
LAW = TrapLaw.paper()
SETTLE_TICKS = 25  # 0.5 s: the 10 Hz second-order filter settles to 1e-6 within 0.2 s


def _steady(law, force_pn, offset_um, contact_pn=0.0, valid=None, ticks=SETTLE_TICKS):
    force_pn, offset_um = np.atleast_2d(force_pn), np.atleast_2d(offset_um)
    valid = np.ones(len(force_pn), bool) if valid is None else np.asarray(valid)
    for _ in range(ticks):
        out = law(force_pn, offset_um, contact_pn, valid)
    return out


def _trap_force(offset_um):
    return np.asarray(LAW.force_pn(np.asarray(offset_um, float)))


def test_stylus_force_opposes_the_traps_lead():
    """Trap 0.2 um to the handle's +x (chip): the stylus is pushed to device -x; trap
    0.2 um toward chip +y (down): the stylus is pushed up (device +y). Magnitude:
    newtons_per_pn * |f| with no stiffening at 0.2 um (< half the bend distance)."""
    config = FeedbackConfig()
    for offset, expected_direction in [([0.2, 0.0], [-1.0, 0.0, 0.0]), ([0.0, 0.2], [0.0, 1.0, 0.0])]:
        out = _steady(FeedbackLaw(config, LAW, TICK_HZ), _trap_force(offset), offset)
        magnitude = config.newtons_per_pn * LAW.paper_k_pn_per_um * 0.2
        np.testing.assert_allclose(out, magnitude * np.array(expected_direction), atol=1e-6)


def test_xz_plane_maps_chip_y_to_device_z():
    out = _steady(FeedbackLaw(FeedbackConfig(plane="xz"), LAW, TICK_HZ), _trap_force([0.0, 0.2]), [0.0, 0.2])
    assert out[2] < 0 and abs(out[1]) < 1e-12


def test_force_saturates_at_the_limit():
    law = FeedbackLaw(FeedbackConfig(force_limit_n=0.5), LAW, TICK_HZ)
    outputs = [law(np.array([[30.0, 40.0]]), np.array([[0.3, 0.4]]), 0.0, np.array([True])) for _ in range(50)]
    norms = np.linalg.norm(outputs, axis=1)
    assert norms.max() <= 0.5 + 1e-12
    np.testing.assert_allclose(outputs[-1], 0.5 * np.array([-0.6, 0.8, 0.0]), atol=1e-9)


def test_force_grows_toward_the_bend():
    """The same trap force read at growing handle distances: gain 1 up to half the
    bend distance (TrapLaw.escape_distance), rising quadratically to 1 + 2 = 3 at it."""
    config = FeedbackConfig(force_limit_n=100.0)
    bend = LAW.escape_distance
    force = np.array([[0.05, 0.0]])
    ratios = np.linspace(0.2, 1.2, 11)
    magnitudes = [np.linalg.norm(_steady(FeedbackLaw(config, LAW, TICK_HZ), force, [[r * bend, 0.0]])) for r in ratios]
    base = config.newtons_per_pn * 0.05
    expected = base * (1 + config.bend_stiffening * np.clip((ratios - 0.5) / 0.5, 0, 1) ** 2)
    np.testing.assert_allclose(magnitudes, expected, rtol=1e-6)
    assert np.all(np.diff(magnitudes) >= 0) and magnitudes[-1] == pytest.approx(3 * base)


def test_contact_cue_resists_the_commanded_direction_near_the_limit():
    config = FeedbackConfig()
    offset = [0.2, 0.0]
    quiet = _steady(FeedbackLaw(config, LAW, TICK_HZ), _trap_force(offset), offset, contact_pn=4.0)
    loud = _steady(FeedbackLaw(config, LAW, TICK_HZ), _trap_force(offset), offset, contact_pn=10.0)
    np.testing.assert_allclose(loud - quiet, [-config.contact_gain_n, 0.0, 0.0], atol=1e-6)


def test_invalid_readings_contribute_nothing_and_the_force_decays():
    config = FeedbackConfig()
    offsets = np.array([[0.2, 0.0], [0.0, 0.2]])
    forces = _trap_force(offsets)
    single = _steady(FeedbackLaw(config, LAW, TICK_HZ), forces[:1], offsets[:1])
    garbage = np.array([forces[0], [np.nan, np.nan]])
    mixed = _steady(FeedbackLaw(config, LAW, TICK_HZ), garbage, offsets, valid=[True, False])
    np.testing.assert_allclose(mixed, single, atol=1e-12)
    flagged = _steady(FeedbackLaw(config, LAW, TICK_HZ), forces, offsets, valid=[True, False])
    np.testing.assert_allclose(flagged, single, atol=1e-12)
    law = FeedbackLaw(config, LAW, TICK_HZ)
    _steady(law, forces, offsets)
    lost = [law(np.full((2, 2), np.nan), np.full((2, 2), np.nan), np.nan, np.zeros(2, bool)) for _ in range(25)]
    norms = np.linalg.norm(lost, axis=1)
    assert np.isfinite(lost).all() and norms[0] > 0.1 * norms.max() and norms[-1] < 1e-3 * norms.max()


def test_feedback_from_a_real_microscope_frame_opposes_the_true_offset():
    """20 frames of a two-handle robot at random poses, each trap 0.1-0.4 um from its
    handle in a random direction; the sensor reads the frames (its force error is about
    1 %, tests/sim/test_sensor.py) and the feedback, mapped back to the chip plane, must
    point against the true total trap force: every angle error below 5 degrees."""
    rng = np.random.default_rng(3)
    frames, robot = 20, two_handle_robot()
    theta = rng.uniform(0, 2 * np.pi, frames)
    cos, sin = np.cos(theta), np.sin(theta)
    rotation = np.stack([np.stack([cos, -sin], -1), np.stack([sin, cos], -1)], -2)
    spheres = np.array([7.0, 7.0]) + np.einsum("bij,nj->bni", rotation, robot.offsets_um)
    handles = spheres[:, list(robot.handle_indices)]
    angle = rng.uniform(0, 2 * np.pi, (frames, 2))
    traps = handles + rng.uniform(0.1, 0.4, (frames, 2))[..., None] * np.stack([np.cos(angle), np.sin(angle)], -1)
    params = MicroscopeParams(pixel_size_um=0.1)
    origin = np.zeros((frames, 2))
    images = microscope_images(
        spheres, np.broadcast_to(robot.radii_um, spheres.shape[:2]), origin, (140, 140), params, rng=5
    )
    reading = VisionForceSensor(LAW).measure(images, origin, params.pixel_size_um, traps)
    assert reading.valid.all()
    for b in range(frames):
        law = FeedbackLaw(FeedbackConfig(), LAW, TICK_HZ)
        out = _steady(law, reading.force_pn[b], traps[b] - reading.handle_xy_um[b])
        true_total = _trap_force(traps[b] - handles[b]).sum(axis=0)
        felt = device_to_chip(out, "xy")
        cosine = felt @ -true_total / (np.linalg.norm(felt) * np.linalg.norm(true_total))
        assert np.degrees(np.arccos(np.clip(cosine, -1, 1))) < 5.0


def test_scale_for_a_trap_law_and_validation():
    assert newtons_per_pn_for(LAW, 0.6) == pytest.approx(0.6 / LAW.max_force_pn)
    assert newtons_per_pn_for(LAW, 0.6) == pytest.approx(FeedbackConfig().newtons_per_pn, rel=0.01)
    with pytest.raises(ValueError, match="newtons_per_pn"):
        FeedbackConfig(newtons_per_pn=0.0)
    with pytest.raises(ValueError, match="plane"):
        FeedbackConfig(plane="yz")
    with pytest.raises(ValueError, match="cutoff_hz"):
        FeedbackLaw(FeedbackConfig(cutoff_hz=30.0), LAW, TICK_HZ)
    with pytest.raises(ValueError, match=r"\(H, 2\)"):
        FeedbackLaw(FeedbackConfig(), LAW, TICK_HZ)(np.zeros((2, 2)), np.zeros((1, 2)), 0.0, np.ones(2, bool))


def test_stable_scale_makes_the_quasi_static_loop_gain_one():
    """At the stable scale a trap offset d pushes the hand (300 N/m) back by exactly d
    at the trap: s * H * K * d newtons, over k_arm, times tau. Twice the stiffness
    halves the scale; non-positive inputs are refused."""
    from otgym.teleop.feedback import stable_newtons_per_pn

    scale = stable_newtons_per_pn(50.0, 2, 2.0)
    offset_um = 0.1
    hand_m = scale * 2 * 50.0 * offset_um / 300.0
    assert hand_m * 1000.0 * 2.0 == pytest.approx(offset_um, rel=1e-12)
    assert stable_newtons_per_pn(100.0, 2, 2.0) == pytest.approx(scale / 2)
    with pytest.raises(ValueError, match="handles"):
        stable_newtons_per_pn(50.0, 0, 2.0)
