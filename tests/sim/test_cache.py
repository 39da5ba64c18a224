"""Derived fields are computed once, stored under OTGYM_CACHE_DIR, keyed by content."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import straight_duct

from otgym.sim import cache, flow
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


def test_an_edit_of_a_solver_or_a_new_library_moves_the_key(tmp_path):
    """Fields written by other solver code (or under another SciPy) are never read: a
    cache left on the machine by an earlier version cannot decide a run's fields."""
    chip = straight_duct(length_um=20.0)
    edited = tmp_path / "flow.py"
    edited.write_bytes(Path(flow.__file__).read_bytes() + b"\n# an edit\n")

    def key(change=lambda patch: None) -> str:
        with pytest.MonkeyPatch.context() as patch:
            change(patch)
            cache.solver_fingerprint.cache_clear()
            name = cache_path(chip).name
        cache.solver_fingerprint.cache_clear()
        return name

    before = key()
    after_edit = key(lambda patch: patch.setattr(flow, "__file__", str(edited)))
    after_library = key(lambda patch: patch.setattr(cache, "SOLVER_LIBRARIES", (*cache.SOLVER_LIBRARIES, "pytest")))
    assert len({before, after_edit, after_library}) == 3 and key() == before


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
