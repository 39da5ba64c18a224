"""Shared fixtures of the sim tests: the default chip and its derived fields (from the
run's fields cache, which the other packages' tests and every worker share: solved at
most once per run, about 6 s), scenes built once per session, and a builder of
straight-duct chips. Each test's own disk cache is private (tests of the cache itself)."""

from __future__ import annotations

import numpy as np
import pytest

from otgym.sim.cache import chip_fields
from otgym.sim.cache_dir import cache_dir
from otgym.sim.chip import Chip, Port, load_chip

RUN_CACHE_DIR = cache_dir()
"""The run's fields cache (``$OTGYM_CACHE_DIR`` or the default), read before any test
points the variable at its own directory."""


@pytest.fixture(autouse=True)
def private_cache(tmp_path, monkeypatch):
    """Keep every test's disk cache in its own temporary directory."""
    monkeypatch.setenv("OTGYM_CACHE_DIR", str(tmp_path / "cache"))


@pytest.fixture(scope="session")
def default_chip():
    return load_chip("default")


@pytest.fixture(scope="session")
def shared_cache_dir():
    """The run's fields cache for the default-chip fields and scenes, so the flow is
    solved once per run (about 6 s) rather than once per scene or worker."""
    return RUN_CACHE_DIR


def _in_cache(cache, make, *args):
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("OTGYM_CACHE_DIR", str(cache))
        return make(*args)


@pytest.fixture(scope="session")
def default_fields(default_chip, shared_cache_dir):
    return _in_cache(shared_cache_dir, chip_fields, default_chip)


@pytest.fixture(scope="session")
def scene_of(shared_cache_dir):
    """``scene_of(config)``: the scene of a ``SceneConfig``, built once per session (the
    tests share its compiled steps too) from the shared fields cache."""
    from otgym.sim.scene import build_scene

    scenes = {}

    def build(config):
        if config not in scenes:
            scenes[config] = _in_cache(shared_cache_dir, build_scene, config)
        return scenes[config]

    return build


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
