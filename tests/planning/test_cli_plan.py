"""``otgym plan``: writes the table and figures; user errors are one line, exit code 2."""

import csv

import numpy as np
import pytest
from PIL import Image

from otgym.cli.app import main
from otgym.planning.metrics import path_metrics
from otgym.planning.pipeline import load_path_csv, save_path_csv


def _run(args, capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(args)
    return exit_info.value.code, capsys.readouterr()


def _expect_error(args, capsys, *words):
    code, output = _run(args, capsys)
    error = output.err.strip()
    assert code == 2 and error.startswith("error:") and "\n" not in error and "Traceback" not in error
    for word in words:
        assert word in error
    return error


def _corridor_png(tmp_path):
    from tests.planning.conftest import corridor_image

    path = tmp_path / "corridor.png"
    Image.fromarray((corridor_image() * 255).astype(np.uint8)).save(path)
    return path


@pytest.mark.slow
def test_plan_on_the_default_chip_writes_table_and_figures(tmp_path, capsys):
    code, output = _run(
        ["plan", "--chip", "default", "--start", "5,40", "--goal", "295,160", "--out", str(tmp_path)], capsys
    )
    assert code in (0, None)
    with open(tmp_path / "metrics.csv") as handle:
        rows = list(csv.DictReader(handle))
    assert [row["path"] for row in rows] == ["manual", "A*", "B-spline"]
    lengths = [float(row["length_um"]) for row in rows]
    assert lengths[0] > lengths[1] > lengths[2]
    for name in ("path.csv", "astar.csv", "paths.png", "spectrum.png", "metrics.md"):
        assert (tmp_path / name).is_file()
    assert "B-spline" in output.out


@pytest.mark.slow
def test_plan_on_a_png_uses_the_recorded_manual_path(tmp_path, capsys):
    png = _corridor_png(tmp_path)
    manual = np.array([[8.0, 10.0], [40.0, 12.0], [70.0, 20.0], [70.0, 34.0]])
    save_path_csv(tmp_path / "manual_in.csv", manual)
    out = tmp_path / "out"
    code, _ = _run(
        [
            "plan",
            "--chip",
            str(png),
            "--pixel-size-um",
            "1",
            "--start",
            "8,10",
            "--goal",
            "70,34",
            "--robot-radius-um",
            "2",
            "--margin-um",
            "0.5",
            "--manual",
            str(tmp_path / "manual_in.csv"),
            "--out",
            str(out),
        ],
        capsys,
    )
    assert code in (0, None)
    assert np.allclose(load_path_csv(out / "manual.csv"), manual)
    with open(out / "metrics.csv") as handle:
        manual_row = next(csv.DictReader(handle))
    assert float(manual_row["length_um"]) == pytest.approx(path_metrics(manual).length_um, rel=1e-6)


def test_png_without_sidecar_needs_the_pixel_size(tmp_path, capsys):
    png = _corridor_png(tmp_path)
    _expect_error(
        ["plan", "--chip", str(png), "--start", "8,10", "--goal", "70,34", "--out", str(tmp_path)], capsys, "pixel"
    )


def test_empty_and_non_image_files(tmp_path, capsys):
    (tmp_path / "empty.png").write_bytes(b"")
    (tmp_path / "text.png").write_text("not an image")
    for name in ("empty.png", "text.png"):
        _expect_error(
            [
                "plan",
                "--chip",
                str(tmp_path / name),
                "--pixel-size-um",
                "1",
                "--start",
                "1,1",
                "--goal",
                "2,2",
                "--out",
                str(tmp_path),
            ],
            capsys,
            "image",
        )
    _expect_error(
        [
            "plan",
            "--chip",
            str(tmp_path / "missing.png"),
            "--pixel-size-um",
            "1",
            "--start",
            "1,1",
            "--goal",
            "2,2",
            "--out",
            str(tmp_path),
        ],
        capsys,
        "missing.png",
    )


@pytest.mark.parametrize(
    "extra, words",
    [
        (["--start", "150,10", "--goal", "295,160"], ("start", "inside an obstacle")),
        (["--start", "5,40", "--goal", "999,160"], ("goal", "outside the image")),
        (["--start", "5;40", "--goal", "295,160"], ("--start", "X,Y")),
        (["--start", "5,40", "--goal", "295,160", "--robot-radius-um", "30"], ("larger than every channel",)),
    ],
)
def test_bad_input_on_the_default_chip(tmp_path, capsys, extra, words):
    _expect_error(["plan", "--chip", "default", "--out", str(tmp_path), *extra], capsys, *words)
