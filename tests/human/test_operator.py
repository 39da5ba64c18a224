"""The simulated operator: reaches the goal through free space, with the human model's
delay, errors and tremor (the model itself is tested in test_human.py)."""

import numpy as np
import pytest
from scipy import signal

from otgym.human.operator import OperatorParams, simulate_operator
from otgym.human.params import HumanParams
from otgym.planning.collision import segments_free
from otgym.planning.occupancy import build_occupancy

START, GOAL = (8.0, 10.0), (70.0, 34.0)


@pytest.fixture(scope="module")
def corridor_map():
    from tests.planning.conftest import corridor_image

    return build_occupancy(corridor_image(), 1.0, 2.0, 0.0).planning


@pytest.mark.slow
def test_reaches_the_goal_inside_free_space_reproducibly(corridor_map):
    params = OperatorParams()
    run = simulate_operator(corridor_map, 1.0, START, GOAL, params, seed=4)
    assert np.linalg.norm(run[-1] - GOAL) <= params.goal_tolerance_um
    assert np.array_equal(run[0], START)
    assert segments_free(corridor_map, run).all()  # walls stop the robot
    assert np.array_equal(run, simulate_operator(corridor_map, 1.0, START, GOAL, params, seed=4))
    assert not np.array_equal(run, simulate_operator(corridor_map, 1.0, START, GOAL, params, seed=5))


def test_nothing_moves_before_the_reaction_delay(corridor_map):
    human = HumanParams(tremor_rms_mm=0.0, drift_rms_mm=0.0, reaction_time_s=0.3, lapse_rate_per_h=0.0)
    quiet = OperatorParams(human=human, thermal_energy_pn_um=0.0)
    run = simulate_operator(corridor_map, 1.0, START, GOAL, quiet, seed=0)
    steps = int(0.3 * quiet.sample_rate_hz)
    assert np.all(run[: steps + 1] == START)
    assert np.linalg.norm(run[steps + 5] - START) > 0


@pytest.mark.slow
def test_stylus_tremor_reaches_the_trap_through_the_motion_scale(corridor_map):
    """Without the robot's thermal motion, the 8-12 Hz jitter of the robot's path is the
    stylus tremor times the motion scale, filtered by the overdamped robot (corner
    frequency 1.7 Hz: a gain of 0.14-0.21 across the band): four times the scale, about
    four times the jitter."""

    def jitter(scale):
        human = HumanParams(tremor_rms_mm=0.05, drift_rms_mm=0.0, lapse_rate_per_h=0.0)
        params = OperatorParams(human=human, motion_scale_um_per_mm=scale, thermal_energy_pn_um=0.0)
        run = simulate_operator(corridor_map, 1.0, START, GOAL, params, seed=2)
        sos = signal.butter(4, (8.0, 12.0), btype="bandpass", fs=params.sample_rate_hz, output="sos")
        return np.sqrt(np.mean(signal.sosfiltfilt(sos, run, axis=0) ** 2))

    assert 3.5 < jitter(8.0) / jitter(2.0) < 4.5
    assert 0.12 < jitter(8.0) / (0.05 * 8.0) < 0.23


def test_detours_and_errors_make_the_path_longer_than_without_them(corridor_map):
    calm_human = HumanParams(
        tremor_rms_mm=0.0,
        drift_rms_mm=0.0,
        signal_dependent_noise=0.0,
        extent_error_fraction=0.0,
        direction_error_deg=0.0,
    )
    calm = OperatorParams(human=calm_human, thermal_energy_pn_um=0.0, detour_probability=0.0)
    lengths = {}
    for name, params in (("calm", calm), ("human", OperatorParams(detour_probability=0.5))):
        run = simulate_operator(corridor_map, 1.0, START, GOAL, params, seed=1)
        lengths[name] = np.linalg.norm(np.diff(run, axis=0), axis=1).sum()
    assert lengths["human"] > 1.05 * lengths["calm"]


@pytest.mark.parametrize(
    "field, value, message",
    [
        ("speed_um_per_s", 0.0, "positive"),
        ("detour_probability", 1.5, r"\[0, 1\]"),
        ("detour_fraction", 1.2, r"\[0, 1\]"),
        ("motion_scale_um_per_mm", -4.0, "positive"),
        ("human", HumanParams(tremor_band_hz=(8.0, 60.0)), "sample_rate_hz"),
        ("human", {"reaction_time_s": 0.2}, "HumanParams"),
        ("thermal_energy_pn_um", -1.0, "non-negative"),
    ],
)
def test_bad_parameters_are_rejected(field, value, message):
    with pytest.raises(ValueError, match=message):
        OperatorParams(**{field: value})


def test_unreachable_goal_is_a_clear_error():
    free = np.ones((20, 20), dtype=bool)
    free[:, 10] = False
    with pytest.raises(ValueError, match="cannot reach the goal"):
        simulate_operator(free, 1.0, (2.0, 2.0), (18.0, 18.0))
