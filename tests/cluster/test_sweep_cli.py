"""``otgym sweep`` from the command line: a bad sweep file or bad options end in one
``error:`` line with exit code 2 before anything is written; without Ray it says so
(or runs with --serial); a failing cell makes the sweep exit 1 with a one-line summary."""

import pytest

from tests.cluster.helpers import read_cells, write_sweep_file
from tests.otgym_cli import run_cli


def one_error_line(capsys) -> str:
    error = capsys.readouterr().err.strip()
    assert error.startswith("error:") and "\n" not in error, error
    return error


@pytest.mark.parametrize(
    "text, message",
    [
        ('command = "trian"\n', "unknown command 'trian'"),
        ('command = "demo-x"\n[grid]\nseed = [1]\n', "unknown command 'demo-x'"),
        ('command = "train"\n[options]\nsead = 1\n', "'train' has no option 'sead' (its options: envs, preset"),
        (
            'command = "train"\n[grid]\nsteps = [100, "many"]\n',
            "option 'steps' of 'train' takes an integer, got 'many'",
        ),
        ('command = "train"\n[options]\nseed = 1.5\n', "option 'seed' of 'train' takes an integer, got 1.5"),
        ('command = "train"\n[options]\nsteps = true\n', "option 'steps' of 'train' takes an integer, got True"),
        ('command = "train"\n[options]\npreset = 3\n', "option 'preset' of 'train' takes a string, got 3"),
        (
            'command = "experiment shared-control"\n[grid]\ntime-limit-s = ["long"]\n',
            "option 'time-limit-s' of 'experiment shared-control' takes a number",
        ),
        ('command = "train"\n[options]\nout = "x"\n', "'out' is set by the sweep"),
        ('command = "train"\n[grid]\nseed = []\n', "grid option 'seed' must be a non-empty list"),
        ('command = "train"\n[grid]\nseed = 3\n', "grid option 'seed' must be a non-empty list"),
        ('command = "train"\n[options]\nseed = 1\n[grid]\nseed = [2]\n', "both fixed in [options] and varied"),
        ('command = "train"\n[grid]\nseed = [1, 1]\n', "two cells would share the folder 'seed-1'"),
        ('command = "train"\ncolour = "red"\n', "unknown key 'colour'"),
        ("[grid]\nseed = [1]\n", "give the command to run"),
        ('command = "train"\n[options\n', "is not valid TOML"),
        ('command = "sweep"\n', "unknown command 'sweep'"),
    ],
)
def test_a_bad_sweep_file_is_one_line_and_writes_nothing(tmp_path, capsys, text, message):
    path = tmp_path / "sweep.toml"
    path.write_text(text)
    out = tmp_path / "out"
    assert run_cli(["sweep", str(path), "--out", str(out), "--serial"]) == 2
    error = one_error_line(capsys)
    assert message in error and str(path) in error
    assert not out.exists()


@pytest.mark.parametrize(
    "extra, message",
    [
        (["--serial", "--address", "auto"], "--serial runs without Ray"),
        (["--workers", "0"], "--workers must lie in [1, 1024], not 0"),
        (["--workers", "2", "--address", "auto"], "only sizes a Ray started here"),
        (["--cpus-per-cell", "0"], "--cpus-per-cell must lie in [0.01, 1024.0], not 0"),
    ],
)
def test_bad_sweep_options_are_one_line_and_write_nothing(tmp_path, capsys, extra, message):
    path = write_sweep_file(tmp_path / "sweep.toml", "train", {"steps": 100}, {"seed": [0, 1]})
    out = tmp_path / "out"
    assert run_cli(["sweep", str(path), "--out", str(out), *extra]) == 2
    assert message in one_error_line(capsys) and not out.exists()


def test_a_missing_sweep_file_is_one_line(tmp_path, capsys):
    assert run_cli(["sweep", str(tmp_path / "none.toml"), "--out", str(tmp_path / "out")]) == 2
    assert "does not exist" in one_error_line(capsys) and not (tmp_path / "out").exists()


def test_without_ray_the_sweep_says_so_in_one_line(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr("otgym.cluster.engine.ray_available", lambda: False)
    path = write_sweep_file(tmp_path / "sweep.toml", "train", {"steps": 100}, {"seed": [0, 1]})
    assert run_cli(["sweep", str(path), "--out", str(tmp_path / "out")]) == 2
    error = one_error_line(capsys)
    assert "Ray is not installed" in error and "--serial" in error and not (tmp_path / "out").exists()


def test_failing_cells_end_the_sweep_with_exit_1_and_one_summary_line(tmp_path, capsys):
    """Two cells whose preset does not exist (they fail at once, before any training):
    both marked failed with the command's own error line, exit code 1."""
    path = write_sweep_file(tmp_path / "sweep.toml", "train", {"steps": 100}, {"preset": ["nope", "none"]})
    out = tmp_path / "out"
    assert run_cli(["sweep", str(path), "--out", str(out), "--serial"]) == 1
    error = one_error_line(capsys)
    assert error.startswith(
        "error: 2 of 2 cells failed (preset-nope: error: --preset must be one of paper, realistic, not 'nope'"
    )
    cells = read_cells(out)
    assert (
        cells["preset-none"]["status"] == "failed"
        and "--preset must be one of paper, realistic, not 'none'" in cells["preset-none"]["error"]
    )
