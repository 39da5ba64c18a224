"""The simulated operator: reaches the goal through free space, with its delay and tremor."""

import numpy as np
import pytest
from scipy import signal

from otgym.planning.collision import segments_free
from otgym.planning.occupancy import build_occupancy
from otgym.planning.operator import OperatorParams, _tremor, simulate_operator

START, GOAL = (8.0, 10.0), (70.0, 34.0)


@pytest.fixture(scope="module")
def corridor_map():
    from tests.planning.conftest import corridor_image

    return build_occupancy(corridor_image(), 1.0, 2.0, 0.0).planning


def test_reaches_the_goal_inside_free_space_reproducibly(corridor_map):
    params = OperatorParams()
    run = simulate_operator(corridor_map, 1.0, START, GOAL, params, seed=4)
    assert np.linalg.norm(run[-1] - GOAL) <= params.goal_tolerance_um
    assert np.array_equal(run[0], START)
    assert segments_free(corridor_map, run).all()  # walls stop the robot
    assert np.array_equal(run, simulate_operator(corridor_map, 1.0, START, GOAL, params, seed=4))
    assert not np.array_equal(run, simulate_operator(corridor_map, 1.0, START, GOAL, params, seed=5))


def test_nothing_moves_before_the_reaction_delay(corridor_map):
    quiet = OperatorParams(tremor_rms_um=0.0, thermal_energy_pn_um=0.0, reaction_delay_s=0.3)
    run = simulate_operator(corridor_map, 1.0, START, GOAL, quiet, seed=0)
    steps = int(0.3 * quiet.sample_rate_hz)
    assert np.all(run[: steps + 1] == START)
    assert np.linalg.norm(run[steps + 5] - START) > 0


def test_tremor_has_its_rms_and_sits_in_the_physiological_band():
    params = OperatorParams()
    tremor = _tremor(np.random.default_rng(0), 20000, params)
    assert np.allclose(tremor.std(axis=0), params.tremor_rms_um)
    frequency, power = signal.welch(tremor[:, 0], fs=params.sample_rate_hz, nperseg=1024)
    in_band = (frequency >= 8.0) & (frequency <= 12.0)
    assert 8.0 <= frequency[np.argmax(power)] <= 12.0
    assert power[in_band].sum() > 0.9 * power.sum()


def test_detours_and_errors_make_the_path_longer_than_without_them(corridor_map):
    calm = OperatorParams(tremor_rms_um=0.0, thermal_energy_pn_um=0.0, detour_probability=0.0,
                          extent_error_fraction=0.0, direction_error_deg=0.0)
    lengths = {}
    for name, params in (("calm", calm), ("human", OperatorParams(detour_probability=0.5))):
        run = simulate_operator(corridor_map, 1.0, START, GOAL, params, seed=1)
        lengths[name] = np.linalg.norm(np.diff(run, axis=0), axis=1).sum()
    assert lengths["human"] > 1.05 * lengths["calm"]


@pytest.mark.parametrize(
    "field, value, message",
    [("speed_um_per_s", 0.0, "positive"), ("detour_probability", 1.5, r"\[0, 1\]"),
     ("tremor_band_hz", (8.0, 60.0), "sample_rate_hz"), ("reaction_delay_s", -0.1, "non-negative")],
)
def test_bad_parameters_are_rejected(field, value, message):
    with pytest.raises(ValueError, match=message):
        OperatorParams(**{field: value})


def test_unreachable_goal_is_a_clear_error():
    free = np.ones((20, 20), dtype=bool)
    free[:, 10] = False
    with pytest.raises(ValueError, match="cannot reach the goal"):
        simulate_operator(free, 1.0, (2.0, 2.0), (18.0, 18.0))
