"""The fastest passage along the planned route that a scenario's obstacles allow: a
bound on what any controller that keeps the assembly on the route can achieve.

Shared control in the paper (and in ``otgym.runtime.trials``) keeps the carried
assembly on the planned route: the person and the autonomy change its speed, and
side-steps are small in 25 um channels. For such a controller the obstacles of a
scenario are known functions of time (``Scenario.position_um``: they follow their
tracks whatever the assembly does, unless it pushes them), so the earliest arrival
is a shortest-time problem on the route's arc s and time t: the classical
path-velocity decomposition of motion planning among moving obstacles (Kant &
Zucker, IJRR 5(3), 72, 1986), solved here exactly on a grid. A cell (s, t) is
blocked when the assembly, in its gripped formation posed on the route at arc s
(turned with the route's heading), comes within ``margin_um`` of an obstacle's
surface at time t. From the start the reachable set grows each time step by at most
``max_speed_um_s`` times the step in either direction (speed changes are free: an
overdamped assembly has no inertia) and loses its blocked cells; the first time it
holds the goal arc is the earliest arrival. A clairvoyant follower limited to
``max_speed_um_s`` can do no better (up to one grid step), a person who only sees
the obstacles' motion cannot either, so the gap between this bound and the
unobstructed time ``(L - s_0) / v`` is time that any route-keeping control must lose
on that scenario. Left out: lateral offsets from the route's centre line (side-steps),
and the obstacles' deviations from their scheduled tracks (Brownian jitter about the
track, pushes by the assembly), so on the simulator the bound is close, not exact.
"""

from __future__ import annotations

import dataclasses
import itertools

import numpy as np
from scipy.spatial import cKDTree

from otgym.tasks.transport.scenario import Scenario


@dataclasses.dataclass(frozen=True)
class AssemblyShape:
    """The carried assembly's spheres in the route frame (x along the route, y to its
    left), relative to the cell's centre: ``offsets_um`` (P, 2), ``radii_um`` (P,)."""

    offsets_um: np.ndarray
    radii_um: np.ndarray


def task_assembly_shape(task) -> AssemblyShape:
    """The assembly (both robots and the cell) of an ``InteractiveTask`` as it is
    gripped at the route's start, in the route frame."""
    from otgym import physics as ph

    heading = float(task.params.heading_rad)
    gripped = task.params.gripped
    xy = np.asarray(ph.sphere_positions_um(task.scene.model, gripped.physics.pose), float)
    bodies = np.asarray(task.scene.model.sphere_body)
    payload = np.flatnonzero(bodies <= task.scene.payload)
    cell = np.asarray(gripped.physics.pose[task.scene.payload, :2], float)
    c, s = np.cos(-heading), np.sin(-heading)
    relative = (xy[payload] - cell) @ np.array([[c, -s], [s, c]]).T
    return AssemblyShape(relative, np.asarray(task.scene.model.sphere_radius_um, float)[payload])


def _route_poses(route_um, route_arc_um, arcs_um):
    """Points (A, 2) and headings (A,) of the route at ``arcs_um``."""
    x = np.interp(arcs_um, route_arc_um, route_um[:, 0])
    y = np.interp(arcs_um, route_arc_um, route_um[:, 1])
    step = 0.5
    ahead = np.stack([np.interp(arcs_um + step, route_arc_um, route_um[:, i]) for i in range(2)], axis=-1)
    behind = np.stack([np.interp(arcs_um - step, route_arc_um, route_um[:, i]) for i in range(2)], axis=-1)
    tangent = ahead - behind
    return np.stack([x, y], axis=-1), np.arctan2(tangent[:, 1], tangent[:, 0])


_TIMES_PER_CHUNK = 64
"""Time steps whose blocked arcs are found in one vectorised pass."""


