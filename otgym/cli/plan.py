"""``otgym plan``: plan on a chip and write the paper's Table I with its figures."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.console import Console

from otgym.cli import options

# The simulator defines a pixel as fluid when its gray value is above one half; the
# planner binarises chips the same way so both agree on where the walls are.
CHIP_FLUID_THRESHOLD = 0.5


def register(app: typer.Typer) -> None:
    @app.command()
    def plan(
        chip: str = options.chip(...),
        pixel_size_um: float = typer.Option(
            None,
            "--pixel-size-um",
            min=1e-3,
            max=1e3,
            help="Pixel size in um; required for a PNG without a JSON sidecar.",
        ),
        start: str = options.point(..., "--start", "Start X,Y in um (origin top-left, y down)."),
        goal: str = options.point(..., "--goal", "Goal X,Y in um (origin top-left, y down)."),
        robot_radius_um: float = typer.Option(5.0, "--robot-radius-um", min=0.1, max=100.0, help="Robot radius in um."),
        margin_um: float = typer.Option(
            None,
            "--margin-um",
            min=0.0,
            max=100.0,
            help="Safety margin in um added to the radius (default: sqrt(2) pixels).",
        ),
        manual: Path = typer.Option(
            None,
            "--manual",
            exists=True,
            dir_okay=False,
            help="Recorded manual trajectory, CSV with columns x_um,y_um (default: a simulated human operator).",
        ),
        out: Path = options.out_dir(..., "Folder for the results."),
        seed: int = options.seed(0, "Seed of the simulated operator,"),
    ) -> None:
        """A* + B-spline path on a chip; writes path.csv, astar.csv, manual.csv, metrics.csv,
        metrics.md (Table I: manual, A*, B-spline), paths.png and spectrum.png.

        Example: otgym plan --chip default --start 15,40 --goal 285,160 --out results/plan
        """
        from otgym.human.operator import simulate_operator
        from otgym.planning.pipeline import load_path_csv, metrics_markdown, plan_path, write_plan

        start_um = options.parse_point("--start", start)
        goal_um = options.parse_point("--goal", goal)
        manual_um = load_path_csv(manual) if manual is not None else None
        loaded = load_chip_arrays(chip, pixel_size_um)
        plan = plan_path(
            loaded.image, loaded.pixel_size_um, start_um, goal_um, robot_radius_um, margin_um, CHIP_FLUID_THRESHOLD
        )
        if manual_um is None:
            manual_um = simulate_operator(plan.occupancy.planning, loaded.pixel_size_um, start_um, goal_um, seed=seed)
        metrics = write_plan(plan, manual_um, out)
        console = Console()
        console.print(
            f"[bold]otgym plan[/bold] wrote {out}/path.csv, astar.csv, manual.csv, metrics.csv, metrics.md, "
            "paths.png, spectrum.png",
            soft_wrap=True,
        )
        console.print(metrics_markdown(metrics), markup=False, soft_wrap=True)


def load_chip_arrays(name_or_png: str, pixel_size_um: float | None):
    """The chip (``.image``, ``.pixel_size_um``) from ``otgym.sim.chip``, imported here
    only, so that the planning package itself never depends on the simulator."""
    try:
        from otgym.sim.chip import load_chip
    except ImportError as error:
        raise ValueError(f"loading chips needs otgym.sim.chip, which cannot be imported here ({error})") from None
    return load_chip(name_or_png, pixel_size_um)
