"""The start-up shared by every task that carries a gripped payload along a planned
route: the route planned on the chip image between two of its sites (A* and a
B-spline for the whole assembly, ``otgym.planning``), densified, and the formation of
traps that holds the assembly, read off the scene at rest at the route's start
(``otgym.planning.formation``). ``SpeedControl`` and ``CellTransport``
(``otgym.tasks.transport.core``) and the interactive task
(``otgym.tasks.transport.interactive``) all start here.

Each piece is compiled whole (``jax.jit``): bitwise the op-by-op result, without
compiling each operation of a cold start.
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp

from otgym.planning import formation as fm
from otgym.planning import plan_path
from otgym.sim import scene as sc
from otgym.sim.chip import Chip, load_chip

reset_one = jax.jit(sc.reset_at)
"""``sc.reset_at`` compiled whole."""
start_heading = jax.jit(lambda path: fm.heading_at(path, 0.0))
"""A dense path's heading (rad) at its start."""
_formation_offsets = jax.jit(fm.formation_offsets)


@dataclasses.dataclass(frozen=True)
class RouteStart:
    """A task's route and formation on one chip."""

    chip: Chip
    path: fm.DensePath
    heading_rad: jnp.ndarray  # the path's heading at its start
    gripped: sc.SceneState  # the scene at rest at the path's start (key 0): the assembly gripped
    offsets_um: jnp.ndarray  # (T, 2) trap positions in the formation frame


def chip_of(scene_config: sc.SceneConfig) -> Chip:
    """The scene's chip (a ``Chip`` as given, or loaded by its name)."""
    chip = scene_config.chip
    return chip if isinstance(chip, Chip) else load_chip(chip)


def route_start(scene: sc.Scene, scene_config: sc.SceneConfig, start_um, goal_um) -> RouteStart:
    """Plan the route from ``start_um`` to ``goal_um`` (each a site name of the chip's
    sidecar or an (x, y) um point: ``Chip.site_um``) for ``scene``'s assembly and read
    its formation at the route's start."""
    chip = chip_of(scene_config)
    plan = plan_path(
        chip.image,
        chip.pixel_size_um,
        chip.site_um(start_um),
        chip.site_um(goal_um),
        robot_radius_um=scene.assembly_radius_um,
        threshold=0.5,
    )
    path = fm.dense_path(plan.smoothed_um)
    heading = start_heading(path)
    gripped = reset_one(scene, jax.random.PRNGKey(0), path.points_um[0], heading)
    offsets = _formation_offsets(gripped.physics.trap_xy_um, path.points_um[0], heading)
    return RouteStart(chip, path, heading, gripped, offsets)
