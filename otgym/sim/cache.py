"""The fields derived from a chip (wall distance, normals, flow), computed once and
cached on disk as ``<cache dir>/chip-<hash>.npz``. The key hashes the chip's content
(image, pixel size, height, ports) and ``solver_fingerprint()``: the source of the
modules that compute the fields and the versions of the libraries they call. So a new
chip, an edit of a solver or a new SciPy never reads fields that another version wrote,
whatever a machine's cache holds from earlier runs. The cache directory is
``$OTGYM_CACHE_DIR`` or ``~/.cache/otgym``.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import importlib
import importlib.metadata
import os
import tempfile
from pathlib import Path

import numpy as np

from otgym.sim.cache_dir import cache_dir
from otgym.sim.chip import Chip
from otgym.sim.flow import FlowSolution, mid_height_factor, solve_flow
from otgym.sim.walls import channel_widths_um, signed_distance_um, wall_normals

SOLVER_MODULES = ("otgym.sim.walls", "otgym.sim.flow", "otgym.sim.cache", "otgym.physics.constants")
"""The modules whose code decides the cached fields."""

SOLVER_LIBRARIES = ("numpy", "scipy", "scikit-image")
"""The libraries whose versions may change the cached fields."""


@dataclasses.dataclass(frozen=True)
class ChipFields:
    """Everything derived from one chip (numpy, um and um/s)."""

    distance_um: np.ndarray
    normal: np.ndarray
    flow: FlowSolution
    median_width_um: float

    @property
    def mid_height_factor(self) -> float:
        """Focal-plane (mid-height) over depth-averaged speed, see ``flow``."""
        return mid_height_factor(self.median_width_um, self.flow.channel_height_um)


@functools.cache
def solver_fingerprint() -> str:
    """A hash of the source of ``SOLVER_MODULES`` and the versions of ``SOLVER_LIBRARIES``."""
    digest = hashlib.sha256()
    for name in SOLVER_MODULES:
        digest.update(Path(importlib.import_module(name).__file__).read_bytes())
    for library in SOLVER_LIBRARIES:
        digest.update(f"{library}={importlib.metadata.version(library)}".encode())
    return digest.hexdigest()


def cache_path(chip: Chip) -> Path:
    key = hashlib.sha256(f"{solver_fingerprint()}:{chip.content_hash}".encode()).hexdigest()[:32]
    return cache_dir() / f"chip-{key}.npz"


def compute_fields(chip: Chip) -> ChipFields:
    distance = signed_distance_um(chip)
    widths = channel_widths_um(chip, distance)
    return ChipFields(distance, wall_normals(distance), solve_flow(chip), float(np.median(widths)))


def chip_fields(chip: Chip) -> ChipFields:
    """The chip's derived fields, from the cache when present, else computed and stored."""
    path = cache_path(chip)
    if path.is_file():
        with np.load(path) as stored:
            flow = FlowSolution(stored["u_faces"], stored["v_faces"], chip.pixel_size_um, chip.channel_height_um)
            return ChipFields(stored["distance_um"], stored["normal"], flow, float(stored["median_width_um"]))
    fields = compute_fields(chip)
    path.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.NamedTemporaryFile(dir=path.parent, suffix=".npz", delete=False) as handle:
        np.savez_compressed(
            handle,
            distance_um=fields.distance_um,
            normal=fields.normal,
            u_faces=fields.flow.u_faces,
            v_faces=fields.flow.v_faces,
            median_width_um=fields.median_width_um,
        )
    os.replace(handle.name, path)
    return fields
