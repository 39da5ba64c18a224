"""End to end on the default chip: the ordering of the paper's Table I, and clear errors."""

import numpy as np
import pytest

from otgym.planning.collision import segments_free
from otgym.planning.pipeline import (
    TABLE_ROWS,
    load_path_csv,
    metrics_markdown,
    plan_path,
    save_path_csv,
    table_metrics,
    write_plan,
)

START, GOAL = (5.0, 40.0), (295.0, 160.0)


@pytest.fixture(scope="module")
def chip_plan(default_chip):
    return plan_path(default_chip.image, default_chip.pixel_size_um, START, GOAL, threshold=0.5)


def test_smoothed_path_is_free_and_beats_astar_on_every_table_metric(chip_plan):
    occupancy = chip_plan.occupancy
    assert segments_free(occupancy.planning, chip_plan.smoothed_um / occupancy.pixel_size_um).all()
    assert chip_plan.astar_cost_px > 0
    metrics = table_metrics({"A*": chip_plan.astar_um, "B-spline": chip_plan.smoothed_um})
    astar_row, spline_row = metrics["A*"], metrics["B-spline"]
    assert spline_row.length_um < astar_row.length_um
    assert spline_row.mean_curvature_per_um < astar_row.mean_curvature_per_um
    assert spline_row.angular_deviation_deg < astar_row.angular_deviation_deg
    assert spline_row.hf_curvature_rms_per_um < astar_row.hf_curvature_rms_per_um


@pytest.mark.slow
def test_table_has_the_paper_ordering_with_the_simulated_operator(default_chip, tmp_path):
    from otgym.human.operator import simulate_operator

    plan = plan_path(default_chip.image, default_chip.pixel_size_um, START, GOAL, threshold=0.5)
    manual_um = simulate_operator(plan.occupancy.planning, default_chip.pixel_size_um, START, GOAL)
    metrics = write_plan(plan, manual_um, tmp_path)
    assert tuple(metrics) == TABLE_ROWS
    for field in ("length_um", "mean_curvature_per_um", "angular_deviation_deg"):
        values = [getattr(metrics[row], field) for row in TABLE_ROWS]
        assert values[0] > values[1] > values[2], field
    for name in ("path.csv", "astar.csv", "manual.csv", "metrics.csv", "metrics.md", "paths.png", "spectrum.png"):
        assert (tmp_path / name).stat().st_size > 0
    assert np.allclose(load_path_csv(tmp_path / "path.csv")[[0, -1]], [START, GOAL])
    table = (tmp_path / "metrics.md").read_text()
    assert [line.split("|")[1].strip() for line in table.splitlines()[2:5]] == list(TABLE_ROWS)


@pytest.mark.parametrize(
    "start, goal, message",
    [
        ((-5.0, 40.0), GOAL, "start .* outside the image"),
        (START, (150.0, 10.0), "goal .* inside an obstacle"),
        (START, (150.0, 72.0), "goal .* inside an obstacle"),  # a pillar
        ((5.0, 30.0), GOAL, "start .* closer to a wall"),
    ],
)
def test_bad_start_or_goal(default_chip, start, goal, message):
    with pytest.raises(ValueError, match=message):
        plan_path(default_chip.image, default_chip.pixel_size_um, start, goal, threshold=0.5)


def test_unreachable_goal_and_too_large_robot():
    image = np.zeros((40, 60))
    image[5:35, 2:25] = 1.0
    image[5:35, 35:58] = 1.0  # two separate chambers
    with pytest.raises(ValueError, match="not reachable"):
        plan_path(image, 1.0, (10.0, 20.0), (50.0, 20.0), robot_radius_um=2.0)
    with pytest.raises(ValueError, match="larger than every channel"):
        plan_path(image, 1.0, (10.0, 20.0), (15.0, 20.0), robot_radius_um=20.0)


def test_trajectory_csv_round_trip_and_errors(tmp_path):
    points = np.array([[0.0, 1.5], [2.25, 3.0], [4.0, 4.0]])
    save_path_csv(tmp_path / "p.csv", points)
    assert np.allclose(load_path_csv(tmp_path / "p.csv"), points)
    (tmp_path / "cols.csv").write_text("x,y\n1,2\n3,4\n")
    with pytest.raises(ValueError, match="x_um,y_um"):
        load_path_csv(tmp_path / "cols.csv")
    (tmp_path / "text.csv").write_text("x_um,y_um\n1,a\n3,4\n")
    with pytest.raises(ValueError, match="not two numbers"):
        load_path_csv(tmp_path / "text.csv")
    (tmp_path / "short.csv").write_text("x_um,y_um\n1,2\n")
    with pytest.raises(ValueError, match="at least two"):
        load_path_csv(tmp_path / "short.csv")
    with pytest.raises(FileNotFoundError):
        load_path_csv(tmp_path / "missing.csv")


def test_markdown_lists_rows_in_order():
    line = np.array([[0.0, 0.0], [1.0, 0.0]])
    text = metrics_markdown(table_metrics({"manual": line, "A*": line, "B-spline": line}))
    assert "| manual | 1 | 0 | 0 |" in text and text.index("A*") < text.index("B-spline")
