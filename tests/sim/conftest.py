"""Shared fixtures of the sim tests: the default chip and its derived fields (solved
once per session, about 6 s), and a builder of straight-duct chips."""

from __future__ import annotations

import numpy as np
import pytest

from otgym.sim.cache import compute_fields
from otgym.sim.chip import Chip, Port, load_chip


@pytest.fixture(autouse=True)
def private_cache(tmp_path, monkeypatch):
    """Keep every test's disk cache in its own temporary directory."""
    monkeypatch.setenv("OTGYM_CACHE_DIR", str(tmp_path / "cache"))


@pytest.fixture(scope="session")
def default_chip():
    return load_chip("default")


@pytest.fixture(scope="session")
def default_fields(default_chip):
    return compute_fields(default_chip)


def straight_duct(
    width_um=25.0, length_um=60.0, height_um=50.0, pixel_size_um=0.5, rate_um3_s=5000.0, margin_px=4
) -> Chip:
    """A horizontal channel across the image, inlet left, outlet right."""
    width_px = int(round(width_um / pixel_size_um))
    rows, cols = width_px + 2 * margin_px, int(round(length_um / pixel_size_um))
    image = np.zeros((rows, cols), np.float32)
    image[margin_px : margin_px + width_px] = 1.0
    middle = rows * pixel_size_um / 2
    ports = (
        Port("in", "inlet", (0.0, middle), rate_um3_s),
        Port("out", "outlet", (cols * pixel_size_um, middle), rate_um3_s),
    )
    return Chip("duct", image, pixel_size_um, height_um, ports)
