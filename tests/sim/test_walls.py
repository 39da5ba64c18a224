"""Signed distance field: against exact distances of known geometries."""

from __future__ import annotations

import numpy as np

from otgym.sim.chip import Chip
from otgym.sim.default_chip import PILLARS_UM
from otgym.sim.walls import channel_widths_um, signed_distance_um, wall_normals


def _disc_chamber(radius_um=20.0, pixel_size_um=0.5, size_um=60.0):
    """An anti-aliased circular chamber (fluid inside) and its exact distance."""
    n = int(size_um / pixel_size_um)
    centres = (np.arange(n) + 0.5) * pixel_size_um
    x, y = np.meshgrid(centres, centres)
    exact = radius_um - np.hypot(x - size_um / 2, y - size_um / 2)
    image = np.clip(0.5 + exact / pixel_size_um, 0.0, 1.0)
    return Chip("disc", image, pixel_size_um), exact, np.stack([x, y], axis=-1) - size_um / 2


def test_distance_to_a_circular_wall_is_sub_pixel_exact():
    chip, exact, offset = _disc_chamber()
    distance = signed_distance_um(chip)
    band = np.abs(exact) < 5.0
    # the iso-line of the bilinear image is a chord polygon of the circle: its error is
    # a small fraction of a pixel (0.08 px measured), far below a staircase's 0.5 px
    assert np.abs(distance - exact)[band].max() < 0.1 * chip.pixel_size_um
    assert np.abs(distance - exact)[band].mean() < 0.05 * chip.pixel_size_um
    assert np.all(np.sign(distance[np.abs(exact) > 0.3]) == np.sign(exact[np.abs(exact) > 0.3]))


def test_normals_are_unit_and_point_into_the_fluid():
    chip, exact, offset = _disc_chamber()
    normal = wall_normals(signed_distance_um(chip))
    assert np.allclose(np.linalg.norm(normal, axis=-1), 1.0)
    band = np.abs(exact) < 5.0
    inward = -offset[band] / np.linalg.norm(offset[band], axis=-1, keepdims=True)
    assert np.min(np.sum(normal[band] * inward, axis=-1)) > np.cos(np.radians(5.0))


def test_default_chip_pillars_and_widths(default_chip, default_fields):
    distance = default_fields.distance_um
    dx = default_chip.pixel_size_um
    for x, y, radius in PILLARS_UM:
        # centre of a pixel next to the pillar centre: exact distance known
        col, row = int(x / dx), int(y / dx)
        exact = np.hypot((col + 0.5) * dx - x, (row + 0.5) * dx - y) - radius
        assert abs(distance[row, col] - exact) < 0.05 * dx
    widths = channel_widths_um(default_chip, distance)
    assert abs(np.median(widths) - 25.0) <= dx
    assert abs(default_fields.median_width_um - np.median(widths)) < 1e-9
