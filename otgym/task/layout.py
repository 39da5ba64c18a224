"""What a view of the interactive task needs to know about it, as plain numpy arrays
(``TaskLayout``): the chip, its flow sampled at the pixel centres, the planned route,
which sphere belongs to which body, the traps' handles and beams. It is built once from an
``InteractiveTask`` (``layout_of``) where the task lives and handed to a window in
another process (it pickles: no JAX arrays inside), so the window never builds the
task (seconds of work beside the simulation's own build)."""

from __future__ import annotations

import dataclasses

import jax.numpy as jnp
import numpy as np

from otgym.physics.light_dose import TrapBeam
from otgym.sim.chip import Chip
from otgym.task.task import ROUTE_SEARCH_POINTS, InteractiveTask, Observation


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
    trap_beam: TrapBeam
    """Each trap's beam (``otgym.physics.light_dose``), for the cell's light dose."""
    cell_radius_um: float

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
    ys, xs = np.meshgrid(
        (np.arange(height) + 0.5) * chip.pixel_size_um, (np.arange(width) + 0.5) * chip.pixel_size_um, indexing="ij"
    )
    points = np.stack([xs, ys], axis=-1).reshape(-1, 2).astype(np.float32)
    flow = np.asarray(task.scene.model.flow.velocity_um_s(jnp.asarray(points)), np.float32).reshape(height, width, 2)
    model = task.scene.model
    return TaskLayout(
        chip=chip,
        flow_velocity_um_s=flow,
        route_um=np.asarray(task.route_um, float),
        route_arc_um=np.asarray(task.route_arc_um, float),
        goal_tolerance_um=float(task.config.goal_tolerance_um),
        encounter_gap_um=float(task.config.encounter_gap_um),
        escape_distance_um=float(task.config.scene.trap_law.escape_distance),
        tick_s=float(task.config.tick_s),
        sphere_body=np.asarray(model.sphere_body, int),
        sphere_radius_um=np.asarray(model.sphere_radius_um, float),
        robots=tuple(int(r) for r in task.scene.robots),
        payload=int(task.scene.payload),
        obstacles=tuple(int(o) for o in task.scene.obstacles),
        trap_sphere=np.asarray(task.trap_sphere, int),
        trap_robot=np.asarray(task.trap_robot, int),
        trap_beam=TrapBeam.of_trap_law(task.config.scene.trap_law),
        cell_radius_um=float(task.config.scene.cell_radius_um),
    )


def observation_from_spheres(
    layout: TaskLayout, sphere_xy_um, trap_xy_um, phase: int, time_s: float, route_index: int
) -> tuple[Observation, int]:
    """One environment's ``Observation`` rebuilt from what a simulator publishes
    (every sphere's centre (S, 2) in ``layout.sphere_body`` order, the traps (T, 2), the
    phase, the time in the trial) and the new route index: the cell, robots and
    obstacles at their spheres' mean, handles at the trapped spheres, each obstacle's
    gap to the assembly's spheres as the task measures it. The robot-cell contact force
    and gripper gap, which are not published, are NaN."""
    spheres = np.asarray(sphere_xy_um, float)
    traps = np.asarray(trap_xy_um, float)
    bodies, radius = layout.sphere_body, layout.sphere_radius_um
    cell = spheres[bodies == layout.payload].mean(axis=0)
    route_index = layout.route_index(cell, route_index)
    obstacle_spheres = [np.flatnonzero(bodies == obstacle) for obstacle in layout.obstacles]
    obstacles = np.array([spheres[s].mean(axis=0) for s in obstacle_spheres]).reshape(-1, 2)
    obstacle_radius = np.array([radius[s].max() for s in obstacle_spheres])
    assembly = np.isin(bodies, (*layout.robots, layout.payload))
    between = np.linalg.norm(spheres[assembly][:, None] - obstacles[None], axis=-1)
    gaps = (between - radius[assembly][:, None] - obstacle_radius[None]).min(axis=0, initial=np.inf)
    handles = spheres[layout.trap_sphere]
    n_robots = len(layout.robots)
    observation = Observation(
        time_s=np.array([time_s], float),
        phase=np.array([phase]),
        cell_xy_um=cell[None],
        cell_arc_um=np.array([layout.route_arc_um[route_index]]),
        trap_xy_um=traps[None],
        handle_xy_um=handles[None],
        robot_xy_um=np.array([spheres[bodies == robot].mean(axis=0) for robot in layout.robots])[None],
        obstacle_xy_um=obstacles[None],
        obstacle_gap_um=gaps[None],
        contact_force_pn=np.full((1, n_robots), np.nan),
        cell_gap_um=np.full((1, n_robots), np.nan),
        trap_distance_um=np.linalg.norm(handles - traps, axis=-1)[None],
    )
    return observation, route_index
