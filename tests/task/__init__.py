"""Shared helpers of the runtime tests: one ``InteractiveTask`` per test process (it
takes several seconds to build) and a fast wall-distance function.

``InteractiveTask.scenario`` samples the walls with eager ``jax.numpy`` on point
arrays whose length changes from call to call, so every new length compiles a dozen
small XLA programs: about 10 s per scenario on a 2-core machine. The tests build most
scenarios with ``make_scenario`` on the task's own route, obstacle radius and config,
through the same ``walls.distance_and_normal`` jitted on arrays padded to powers of
two; ``test_scenario`` checks once that this gives the very scenario that
``task.scenario`` gives."""

import functools

import jax
import jax.numpy as jnp
import numpy as np


@functools.lru_cache(maxsize=1)
def shared_task():
    from otgym.task.task import InteractiveTask

    return InteractiveTask()


@functools.lru_cache(maxsize=1)
def _jitted_distance():
    walls = shared_task().scene.model.walls
    return jax.jit(lambda points: walls.distance_and_normal(points)[0])


def wall_distance_um(points) -> np.ndarray:
    """Signed wall distance (um) of points (n, 2) on the task's chip, from
    ``walls.distance_and_normal`` (float32, as ``task.scenario`` evaluates it)."""
    points = np.asarray(points, np.float32).reshape(-1, 2)
    n = len(points)
    size = max(64, 1 << max(n - 1, 0).bit_length())
    padded = np.zeros((size, 2), np.float32)
    padded[:n] = points
    return np.asarray(_jitted_distance()(jnp.asarray(padded)))[:n]


def fast_scenario(seed: int, config=None):
    """``task.scenario(seed)`` (or with another ``ScenarioConfig``), built through the
    jitted wall distance."""
    from otgym.tasks.transport.scenario import make_scenario

    task = shared_task()
    return make_scenario(
        seed,
        task.route_um,
        task.route_arc_um,
        wall_distance_um,
        task.config.scene.obstacle_radius_um,
        config or task.config.scenario,
    )
