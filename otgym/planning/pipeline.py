"""End to end: chip image -> A* path -> smoothed path -> Table I of the paper.

The paper's planning pipeline (section II-C): grayscale image -> binarisation ->
dilation by the robot's radius plus a margin -> image-to-physical coordinates -> A*
with eight directions -> B-spline smoothing. ``plan_path`` runs it on any chip image
(a numpy array with its pixel size; a chip object gives ``chip.image`` and
``chip.pixel_size_um``). ``write_plan`` takes a plan and the manual path (a recorded
trajectory, or the simulated operator's that the caller made with
``otgym.human.operator.simulate_operator``) and writes the paper's Table I with its
figures.

Coordinates everywhere: um, origin at the image's top-left corner, x right
(column * pixel size), y down (row * pixel size), pixel centres at +0.5 pixel.
"""

from __future__ import annotations

import csv
import dataclasses
from pathlib import Path

import numpy as np

from otgym.planning.astar import astar
from otgym.planning.metrics import DEFAULT_STEP_UM, PathMetrics, path_metrics
from otgym.planning.occupancy import OccupancyMap, build_occupancy, pixels_to_um
from otgym.planning.smoothing import smooth_path

TABLE_ROWS = ("manual", "A*", "B-spline")
TABLE_COLUMNS = (
    ("Total path length (um)", "length_um"),
    ("Mean curvature (1/um)", "mean_curvature_per_um"),
    ("Angular deviation (deg)", "angular_deviation_deg"),
)


@dataclasses.dataclass(frozen=True)
class PlanResult:
    """A planned path: the A* polyline and its smoothed, densely resampled version (um)."""

    occupancy: OccupancyMap
    astar_um: np.ndarray
    smoothed_um: np.ndarray
    astar_cost_px: float


def plan_path(
    image: np.ndarray,
    pixel_size_um: float,
    start_um,
    goal_um,
    robot_radius_um: float = 5.0,
    margin_um: float | None = None,
    threshold: float | str = "otsu",
    step_um: float | None = None,
) -> PlanResult:
    """Plan from ``start_um`` to ``goal_um`` (x, y in um) on a chip image.

    ``image``: grayscale (channels bright) or a boolean free mask. The obstacles are
    dilated by ``robot_radius_um + margin_um`` (margin default: sqrt(2) pixels, see
    ``occupancy``). The A* path runs from the exact start through pixel centres to the
    exact goal; the smoothed path is sampled every ``step_um`` (default a quarter
    pixel). Raises ``ValueError`` naming the problem for a start or goal outside the
    image or in an obstacle, an unreachable goal, or a robot too large for every
    channel.
    """
    occupancy = build_occupancy(image, pixel_size_um, robot_radius_um, margin_um, threshold)
    start_px = occupancy.require_free(start_um, "start")
    goal_px = occupancy.require_free(goal_um, "goal")
    try:
        pixels, cost = astar(occupancy.planning, start_px, goal_px)
    except ValueError:
        raise ValueError(
            f"goal {tuple(goal_um)} um is not reachable from start {tuple(start_um)} um for a robot of radius "
            f"{robot_radius_um:g} um plus margin (clearance {occupancy.clearance_um:g} um): "
            "every route passes a gap narrower than the robot"
        ) from None
    astar_um = np.vstack(
        (np.asarray(start_um, float), pixels_to_um(pixels, occupancy.pixel_size_um), np.asarray(goal_um, float))
    )
    smoothed = smooth_path(astar_um, occupancy.planning, occupancy.pixel_size_um, step_um=step_um)
    return PlanResult(occupancy=occupancy, astar_um=astar_um, smoothed_um=smoothed, astar_cost_px=cost)


def load_path_csv(path: str | Path) -> np.ndarray:
    """A recorded trajectory: CSV with a header containing ``x_um`` and ``y_um``."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"trajectory file {str(path)!r} does not exist")
    with open(path, newline="") as handle:
        reader = csv.DictReader(handle)
        if reader.fieldnames is None or not {"x_um", "y_um"} <= set(reader.fieldnames):
            raise ValueError(f"trajectory file {str(path)!r} needs a header with columns x_um,y_um")
        try:
            points = np.array([[float(row["x_um"]), float(row["y_um"])] for row in reader])
        except (TypeError, ValueError):
            raise ValueError(f"trajectory file {str(path)!r} has a row that is not two numbers") from None
    if points.shape[0] < 2 or not np.all(np.isfinite(points)):
        raise ValueError(f"trajectory file {str(path)!r} needs at least two finite points")
    return points


def save_path_csv(path: str | Path, points_um: np.ndarray) -> None:
    """Write a path as CSV with columns x_um,y_um."""
    np.savetxt(path, points_um, delimiter=",", header="x_um,y_um", comments="", fmt="%.6f")


def table_metrics(paths: dict[str, np.ndarray], step_um: float = DEFAULT_STEP_UM) -> dict[str, PathMetrics]:
    """Table I metrics of each named path, all computed at the same resampling step."""
    return {name: path_metrics(points, step_um) for name, points in paths.items()}


def metrics_markdown(metrics: dict[str, PathMetrics], step_um: float = DEFAULT_STEP_UM) -> str:
    """Table I as a markdown table (rows in the paper's order)."""
    lines = [
        "| Trajectory type | " + " | ".join(title for title, _ in TABLE_COLUMNS) + " |",
        "|---|" + "---:|" * len(TABLE_COLUMNS),
    ]
    for name, row in metrics.items():
        lines.append(f"| {name} | " + " | ".join(f"{getattr(row, field):.5g}" for _, field in TABLE_COLUMNS) + " |")
    lines.append("")
    lines.append(
        f"Curvature and angular deviation on paths resampled every {step_um:g} um (see otgym.planning.metrics)."
    )
    return "\n".join(lines) + "\n"


def write_metrics_csv(path: str | Path, metrics: dict[str, PathMetrics]) -> None:
    fields = [field.name for field in dataclasses.fields(PathMetrics)]
    with open(path, "w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["path", *fields])
        for name, row in metrics.items():
            writer.writerow([name, *(f"{getattr(row, field):.8g}" for field in fields)])


def write_plan(plan: PlanResult, manual_um: np.ndarray, out_dir: str | Path) -> dict[str, PathMetrics]:
    """Table I of ``plan`` beside the manual path ``manual_um`` ((n, 2) um): writes
    ``path.csv`` (smoothed), ``astar.csv``, ``manual.csv``, ``metrics.csv``,
    ``metrics.md``, ``paths.png`` and ``spectrum.png`` into ``out_dir``."""
    paths = dict(zip(TABLE_ROWS, (manual_um, plan.astar_um, plan.smoothed_um)))
    metrics = table_metrics(paths)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    save_path_csv(out_dir / "path.csv", plan.smoothed_um)
    save_path_csv(out_dir / "astar.csv", plan.astar_um)
    save_path_csv(out_dir / "manual.csv", manual_um)
    write_metrics_csv(out_dir / "metrics.csv", metrics)
    (out_dir / "metrics.md").write_text(metrics_markdown(metrics))
    from otgym.planning.figures import plot_paths, plot_spectrum  # matplotlib: imported where a figure is drawn

    plot_paths(out_dir / "paths.png", plan.occupancy, paths)
    plot_spectrum(out_dir / "spectrum.png", paths)
    return metrics
