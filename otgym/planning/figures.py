"""Figures of the paper's Fig. 5: (a) the paths over the chip, (b) their spectra.

Drawn with matplotlib's non-interactive Agg backend, so they work without a display.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (the backend must be chosen first)
import numpy as np  # noqa: E402

from otgym.planning.metrics import DEFAULT_STEP_UM, curvature_spectrum  # noqa: E402
from otgym.planning.occupancy import OccupancyMap  # noqa: E402

_STYLE = {"manual": ("tab:purple", 0.8), "A*": ("tab:red", 1.0), "B-spline": ("tab:cyan", 1.6)}


def plot_paths(out_path: str | Path, occupancy: OccupancyMap, paths: dict[str, np.ndarray]) -> None:
    """The paths over the chip: solid black, dilated margin gray, free space white."""
    height, width = occupancy.shape
    extent = (0.0, width * occupancy.pixel_size_um, height * occupancy.pixel_size_um, 0.0)
    background = 0.55 * occupancy.free + 0.45 * occupancy.planning
    fig, ax = plt.subplots(figsize=(8, 8 * height / width + 0.8), dpi=150)
    ax.imshow(background, cmap="gray", vmin=0, vmax=1, extent=extent, interpolation="nearest")
    for name, points in paths.items():
        colour, width_pt = _STYLE.get(name, ("tab:green", 1.0))
        ax.plot(points[:, 0], points[:, 1], color=colour, lw=width_pt, label=name)
    first = next(iter(paths.values()))
    ax.plot(*first[0], "o", color="tab:green", ms=6, label="start")
    ax.plot(*first[-1], "*", color="tab:orange", ms=10, label="goal")
    ax.set_xlabel("x (um)")
    ax.set_ylabel("y (um)")
    ax.set_title(f"Paths (gray: within {occupancy.clearance_um:.3g} um of a wall)")
    ax.legend(loc="best", fontsize=8)
    fig.tight_layout()
    fig.savefig(out_path)
    plt.close(fig)


def plot_spectrum(out_path: str | Path, paths: dict[str, np.ndarray], step_um: float = DEFAULT_STEP_UM) -> None:
    """Amplitude spectra of the paths' curvature against spatial frequency (log scale)."""
    fig, ax = plt.subplots(figsize=(7, 4.5), dpi=150)
    for name, points in paths.items():
        frequency, amplitude = curvature_spectrum(points, step_um)
        colour, _ = _STYLE.get(name, ("tab:green", 1.0))
        positive = amplitude > 0
        ax.loglog(frequency[1:][positive[1:]], amplitude[1:][positive[1:]], color=colour, lw=0.8, label=name)
    ax.set_xlabel("spatial frequency (cycles/um)")
    ax.set_ylabel("curvature amplitude (1/um)")
    ax.set_title(f"Curvature spectrum (paths resampled every {step_um:g} um)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(out_path)
    plt.close(fig)
