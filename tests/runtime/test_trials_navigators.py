"""A navigator registered at run time (``otgym.registry.register``, tag ``trial-mode``)
is a mode of the batched trials: ``run_trials`` builds it by its name, with its own
options, and its dP_r drives its trials' rows while the route navigator drives the
others."""

from __future__ import annotations

import numpy as np
import pytest

from otgym import registry
from otgym.human.params import sample_population
from otgym.runtime import trials as tr
from tests.task import fast_scenario, shared_task

STEP_UM = 0.0123
"""The marker navigator's dP_r along x in every tick, um (no other navigator gives it)."""
TICKS = 5


class MarkerNavigator:
    """Moves every trap by ``step_um`` along x each tick; records how it was built and
    what it was asked."""

    built: list[MarkerNavigator] = []

    def __init__(self, task, max_speed_um_s, step_um, seed):
        self.task, self.max_speed_um_s, self.step_um, self.seed = task, max_speed_um_s, step_um, seed
        self.environments, self.rows_seen = None, []
        MarkerNavigator.built.append(self)

    @classmethod
    def for_task(cls, task, max_speed_um_s: float = 20.0, step_um: float = 0.0, seed: int = 0):
        return cls(task, max_speed_um_s, step_um, seed)

    def reset(self, n_env: int) -> None:
        self.environments = n_env

    def increments(self, obs):
        n = len(obs.trap_xy_um)
        self.rows_seen.append(n)
        step = np.zeros((n, self.task.n_traps, 2))
        step[..., 0] = self.step_um
        return step


class _Enough(Exception):
    """Ends the batch after ``TICKS`` ticks."""


@pytest.fixture
def marker():
    MarkerNavigator.built.clear()
    registry.register("navigators", "marker", f"{__name__}:MarkerNavigator", "moves along x", tags=("trial-mode",))
    yield
    registry.unregister("navigators", "marker")


@pytest.mark.slow
def test_a_navigator_registered_at_run_time_is_a_mode_of_the_batched_trials(marker):
    """Fails if the trials refuse the registered mode (a list of modes read once, at
    import), if they build another navigator in its place or without its options and
    seed, or if its dP_r does not reach its own trial (and only that one)."""
    assert "marker" in tr.trial_modes() and tr.trial_autonomy("marker") == "marker"
    specs = [tr.TrialSpec(0, mode, 0, 7) for mode in ("autonomous", "marker")]
    robot = []

    def recorder(view):
        robot.append(np.array(view.robot_um))
        if len(robot) == TICKS:
            raise _Enough

    task = shared_task()
    with pytest.raises(_Enough):
        tr.run_trials(
            task,
            specs,
            {0: sample_population(1, 3)[0]},
            seed=3,
            scenarios=[fast_scenario(7)] * 2,
            recorder=recorder,
            navigator_config={"marker": {"step_um": STEP_UM}},
        )
    (navigator,) = MarkerNavigator.built
    assert navigator.task is task and navigator.step_um == STEP_UM and navigator.seed == 3
    assert navigator.max_speed_um_s == tr.TASK_RETARGET.max_trap_speed_um_s
    assert navigator.environments == 1 and navigator.rows_seen == [1] * TICKS
    robot = np.stack(robot)
    assert np.all(robot[:, 1, :, 0] == STEP_UM) and np.all(robot[:, 1, :, 1] == 0)
    assert not np.any(np.isclose(robot[:, 0, :, 0], STEP_UM))  # the autonomous trial keeps the route follower
