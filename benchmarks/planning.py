"""Planning benchmark: our A* and B-spline smoothing against scikit-image and pyastar2d.

Maps: a 1000 x 1000 map with 25 % random obstacles (seed 1, corners connected),
planned corner to corner, and the default chip (``otgym.sim``) dilated for a 5 um
robot, planned from inlet to the opposite outlet. For each map it prints the best of
``--repeats`` wall times of

* otgym A* (numba; its one-off compile/cache-load time is printed separately),
* otgym smoothing (string pulling + B-spline + collision check),
* scikit-image ``MCP_Geometric`` (the reference: a Dijkstra search of the same
  8-connected graph with octile costs),
* ``pyastar2d`` with diagonal moves, if it is installed,

with the ratio of each time to scikit-image's and each path's length relative to the
optimal (scikit-image's) cost. Target: A* <= 25 ms on the 1000 x 1000 map, optimal.

    python benchmarks/planning.py [--repeats 7]
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np
from skimage.graph import MCP_Geometric

from otgym.planning.astar import astar
from otgym.planning.maps import random_obstacle_map
from otgym.planning.metrics import path_length
from otgym.planning.occupancy import build_occupancy, pixels_to_um
from otgym.planning.smoothing import smooth_path


def best_time(function, repeats):
    times = []
    for _ in range(repeats):
        begin = time.perf_counter()
        result = function()
        times.append(time.perf_counter() - begin)
    return min(times), result


def grid_length(path) -> float:
    steps = np.abs(np.diff(np.asarray(path), axis=0))
    return float(np.sum(np.where(steps.sum(axis=1) == 2, math.sqrt(2.0), 1.0)))


def mcp(free, start, goal):
    graph = MCP_Geometric(np.where(free, 1.0, np.inf))
    costs, _ = graph.find_costs([start], [goal])
    return costs[goal]


def pyastar2d_runner():
    try:
        import pyastar2d
    except ImportError:
        return None

    def run(free, start, goal):
        weights = np.where(free, 1.0, np.inf).astype(np.float32)
        return pyastar2d.astar_path(weights, start, goal, allow_diagonal=True)

    return run


def benchmark(name, free, start, goal, pixel_size_um, repeats):
    print(
        f"\n{name}: {free.shape[0]}x{free.shape[1]} pixels, {100 * (1 - free.mean()):.1f} % blocked, {start} -> {goal}"
    )
    rows = []
    t_astar, (path, cost) = best_time(lambda: astar(free, start, goal), repeats)
    t_mcp, optimal = best_time(lambda: mcp(free, start, goal), max(1, repeats // 3))
    rows.append(("otgym A* (numba)", t_astar, cost))
    rows.append(("scikit-image MCP_Geometric", t_mcp, optimal))
    runner = pyastar2d_runner()
    if runner is None:
        print("  pyastar2d: unavailable (pip install pyastar2d to compare)")
    else:
        t_py, py_path = best_time(lambda: runner(free, start, goal), repeats)
        rows.append(("pyastar2d (diagonal)", t_py, grid_length(py_path)))
    path_um = pixels_to_um(path, pixel_size_um)
    t_smooth, smooth = best_time(lambda: smooth_path(path_um, free, pixel_size_um), repeats)
    print(f"  {'method':<30} {'time ms':>9} {'vs skimage':>11} {'length/optimal':>15}")
    for label, seconds, length in rows:
        print(f"  {label:<30} {1e3 * seconds:9.2f} {seconds / t_mcp:11.3f} {length / optimal:15.6f}")
    ratio = path_length(smooth) / (optimal * pixel_size_um)
    print(f"  {'otgym smoothing (B-spline)':<30} {1e3 * t_smooth:9.2f} {'':>11} {ratio:15.6f}  ({len(smooth)} points)")
    return t_astar, cost / optimal


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()

    begin = time.perf_counter()
    astar(np.ones((2, 2), dtype=bool), (0, 0), (1, 1))
    smooth_path(np.array([[0.5, 0.5], [1.5, 1.5], [2.5, 1.5]]), np.ones((3, 3), dtype=bool), 1.0)
    print(f"numba compile or cache load (first calls): {time.perf_counter() - begin:.2f} s")

    free = random_obstacle_map((1000, 1000), 0.25, seed=1)
    t_astar, optimality = benchmark("random 25 %", free, (0, 0), (999, 999), 1.0, args.repeats)
    verdict = "met" if t_astar <= 0.025 and abs(optimality - 1) <= 1e-6 else "NOT met"
    print(f"  target (A* <= 25 ms and optimal): {verdict}")

    try:
        from otgym.sim.chip import load_chip
    except ImportError:
        print("\ndefault chip: otgym.sim is unavailable, skipped")
        return
    chip = load_chip("default")
    occupancy = build_occupancy(chip.image, chip.pixel_size_um, robot_radius_um=5.0, threshold=0.5)
    start = occupancy.require_free((5.0, 40.0), "start")
    goal = occupancy.require_free((295.0, 160.0), "goal")
    benchmark("default chip (5 um robot)", occupancy.planning, start, goal, chip.pixel_size_um, args.repeats)


if __name__ == "__main__":
    main()
