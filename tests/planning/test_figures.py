"""Figures are written as images of the expected kind."""

import numpy as np
import pytest
from PIL import Image

from otgym.planning.figures import plot_paths, plot_spectrum
from otgym.planning.occupancy import build_occupancy


@pytest.mark.slow
def test_paths_and_spectrum_figures(tmp_path, corridor):
    occupancy = build_occupancy(corridor, 1.0, 2.0)
    x = np.linspace(5.0, 70.0, 300)
    paths = {"manual": np.column_stack((x, 10 + 0.3 * np.sin(x))), "A*": np.column_stack((x, np.full_like(x, 10.0)))}
    plot_paths(tmp_path / "paths.png", occupancy, paths)
    plot_spectrum(tmp_path / "spectrum.png", paths)
    for name in ("paths.png", "spectrum.png"):
        with Image.open(tmp_path / name) as image:
            assert image.format == "PNG" and min(image.size) > 300
