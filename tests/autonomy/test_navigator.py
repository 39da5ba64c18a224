"""The route navigator's dP_r (``otgym.autonomy.navigator``) on a straight route along x,
numpy only: how hard the autonomy pushes against an assembly that a person holds back,
backs off or steps aside, and that it still restores the formation's shape."""

import numpy as np

from otgym.autonomy.navigator import RouteNavigator
from otgym.task.task import CARRY
from tests.human.test_participants import OFFSETS_UM, TICK_S, scene

GAIN_PER_S, LEAD_UM, CRUISE_UM_S = 3.0, 1.0, 5.0


def carrying_navigator(cell_x_um: float) -> RouteNavigator:
    """A navigator carrying a cell at ``cell_x_um`` along the route, its commanded arc
    run ahead to the cell plus its lead (the steady state of an unhindered carry)."""
    route = np.stack([np.linspace(0.0, 300.0, 2401), np.zeros(2401)], axis=1)
    navigator = RouteNavigator(
        route, route[:, 0].copy(), OFFSETS_UM, TICK_S, CRUISE_UM_S, lead_um=LEAD_UM, carry_gain_per_s=GAIN_PER_S
    )
    navigator.reset(1)
    at_cell = scene([[cell_x_um, 0.0]], (OFFSETS_UM + [cell_x_um, 0.0])[None], CARRY)
    for _ in range(20):
        navigator.increments(at_cell)
    assert navigator.commanded_arc_um[0] == LEAD_UM + cell_x_um  # the set-up holds
    return navigator


def assembly_velocity_um_s(navigator, shift_um) -> np.ndarray:
    """The autonomy's mean trap velocity (2,) when cell and traps sit at 100 um + shift."""
    cell = np.array([100.0, 0.0]) + shift_um
    return navigator.increments(scene([cell], (OFFSETS_UM + cell)[None], CARRY))[0].mean(axis=0) / TICK_S


def test_backing_off_is_opposed_by_at_most_the_lead_pull():
    """A person backs the carried assembly 5 um along the route (away from a threat):
    the autonomy may pull forward by at most gain x lead = 3 um/s. A position servo
    that kept its commanded arc pulled by gain x 6 um = 18 um/s, which a person
    holding half the command could not overcome within the 20 um/s trap-speed clamp."""
    velocity = assembly_velocity_um_s(carrying_navigator(100.0), np.array([-5.0, 0.0]))
    assert velocity[0] <= GAIN_PER_S * LEAD_UM + 1e-9, velocity
    assert velocity[0] > 0.0  # it still leads the assembly forward


def test_a_step_aside_is_opposed_by_at_most_the_lead_pull():
    """Stepped 6 um aside (a dodge), the pull back toward the route is at most 3 um/s,
    not gain x 6 um = 18 um/s, and it points back to the route (-y)."""
    velocity = assembly_velocity_um_s(carrying_navigator(100.0), np.array([0.0, 6.0]))
    assert np.linalg.norm(velocity) <= GAIN_PER_S * LEAD_UM + 1e-9, velocity
    assert velocity[1] < -1.0


def test_the_formation_shape_is_restored_at_full_gain():
    """One robot's traps 0.5 um behind the other's (a shear that pinches the cell): the
    autonomy moves that robot forward relative to the other at the full gain,
    3 /s x 0.5 um = 1.5 um/s, within float round-off; capping the shape with the drift
    would halve it."""
    navigator = carrying_navigator(100.0)
    cell = np.array([100.0, 0.0])
    traps = OFFSETS_UM + cell
    traps[:2, 0] -= 0.5  # robot 0 lags
    increment = navigator.increments(scene([cell], traps[None], CARRY))[0] / TICK_S
    relative = increment[:2, 0].mean() - increment[2:, 0].mean()
    np.testing.assert_allclose(relative, GAIN_PER_S * 0.5, rtol=1e-6)
