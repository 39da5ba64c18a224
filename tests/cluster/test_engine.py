"""The sweep engine run serially with a stand-in command: cells of a grid, failing
cells, a stopped sweep resumed, cell folders that appear only when complete."""

import json

import pytest

from otgym.cluster import output
from otgym.cluster.engine import run_sweep
from otgym.cluster.sweep_file import load_sweep
from tests.cluster import fake_command
from tests.cluster.helpers import FAKE, fake_sweep, read_cells, write_sweep_file


def test_the_grid_gives_one_cell_per_combination_in_file_order(tmp_path):
    path = write_sweep_file(tmp_path / "s.toml", "fake", {"count": 2}, {"value": [1, 2], "fail-on": [7, 8, 9]})
    sweep = load_sweep(path, {"fake": FAKE})
    assert [cell.name for cell in sweep.cells] == [f"value-{v}_fail-on-{f}" for v in (1, 2) for f in (7, 8, 9)]
    assert sweep.cells[4].argv == ("fake", "--count", "2", "--value", "2", "--fail-on", "8")
    assert sweep.cells[4].options == {"count": 2, "value": 2, "fail-on": 8}


def test_a_failing_cell_is_marked_with_its_error_line_and_the_others_go_on(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    sweep = fake_sweep(tmp_path, {"fail-on": 2})
    run = run_sweep(sweep, out, fake_command.main, serial=True)
    assert [o.name for o in run.done] == ["value-1", "value-3"] and [o.name for o in run.failed] == ["value-2"]
    cells = read_cells(out)
    assert [cells[name]["status"] for name in ("value-1", "value-2", "value-3")] == ["done", "failed", "done"]
    assert cells["value-2"]["error"] == "error: cell 2 was told to fail" and cells["value-1"]["error"] == ""
    assert (out / "value-3" / "value.txt").read_text() == "9\n"
    assert not (out / "value-2").exists() and "told to fail" in (out / "value-2.failed.log").read_text()
    meta = json.loads((out / "value-1" / "cell.json").read_text())
    assert (
        meta["argv"] == ["fake", "--fail-on", "2", "--value", "1"]
        and "value 1: wrote 1" in (out / "value-1" / "cell.log").read_text()
    )


def test_a_stopped_sweep_resumes_with_the_cells_it_had_not_finished(tmp_path):
    """Cell 2 stops the sweep (KeyboardInterrupt, as a user's Ctrl-C): cell 1 is in
    place, cells 2 and 3 are not, cells.csv says so. Run again: only 2 and 3 run, and
    cell 1's files are those of the first run."""
    out, calls, stop = tmp_path / "out", tmp_path / "calls", tmp_path / "stop"
    out.mkdir()
    stop.touch()
    sweep = fake_sweep(tmp_path, {"stop-if": str(stop), "calls": str(calls)})
    with pytest.raises(KeyboardInterrupt):
        run_sweep(sweep, out, fake_command.main, serial=True)
    assert (out / "value-1" / "value.txt").is_file() and not (out / "value-2").exists()
    assert not list(out.glob(".partial-*"))
    assert [row["status"] for row in read_cells(out).values()] == ["done", "pending", "pending"]
    first_files = (out / "value-1" / "cell.json").stat().st_mtime_ns
    stop.unlink()
    ran_before = sorted(path.name.split("-")[0] for path in calls.iterdir())
    run = run_sweep(sweep, out, fake_command.main, serial=True)
    ran = sorted(path.name.split("-")[0] for path in calls.iterdir())
    assert ran_before == ["1", "2"] and ran == ["1", "2", "2", "3"]
    assert run.skipped == ["value-1"] and [o.name for o in run.done] == ["value-2", "value-3"]
    assert (out / "value-1" / "cell.json").stat().st_mtime_ns == first_files
    assert [row["status"] for row in read_cells(out).values()] == ["done", "done", "done"]


def test_a_partial_cell_folder_is_not_a_finished_cell(tmp_path):
    """A driver killed while it wrote a cell leaves a hidden partial folder: it does not
    count as finished, the cell runs again and the partial folder is removed."""
    out = tmp_path / "out"
    (out / ".partial-value-1-0123abcd").mkdir(parents=True)
    (out / ".partial-value-1-0123abcd" / "value.txt").write_text("half")
    sweep = fake_sweep(tmp_path, {}, values=(1,))
    run = run_sweep(sweep, out, fake_command.main, serial=True)
    assert [o.name for o in run.done] == ["value-1"] and run.skipped == []
    assert (out / "value-1" / "value.txt").read_text() == "1\n" and not list(out.glob(".partial-*"))


def test_a_folder_with_another_sweeps_cells_is_refused(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    run_sweep(fake_sweep(tmp_path, {"count": 1}, values=(1,)), out, fake_command.main, serial=True)
    with pytest.raises(ValueError, match="was made by another sweep"):
        output.check_resumable(out, fake_sweep(tmp_path, {"count": 5}, values=(1,)))
