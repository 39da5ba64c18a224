"""Path planning (numpy/scipy/scikit-image/numba): the paper's section II-C and Table I.

Chip image -> binary map -> obstacles dilated by robot radius + margin -> 8-connected
A* with octile costs -> collision-free B-spline smoothing, plus the path metrics of
Table I, and a formation of traps carried along a path (``formation``, JAX).
Coordinates are um with the origin at the image's top-left corner, x right (column *
pixel size), y down (row * pixel size), pixel centres at +0.5 pixel.

Table I's manual row comes from the caller (a recorded trajectory, or the simulated
operator of ``otgym.human.operator``): planning imports nothing of otgym above it.
"""

from otgym.planning.astar import astar
from otgym.planning.collision import segments_free
from otgym.planning.metrics import (
    PathMetrics,
    curvature_spectrum,
    path_length,
    path_metrics,
    resample_by_arc_length,
)
from otgym.planning.occupancy import OccupancyMap, binarise, build_occupancy, dilate_obstacles, pixels_to_um
from otgym.planning.pipeline import (
    TABLE_ROWS,
    PlanResult,
    load_path_csv,
    metrics_markdown,
    plan_path,
    save_path_csv,
    table_metrics,
    write_plan,
)
from otgym.planning.smoothing import smooth_path, string_pull

__all__ = [
    "TABLE_ROWS",
    "OccupancyMap",
    "PathMetrics",
    "PlanResult",
    "astar",
    "binarise",
    "build_occupancy",
    "curvature_spectrum",
    "dilate_obstacles",
    "load_path_csv",
    "metrics_markdown",
    "path_length",
    "path_metrics",
    "pixels_to_um",
    "plan_path",
    "resample_by_arc_length",
    "save_path_csv",
    "segments_free",
    "smooth_path",
    "string_pull",
    "table_metrics",
    "write_plan",
]
