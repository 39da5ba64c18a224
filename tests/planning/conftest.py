"""Shared maps for the planning tests: small, so the whole set stays fast."""

import numpy as np
import pytest


def corridor_image(width_px: int = 80, height_px: int = 40, channel_px: int = 14) -> np.ndarray:
    """An L-shaped bright channel on a dark chip: along the top, then down the right side."""
    image = np.zeros((height_px, width_px))
    image[3 : 3 + channel_px, 3:-3] = 1.0
    image[3:-3, -3 - channel_px : -3] = 1.0
    return image


@pytest.fixture(scope="session")
def default_chip():
    from otgym.sim.chip import load_chip

    return load_chip("default")


@pytest.fixture
def corridor():
    return corridor_image()
