"""Shared checks of the registered tasks' tests."""

import warnings

import gymnasium as gym
import numpy as np
import pytest


def sb3_checker_warnings(env_id: str) -> list[str]:
    """The warnings Stable-Baselines3's ``check_env`` raises from its own code on
    ``gym.make(env_id)``; the test is skipped where SB3 is not installed."""
    checker = pytest.importorskip("stable_baselines3.common.env_checker")
    env = gym.make(env_id)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        checker.check_env(env, warn=True)
    env.close()
    return [str(w.message) for w in caught if "stable_baselines3" in w.filename]


def sort_state(held_grip_s: float, held: int = 0):
    """A ``sort-cells`` state built by hand (nothing compiled): cell 0 (kind 1, large)
    upstream of the junction, taken hold of for ``held_grip_s`` when ``held`` is 0 (-1:
    none held); cell 1 (kind 0, small) behind it; slot 2 empty; cell 3 (kind 0) past the
    junction (x > 130 um on the sorter chip)."""
    from otgym.tasks.sort_cells import core

    zeros = np.zeros(4, np.float32)
    return core.SortState(
        xy_um=np.array([[100.0, 70.0], [40.0, 58.0], [0.0, 0.0], [180.0, 40.0]], np.float32),
        kind=np.array([1, 0, 0, 0], np.int32),
        active=np.array([True, True, False, True]),
        age_s=zeros,
        dose_mj_per_um2=zeros,
        held=np.int32(held),
        grip_s=np.float32(held_grip_s if held >= 0 else 0.0),
        next_arrival_s=np.float32(10.0),
        time_s=np.float32(20.0),
        steps=np.int32(40),
        arrived=np.int32(3),
        correct=np.int32(0),
        wrong=np.int32(0),
        lost=np.int32(0),
        finished_dose_mj_per_um2=np.float32(0.0),
        finished=np.int32(0),
    )
