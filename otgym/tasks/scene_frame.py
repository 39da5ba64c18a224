"""The frame (and the recorded scene, ``scene_of``) of a task built on an ``otgym.sim.scene`` scene: the chip (or a plain
field of ``region_um`` when the scene has no chip), its spheres by kind, the handles,
the traps and an optional path, drawn by ``otgym.sim.render.SceneRenderer``. One
renderer per (chip or region, size) is kept, since drawing the chip's background is
the costly part."""

from __future__ import annotations

import functools

import jax
import numpy as np

from otgym import physics as ph
from otgym.sim.chip import Chip, load_chip
from otgym.sim.render import SceneRenderer
from otgym.tasks.base import KIND_NAMES, TaskScene


@functools.lru_cache(maxsize=8)
def _renderer(chip_name: str | None, region_um, size_px) -> SceneRenderer:
    chip = load_chip(chip_name) if chip_name is not None else None
    return SceneRenderer(chip, size_px=size_px, region_um=region_um)


def scene_frame(
    scene,
    physics_state,
    path_um=None,
    size_px: tuple[int, int] = (600, 400),
    region_um: tuple[float, float, float, float] | None = None,
    under=(),
    over=(),
) -> np.ndarray:
    """RGB (H, W, 3) uint8 of one environment's ``physics_state`` in ``scene``, with the
    task's marks ``under`` the bodies and ``over`` them (``otgym.sim.render``)."""
    chip = scene.config.chip
    if isinstance(chip, Chip):
        renderer = SceneRenderer(chip, size_px=size_px, region_um=region_um)
    else:
        renderer = _renderer(chip, region_um, tuple(size_px))
    model = scene.model
    physics = jax.device_get(physics_state)
    handles = np.zeros(len(model.sphere_body), bool)
    handles[list(model.trap_sphere)] = True
    return renderer.render(
        np.asarray(ph.sphere_positions_um(model, physics.pose)),
        np.asarray(model.sphere_radius_um),
        np.array([model.body_kinds[b] for b in model.sphere_body]),
        handles,
        np.asarray(physics.trap_xy_um),
        None if path_um is None else np.asarray(path_um),
        under=under,
        over=over,
    )


def scene_of(scene, physics_state, lines_um=(), targets_um=None, target_radius_um: float = 0.5) -> TaskScene:
    """The ``TaskScene`` of one environment's ``physics_state`` in ``scene``: every
    sphere with its radius and kind, the traps, and the given targets and lines."""
    model = scene.model
    physics = jax.device_get(physics_state)
    return TaskScene(
        spheres_um=np.asarray(ph.sphere_positions_um(model, physics.pose), float),
        radii_um=np.asarray(model.sphere_radius_um, float),
        kinds=tuple(KIND_NAMES[int(model.body_kinds[b])] for b in model.sphere_body),
        traps_um=np.asarray(physics.trap_xy_um, float),
        targets_um=np.zeros((0, 2)) if targets_um is None else np.asarray(targets_um, float).reshape(-1, 2),
        target_radius_um=target_radius_um,
        lines_um=tuple(np.asarray(line, float).reshape(-1, 2) for line in lines_um),
    )
