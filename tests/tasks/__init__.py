"""Shared checks of the registered tasks' tests."""

import warnings

import gymnasium as gym
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
