"""Trap formations follow a path rigidly."""

import jax.numpy as jnp
import numpy as np
import pytest

from otgym.planning import formation


def test_formation_velocity_moves_the_traps_rigidly_along_a_circle():
    angles = np.linspace(0, np.pi / 2, 400)
    path = formation.dense_path(np.column_stack([50 * np.cos(angles), 50 * np.sin(angles)]))
    traps = jnp.array([[50.0, -3.0], [50.0, 3.0], [47.0, 0.0]])
    heading = formation.heading_at(path, 0.0)
    assert float(heading) == pytest.approx(np.pi / 2, abs=0.025)  # one-sided over 2 um of a 50 um radius
    offsets = formation.formation_offsets(traps, formation.point_at(path, 0.0), heading)
    arc = float(path.length_um) / 2  # a quarter of pi/2: 45 degrees along
    velocity = formation.formation_velocity(path, offsets, traps, arc, 1.0)
    moved = np.asarray(traps + velocity)
    distances = lambda p: np.linalg.norm(p[:, None] - p[None], axis=-1)  # noqa: E731
    assert distances(moved) == pytest.approx(distances(np.asarray(traps)), abs=1e-3)
    centre = np.array([50 * np.cos(np.pi / 4), 50 * np.sin(np.pi / 4)])
    assert moved[:2].mean(axis=0) == pytest.approx(centre, abs=0.05)  # the pair straddles the path
    inward = centre / np.linalg.norm(centre)
    assert moved[2] - centre == pytest.approx(-3 * inward, abs=0.05)  # the third trap stays inside


@pytest.mark.parametrize("points", [np.zeros((1, 2)), np.zeros((3, 2)), np.full((3, 2), np.nan)])
def test_bad_paths_are_refused(points):
    with pytest.raises(ValueError, match="path"):
        formation.dense_path(points)
