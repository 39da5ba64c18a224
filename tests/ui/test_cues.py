"""The cue functions of the window (``otgym.ui.cues``): what each cue shows, at its edges."""

import numpy as np
import pytest

from otgym.ui import cues


def test_contact_gauge_is_full_at_the_10_pn_limit_and_over_beyond():
    assert cues.contact_gauge(10.0).fraction == pytest.approx(1.0)
    assert not cues.contact_gauge(10.0).over
    assert cues.contact_gauge(5.0).fraction == pytest.approx(0.5)
    assert cues.contact_gauge(12.0).over
    assert cues.contact_gauge(-1.0).fraction == 0.0


def test_haptic_gauges_against_each_device_limit_none_without_haptics():
    gauges = cues.haptic_gauges([[0.3, 0.4, 0.0], [1.0, 0.0, 0.0]], [1.0, 0.0])
    assert gauges[0].fraction == pytest.approx(0.5)
    assert gauges[1] is None


@pytest.mark.parametrize(
    "alpha, mode, shown",
    [
        (0.399, "shared", False),
        (0.4, "shared", True),
        (0.5, "shared", True),
        (0.1, "shared", False),
        (1.0, "manual", False),
        (0.0, "autonomous", False),
    ],
)
def test_fine_tune_prompt_exactly_in_the_fine_tuning_band_of_shared_control(alpha, mode, shown):
    assert cues.fine_tune_prompt(alpha, mode) is shown


def test_fine_tune_prompt_follows_the_alpha_law_between_d1_and_d2():
    # paper law: alpha 0.5 at d1 = 10 um, 0.1 at d2 = 20 um: alpha = 0.4 at 12.5 um
    from otgym.shared import alpha_for_mode

    assert cues.fine_tune_prompt(float(alpha_for_mode("shared", 12.4)), "shared")
    assert not cues.fine_tune_prompt(float(alpha_for_mode("shared", 12.6)), "shared")


def test_trap_loss_warning_as_the_offset_nears_the_escape_distance():
    escape = 0.8
    offsets = np.zeros((4, 2))
    assert not cues.trap_loss_warning(offsets, escape)
    assert cues.trap_loss_level(offsets, escape) == 0.0
    offsets[2] = [0.39, 0.0]
    assert not cues.trap_loss_warning(offsets, escape)
    offsets[2] = [0.0, 0.41]
    assert cues.trap_loss_warning(offsets, escape)
    offsets[2] = [0.6, 0.0]
    assert cues.trap_loss_level(offsets, escape) == pytest.approx(0.5)
    offsets[2] = [0.8, 0.0]
    assert cues.trap_loss_level(offsets, escape) == pytest.approx(1.0)
    offsets[1] = [np.nan, np.nan]  # a handle the sensor lost does not hide the others
    assert cues.trap_loss_warning(offsets, escape)


def test_proximity_colour_ramps_monotonically_from_green_to_red():
    gaps = np.linspace(30.0, 0.0, 61)  # approaching
    levels = [cues.proximity_level(g) for g in gaps]
    assert levels[0] == 0.0 and levels[-1] == 1.0
    assert np.all(np.diff(levels) >= 0)
    colours = np.array([cues.ramp_rgb(level) for level in levels])
    assert np.all(np.diff(colours[:, 0]) >= 0) and np.all(np.diff(colours[:, 1]) <= 0)
    assert colours[0, 1] > colours[0, 0] and colours[-1, 0] > colours[-1, 1]  # green, then red


def test_motion_direction_points_along_the_route_ahead():
    route = np.array([[0.0, 0.0], [100.0, 0.0], [100.0, 100.0]])
    arc = np.array([0.0, 100.0, 200.0])
    assert cues.motion_direction([20.0, 5.0], 20.0, route, arc, lookahead_um=10.0) == pytest.approx(
        np.array([10.0, -5.0]) / np.hypot(10.0, 5.0)
    )
    assert cues.motion_direction([100.0, 100.0], 200.0, route, arc) == pytest.approx([0.0, 0.0])


def test_obstacle_tally_and_elapsed_time():
    assert cues.obstacle_tally([True, True, False, True], [False, True, False, False]) == (2, 3)
    assert cues.format_elapsed(75.25) == "1:15.2"


def test_light_dose_text_in_mj_per_um2_or_unknown():
    assert cues.light_dose_text(0.012345) == "0.0123 mJ/um^2"
    assert cues.light_dose_text(0.0) == "0 mJ/um^2"
    assert cues.light_dose_text(float("nan")) == "unknown"