def _blocked(obstacles_um, route_points: cKDTree, spheres_um, reach_limit_um, reach_any_um) -> np.ndarray:
    """(T, A): whether the assembly posed at arc a (spheres (A, P, 2) about the route
    points of the tree) comes within ``reach_limit_um`` (P,) of any obstacle (T, K, 2)
    at time t. Only (arc, obstacle) pairs whose route point is within ``reach_any_um``
    of the obstacle (a k-d tree's ball query) are measured sphere by sphere."""
    n_times, n_obstacles = obstacles_um.shape[:2]
    near = route_points.query_ball_point(obstacles_um.reshape(-1, 2), reach_any_um)
    counts = np.fromiter(map(len, near), int, len(near))
    a = np.fromiter(itertools.chain.from_iterable(near), int, int(counts.sum()))
    t, k = np.divmod(np.repeat(np.arange(len(near)), counts), n_obstacles)
    distance = np.linalg.norm(spheres_um[a] - obstacles_um[t, k][:, None], axis=-1)  # (n, P)
    touching = np.any(distance < reach_limit_um, axis=-1)
    blocked = np.zeros((n_times, route_points.n), bool)
    blocked[t[touching], a[touching]] = True
    return blocked


@dataclasses.dataclass(frozen=True)
class Passage:
    """The earliest arrival at the goal arc (``arrival_s``, inf if none within the
    limit) and the unobstructed one at the same speed limit (``free_s``)."""

    arrival_s: float
    free_s: float

    @property
    def lost_s(self) -> float:
        return self.arrival_s - self.free_s


def earliest_passage(
    scenario: Scenario,
    route_um,
    route_arc_um,
    shape: AssemblyShape,
    obstacle_radius_um: float,
    start_arc_um: float,
    start_time_s: float,
    max_speed_um_s: float,
    margin_um: float = 0.0,
    goal_arc_um: float | None = None,
    arc_step_um: float = 0.25,
    time_limit_s: float = 300.0,
) -> Passage:
    """The earliest time the assembly, starting at ``start_arc_um`` at
    ``start_time_s`` and moving along the route (M, 2; cumulative arc (M,)) at speeds up
    to ``max_speed_um_s`` either way, reaches ``goal_arc_um`` (default: the route's
    end) without coming within ``margin_um`` of an obstacle of ``scenario`` (module
    docstring). Grid: ``arc_step_um`` by the time the speed limit takes for it (one
    arc step a time step at most, so the speed limit is exact); the time is exact to
    about two time steps."""
    if not (max_speed_um_s > 0 and arc_step_um > 0 and time_limit_s > start_time_s):
        raise ValueError("need positive max_speed_um_s and arc_step_um, and time_limit_s > start_time_s")
    time_step_s = arc_step_um / max_speed_um_s
    route_um, route_arc_um = np.asarray(route_um, float), np.asarray(route_arc_um, float)
    goal_arc_um = float(route_arc_um[-1] if goal_arc_um is None else goal_arc_um)
    arcs = np.arange(start_arc_um, goal_arc_um + arc_step_um, arc_step_um)
    points, heading = _route_poses(route_um, route_arc_um, arcs)
    c, s = np.cos(heading), np.sin(heading)
    offsets = np.asarray(shape.offsets_um, float)
    spheres = points[:, None] + np.stack(
        [
            c[:, None] * offsets[:, 0] - s[:, None] * offsets[:, 1],
            s[:, None] * offsets[:, 0] + c[:, None] * offsets[:, 1],
        ],
        axis=-1,
    )  # (A, P, 2)
    reach_limit = np.asarray(shape.radii_um, float) + obstacle_radius_um + margin_um  # (P,)
    # an obstacle farther than this from an arc's route point touches none of its spheres
    # (triangle inequality; the slack covers round-off), so only pairs closer are measured
    reach_any = float(np.max(np.linalg.norm(offsets, axis=-1) + reach_limit)) + 1e-6
    free_s = start_time_s + (goal_arc_um - start_arc_um) / max_speed_um_s
    reached = np.zeros(len(arcs), bool)
    reached[0] = True
    times = np.arange(start_time_s, time_limit_s + time_step_s, time_step_s)
    route_points = cKDTree(points)
    for first in range(0, len(times), _TIMES_PER_CHUNK):
        chunk = times[first : first + _TIMES_PER_CHUNK]
        blocked = _blocked(scenario.position_um(chunk), route_points, spheres, reach_limit, reach_any)  # (T, A)
        for time_s, blocked_now in zip(chunk, blocked):
            reached &= ~blocked_now
            if reached[-1]:
                return Passage(float(time_s), float(free_s))
            # one time step of motion: an arc step either way, or none
            reached = reached | np.concatenate([[False], reached[:-1]]) | np.concatenate([reached[1:], [False]])
    return Passage(float("inf"), float(free_s))
