"""What a view of the interactive task needs to know about it, as plain numpy arrays
(``TaskLayout``): the chip, its flow sampled at the pixel centres, the planned route,
which sphere belongs to which body, the traps' handles. It is built once from an
``InteractiveTask`` (``layout_of``) where the task lives and handed to a window in
another process (it pickles: no JAX arrays inside), so the window never builds the
task (seconds of work beside the simulation's own build)."""

from __future__ import annotations

import dataclasses

import jax.numpy as jnp
import numpy as np

from otgym.runtime.task import ROUTE_SEARCH_POINTS, InteractiveTask
from otgym.sim.chip import Chip


@dataclasses.dataclass(frozen=True, eq=False)
class TaskLayout:
    chip: Chip
    flow_velocity_um_s: np.ndarray
    """(H, W, 2) the chip's steady flow at each pixel's centre, um/s."""
    route_um: np.ndarray
    """(P, 2) the planned route."""
    route_arc_um: np.ndarray
    """(P,) arc length along the route."""
    goal_tolerance_um: float
    encounter_gap_um: float
    """An obstacle closer than this to the assembly counts as encountered."""
    escape_distance_um: float
    """The trap law's escape distance: a handle farther than this from its trap is lost."""
    tick_s: float
    sphere_body: np.ndarray
    """(S,) the body of each sphere (the order of ``/otgym/bodies`` and of ``Snapshot.sphere_xy_um``)."""
    sphere_radius_um: np.ndarray
    """(S,)"""
    robots: tuple[int, ...]
    """Body indices of the robots (robot i is ``robots[i]``)."""
    payload: int
    """Body index of the cell."""
    obstacles: tuple[int, ...]
    trap_sphere: np.ndarray
    """(T,) the sphere each trap holds."""
    trap_robot: np.ndarray
    """(T,) the body (a robot) of each trap's handle."""

    @property
    def n_traps(self) -> int:
        return len(self.trap_sphere)

    def route_index(self, cell_xy_um: np.ndarray, previous: int) -> int:
        """The route point nearest the cell, searched in the window of
        ``InteractiveTask.route_index`` around ``previous`` (progress never jumps to
        another branch of the route)."""
        window = np.clip(previous + np.arange(*ROUTE_SEARCH_POINTS), 0, len(self.route_um) - 1)
        return int(window[np.argmin(np.linalg.norm(self.route_um[window] - np.asarray(cell_xy_um, float), axis=1))])


def layout_of(task: InteractiveTask) -> TaskLayout:
    chip = task.chip
    height, width = chip.shape
    ys, xs = np.meshgrid((np.arange(height) + 0.5) * chip.pixel_size_um,
                         (np.arange(width) + 0.5) * chip.pixel_size_um, indexing="ij")
    points = np.stack([xs, ys], axis=-1).reshape(-1, 2).astype(np.float32)
    flow = np.asarray(task.scene.model.flow.velocity_um_s(jnp.asarray(points)), np.float32).reshape(height, width, 2)
    model = task.scene.model
    return TaskLayout(
        chip=chip, flow_velocity_um_s=flow, route_um=np.asarray(task.route_um, float),
        route_arc_um=np.asarray(task.route_arc_um, float), goal_tolerance_um=float(task.config.goal_tolerance_um),
        encounter_gap_um=float(task.config.encounter_gap_um),
        escape_distance_um=float(task.config.scene.trap_law.escape_distance), tick_s=float(task.config.tick_s),
        sphere_body=np.asarray(model.sphere_body, int), sphere_radius_um=np.asarray(model.sphere_radius_um, float),
        robots=tuple(int(r) for r in task.scene.robots), payload=int(task.scene.payload),
        obstacles=tuple(int(o) for o in task.scene.obstacles), trap_sphere=np.asarray(task.trap_sphere, int),
        trap_robot=np.asarray(task.trap_robot, int))
