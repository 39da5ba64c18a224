"""Shared, session-wide paper-preset parameters (building the scene and planning
the path once for all env tests)."""

import pytest

from otgym.envs import speed_control as spc


@pytest.fixture(scope="session")
def paper_params():
    return spc.make_params("paper")
