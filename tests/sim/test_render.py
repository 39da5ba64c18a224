"""RGB scene renderer: colours where they belong (its speed: benchmarks/chip.py)."""

from __future__ import annotations

import numpy as np
import pytest

from otgym.physics.bodies import BodyKind
from otgym.sim.render import CHANNEL_RGB, HANDLE_RGB, KIND_RGB, SOLID_RGB, TRAP_RGB, SceneRenderer


def _scene():
    xy = np.array([[40.0, 40.0], [46.0, 40.0], [150.0, 100.0], [250.0, 160.0]])
    radius = np.array([2.0, 2.0, 4.0, 3.0])
    kind = np.array([BodyKind.ROBOT, BodyKind.ROBOT, BodyKind.CELL, BodyKind.OBSTACLE])
    handle = np.array([True, False, False, False])
    traps = np.array([[100.0, 160.0]])
    return xy, radius, kind, handle, traps


def test_frame_shows_channels_bodies_and_traps(default_chip):
    renderer = SceneRenderer(default_chip, (600, 400))
    frame = renderer.render(*_scene())
    assert frame.shape == (400, 600, 3) and frame.dtype == np.uint8
    at = lambda xy: frame[int(renderer.to_px(xy)[1]), int(renderer.to_px(xy)[0])].astype(float)  # noqa: E731
    assert np.allclose(at((20.0, 40.0)), CHANNEL_RGB, atol=2)
    assert np.allclose(at((20.0, 100.0)), SOLID_RGB, atol=2)
    assert np.allclose(at((40.0, 40.0)), HANDLE_RGB, atol=2)
    assert np.allclose(at((46.0, 40.0)), KIND_RGB[BodyKind.ROBOT], atol=2)
    assert np.allclose(at((150.0, 100.0)), KIND_RGB[BodyKind.CELL], atol=2)
    assert np.allclose(at((250.0, 160.0)), KIND_RGB[BodyKind.OBSTACLE], atol=2)
    ring = renderer.to_px((100.0, 160.0)) + np.array([max(3.0, 0.6 * renderer.scale), 0.0])
    patch = frame[int(ring[1]) - 1 : int(ring[1]) + 2, int(ring[0]) - 1 : int(ring[0]) + 2].reshape(-1, 3).astype(float)
    assert np.min(np.abs(patch - TRAP_RGB).max(axis=1)) <= 10


def test_path_and_flow_arrows_are_drawn(default_chip, default_fields):
    plain = SceneRenderer(default_chip, (300, 200))
    with_arrows = SceneRenderer(default_chip, (300, 200), default_fields.flow.node_velocity_um_s(default_chip.fluid))
    assert np.any(plain.background != with_arrows.background)
    xy, radius, kind, handle, traps = _scene()
    path = np.stack([np.linspace(5.0, 295.0, 50), np.full(50, 40.0)], axis=-1)
    assert np.any(plain.render(xy, radius, kind, handle, traps, path) != plain.render(xy, radius, kind, handle, traps))


def test_region_zooms_in(default_chip):
    renderer = SceneRenderer(default_chip, (200, 200), region_um=(30.0, 30.0, 50.0, 50.0))
    assert renderer.scale == pytest.approx(10.0)
    assert np.allclose(renderer.to_px((40.0, 40.0)), (100.0, 100.0))
    with pytest.raises(ValueError, match="region_um"):
        SceneRenderer(default_chip, region_um=(10.0, 0.0, 5.0, 20.0))


def test_without_a_chip_a_plain_field_and_unknown_kinds_in_grey():
    from otgym.sim.render import UNKNOWN_KIND_RGB

    renderer = SceneRenderer(None, (200, 100), region_um=(0.0, 0.0, 100.0, 50.0))
    xy = np.array([[20.0, 20.0], [50.0, 20.0], [80.0, 20.0]])
    frame = renderer.render(
        xy, [3.0, 3.0, 3.0], np.array([-1, BodyKind.ROBOT, -1]), np.array([False, False, True]), np.zeros((0, 2))
    )
    at = lambda xy: frame[int(renderer.to_px(xy)[1]), int(renderer.to_px(xy)[0])].astype(float)  # noqa: E731
    assert np.allclose(at((90.0, 45.0)), CHANNEL_RGB, atol=1)
    assert np.allclose(at(xy[0]), UNKNOWN_KIND_RGB, atol=2)
    assert np.allclose(at(xy[1]), KIND_RGB[BodyKind.ROBOT], atol=2)
    assert np.allclose(at(xy[2]), HANDLE_RGB, atol=2)  # a handle stays a handle whatever its kind
    with pytest.raises(ValueError, match="region_um"):
        SceneRenderer(None, (200, 100))


def test_marks_dashed_lines_discs_labels_beneath_or_above_the_bodies():
    from otgym.sim.render import Disc, Label, Line

    renderer = SceneRenderer(None, (200, 100), region_um=(0.0, 0.0, 200.0, 100.0))  # 1 px per um
    cell = (np.array([[100.0, 50.0]]), np.array([10.0]), np.array([BodyKind.CELL]), np.array([False]), np.zeros((0, 2)))
    line = Line(np.array([[10.0, 20.0], [190.0, 20.0]]), (200, 0, 0), width_px=3.0, dash_px=10.0)
    across = Line(np.array([[80.0, 50.0], [120.0, 50.0]]), (0, 0, 200), width_px=3.0)
    frame = renderer.render(
        *cell,
        under=[across, Disc((30.0, 70.0), 8.0, (0, 200, 0), opacity=0.5)],
        over=[line, Label((150, 80), "x", (0, 0, 0))],
    )
    drawn = np.all(frame[20, 10:190] == (200, 0, 0), axis=-1)
    assert 0.4 < drawn.mean() < 0.6 and np.all(frame[19:22, 12] == (200, 0, 0))  # dashed, 3 px wide
    assert np.allclose(frame[50, 100], KIND_RGB[BodyKind.CELL], atol=1) and np.all(frame[50, 85] == (0, 0, 200))
    assert np.allclose(frame[70, 30], CHANNEL_RGB + 0.5 * ((0, 200, 0) - CHANNEL_RGB), atol=1)  # half blended
    assert frame[75:95, 145:165].astype(int).sum(axis=-1).min() < 200  # the label's dark text
    with pytest.raises(TypeError, match="a mark is a Line, a Disc or a Label"):
        renderer.render(*cell, over=["text"])
