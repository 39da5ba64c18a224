"""Derived fields are computed once, stored under OTGYM_CACHE_DIR, keyed by content."""

from __future__ import annotations

import numpy as np
from conftest import straight_duct

from otgym.sim.cache import cache_dir, cache_path, chip_fields
from otgym.sim.chip import Chip, Port


def test_cache_dir_follows_the_environment(tmp_path, monkeypatch):
    monkeypatch.setenv("OTGYM_CACHE_DIR", str(tmp_path / "elsewhere"))
    assert cache_dir() == tmp_path / "elsewhere"
    monkeypatch.delenv("OTGYM_CACHE_DIR")
    assert cache_dir().parts[-2:] == (".cache", "otgym")


def test_fields_are_stored_and_reloaded_identically():
    chip = straight_duct(length_um=20.0)
    assert not cache_path(chip).exists()
    first = chip_fields(chip)
    assert cache_path(chip).is_file()
    second = chip_fields(chip)
    for a, b in (
        (first.distance_um, second.distance_um),
        (first.normal, second.normal),
        (first.flow.u_faces, second.flow.u_faces),
        (first.flow.v_faces, second.flow.v_faces),
    ):
        assert np.array_equal(a, b)
    assert first.median_width_um == second.median_width_um


def test_key_changes_with_any_content():
    chip = straight_duct(length_um=20.0)
    image = chip.image.copy()
    image[0, 0] = 0.2
    variants = [
        Chip(chip.name, image, chip.pixel_size_um, chip.channel_height_um, chip.ports),
        Chip(chip.name, chip.image, chip.pixel_size_um, 40.0, chip.ports),
        Chip(
            chip.name,
            chip.image,
            chip.pixel_size_um,
            chip.channel_height_um,
            tuple(Port(p.name, p.kind, p.xy_um, 2 * p.flow_rate_um3_s) for p in chip.ports),
        ),
    ]
    keys = {cache_path(c) for c in variants} | {cache_path(chip)}
    assert len(keys) == 4
    renamed = Chip("other name", chip.image, chip.pixel_size_um, chip.channel_height_um, chip.ports)
    assert cache_path(renamed) == cache_path(chip)
