"""``otgym chip show``: a figure of a chip's walls and flow, and its key figures."""

from __future__ import annotations

from pathlib import Path

import typer

from otgym.cli import options


def register(app: typer.Typer) -> None:
    chip_app = typer.Typer(help="Microfluidic chips: inspect their walls and flow.", no_args_is_help=True)
    app.add_typer(chip_app, name="chip")

    @chip_app.command("show")
    def show(
        chip: str = options.chip_argument("default"),
        pixel_size_um: float = typer.Option(
            None,
            "--pixel-size-um",
            min=1e-3,
            max=1e3,
            help="Pixel size in um; required for a PNG without a JSON sidecar.",
        ),
        out: Path = options.out_dir(..., "Folder for the figure."),
    ) -> None:
        """Write <out>/chip_<name>.png (signed wall distance; focal-plane flow speed with
        streamlines) and print size, channel widths and flow speeds.

        Example: otgym chip show default --out results/chip
        """
        from otgym.sim.cache import chip_fields
        from otgym.sim.chip import load_chip

        loaded = load_chip(chip, pixel_size_um)
        fields = chip_fields(loaded)
        figure = write_figure(loaded, fields, out)
        for line in key_figures(loaded, fields):
            typer.echo(line)
        typer.echo(f"figure: {figure}")


def key_figures(chip, fields) -> list[str]:
    import numpy as np

    from otgym.sim.walls import channel_widths_um

    width_um, height_um = chip.size_um
    widths = channel_widths_um(chip, fields.distance_um)
    speed = fields.mid_height_factor * np.linalg.norm(fields.flow.node_velocity_um_s(chip.fluid), axis=-1)
    corners_in_fluid = speed > 0
    lines = [
        f"chip {chip.name!r}: {width_um:g} x {height_um:g} um ({chip.shape[1]} x {chip.shape[0]} px at "
        f"{chip.pixel_size_um:g} um), channel height {chip.channel_height_um:g} um, "
        f"fluid {100 * chip.fluid.mean():.1f} % of the area",
        f"channel width (twice the wall distance along the medial axis): median {np.median(widths):.1f} um, "
        f"5-95 % {np.percentile(widths, 5):.1f}-{np.percentile(widths, 95):.1f} um",
    ]
    for port in chip.ports:
        lines.append(
            f"{port.kind} {port.name!r} at ({port.xy_um[0]:g}, {port.xy_um[1]:g}) um: {port.flow_rate_um3_s:g} um^3/s"
        )
    if corners_in_fluid.any():
        lines.append(
            f"flow speed in the focal plane (mid-height, x{fields.mid_height_factor:.3f} the depth average): "
            f"max {speed.max():.3g} um/s, mean {speed[corners_in_fluid].mean():.3g} um/s"
        )
    else:
        lines.append("flow speed: zero everywhere (no ports)")
    return lines


def write_figure(chip, fields, out: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    out.mkdir(parents=True, exist_ok=True)
    width_um, height_um = chip.size_um
    extent = (0.0, width_um, height_um, 0.0)
    velocity = fields.mid_height_factor * fields.flow.node_velocity_um_s(chip.fluid)
    speed = np.linalg.norm(velocity, axis=-1)
    figure, (walls_ax, flow_ax) = plt.subplots(1, 2, figsize=(13, 4.8 * height_um / width_um + 1.2))
    limit = np.abs(fields.distance_um).max()
    image = walls_ax.imshow(fields.distance_um, extent=extent, cmap="RdBu", vmin=-limit, vmax=limit)
    centres_x = (np.arange(chip.shape[1]) + 0.5) * chip.pixel_size_um
    centres_y = (np.arange(chip.shape[0]) + 0.5) * chip.pixel_size_um
    walls_ax.contour(centres_x, centres_y, fields.distance_um, levels=[0.0], colors="k", linewidths=0.8)
    walls_ax.set_title("signed wall distance (um, + in the fluid)")
    figure.colorbar(image, ax=walls_ax, shrink=0.8)
    shown = np.ma.masked_where(speed <= 0, speed)
    half = 0.5 * chip.pixel_size_um  # corners: the grid extends half a pixel beyond
    image = flow_ax.imshow(shown, extent=(-half, width_um + half, height_um + half, -half), cmap="viridis")
    if speed.max() > 0:
        step = max(1, int(round(2.0 / chip.pixel_size_um)))
        x = np.arange(0, velocity.shape[1], step) * chip.pixel_size_um
        y = np.arange(0, velocity.shape[0], step) * chip.pixel_size_um
        flow_ax.streamplot(
            x,
            y,
            velocity[::step, ::step, 0],
            velocity[::step, ::step, 1],
            color="w",
            linewidth=0.6,
            density=1.6,
            arrowsize=0.7,
        )
    flow_ax.set_xlim(0, width_um)
    flow_ax.set_ylim(height_um, 0)
    flow_ax.set_title("flow speed in the focal plane (um/s) and streamlines")
    figure.colorbar(image, ax=flow_ax, shrink=0.8, label="um/s")
    for axis in (walls_ax, flow_ax):
        axis.set_xlabel("x (um)")
        axis.set_ylabel("y (um)")
    figure.tight_layout()
    path = out / f"chip_{chip.name}.png"
    figure.savefig(path, dpi=130)
    plt.close(figure)
    return path
