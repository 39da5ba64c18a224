"""``otgym chip show``: figure and key figures, and user errors as one line, exit 2."""

from __future__ import annotations

import re

import numpy as np
import pytest
from conftest import straight_duct
from PIL import Image

from otgym.cli.app import main


def _run(argv):
    with pytest.raises(SystemExit) as exit_info:
        main(argv)
    return exit_info.value.code


@pytest.mark.slow
def test_show_a_chip_with_a_sidecar(tmp_path, capsys):
    from otgym.sim.chip import save_chip

    png = save_chip(straight_duct(length_um=60.0), tmp_path / "chips")
    assert _run(["chip", "show", str(png), "--out", str(tmp_path / "out")]) in (0, None)
    printed = capsys.readouterr().out
    assert "60 x 29 um" in printed
    assert abs(float(re.search(r"median ([0-9.]+) um", printed).group(1)) - 25.0) <= 0.5
    assert "max" in printed and "um/s" in printed
    assert (tmp_path / "out" / "chip_duct.png").stat().st_size > 10_000


@pytest.mark.slow
def test_bare_png_needs_a_pixel_size(tmp_path, capsys):
    path = tmp_path / "bare.png"
    Image.fromarray((straight_duct().image * 255).astype(np.uint8)).save(path)
    assert _run(["chip", "show", str(path), "--out", str(tmp_path)]) == 2
    error = capsys.readouterr().err.strip()
    assert error.startswith("error:") and "--pixel-size-um" in error and "\n" not in error
    assert _run(["chip", "show", str(path), "--pixel-size-um", "0.5", "--out", str(tmp_path)]) in (0, None)
    assert "zero everywhere" in capsys.readouterr().out


@pytest.mark.parametrize(
    "argv, message",
    [
        (["chip", "show", "no_such_chip", "--out", "x"], "no_such_chip"),
        (["chip", "show", "default", "--pixel-size-um", "-1", "--out", "x"], "--pixel-size-um must lie in"),
    ],
)
def test_user_errors_are_one_line(argv, message, capsys):
    assert _run(argv) == 2
    error = capsys.readouterr().err.strip()
    assert message in error and "\n" not in error
