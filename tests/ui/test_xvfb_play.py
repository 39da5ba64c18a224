"""``otgym play --task NAME`` for every registered task (``otgym list tasks``) in a real
X window: one Xvfb (the ``xvfb`` fixture), SDL's x11 video driver, one second of play
each with its screenshot. One test plays them all, in this process one after another
(``tests.otgym_cli.run_otgym``: the command as a user runs it, without a fresh
interpreter importing JAX for each task).

Checked per task: the command succeeds and says it played; a window titled
``otgym play --task NAME`` was viewable on the X server while it ran (a thread of its
own watches the server's windows: a window that never reached X fails here); the
episodes table and the recording agree; the screenshot's picture is not blank and
its status lines have text. Slow: every task's build and compile (read back from
JAX's persistent cache after the first run). The pictures of docs/tasks.md are these
screenshots, looked at."""

from __future__ import annotations

import csv

import numpy as np
import pytest

from otgym import registry
from tests.otgym_cli import run_otgym

pytestmark = pytest.mark.slow

DURATION_S = 1.0


def test_every_task_plays_one_second_in_an_x_window(xvfb, tmp_path, monkeypatch):
    import pygame

    from otgym.record.mcap_file import read_recording
    from otgym.record.replay import summary
    from otgym.ui.palette import TEXT_RGB
    from otgym.ui.task_window import FRAME_SIZE
    from tests.xserver import WindowWatcher

    pytest.importorskip("Xlib", reason="needs python-xlib (the test extra) to watch the X server's windows")

    for name, value in xvfb.env({}).items():
        monkeypatch.setenv(name, value)
    monkeypatch.delenv("XAUTHORITY", raising=False)
    tasks = registry.names("tasks")
    assert {"speed-control", "cell-transport", "sort-cells", "assemble", "orient"} <= set(tasks)
    played = {}
    with WindowWatcher(xvfb.display) as watcher:
        for task in tasks:
            out = tmp_path / task
            result = run_otgym(
                ["play", "--task", task, "--duration", DURATION_S, "--out", out, "--screenshot", out / "shot.png"]
            )
            assert result.returncode == 0, (task, result.stdout[-2000:], result.stderr[-3000:])
            played[task] = result.stdout
    for task in tasks:
        out = tmp_path / task
        assert f"otgym play --task {task}" in watcher.titles, (task, watcher.titles)
        steps = int(played[task].split(f" steps of {task},")[0].split()[-1])
        assert steps >= 1, played[task]
        with open(out / "episodes.csv") as handle:
            rows = list(csv.DictReader(handle))
        assert sum(int(row["steps"]) for row in rows) == steps, (task, rows)
        recorded = summary(read_recording(out / "session.mcap"))["task"]
        assert (recorded["task"], recorded["episodes"]) == (task, len(rows))
        shot = pygame.surfarray.array3d(pygame.image.load(out / "shot.png")).swapaxes(0, 1)
        picture, status = shot[: FRAME_SIZE[1]], shot[FRAME_SIZE[1] :]
        assert len(np.unique(picture.reshape(-1, 3), axis=0)) > 2, f"{task}: a blank picture"
        assert np.all(status == np.asarray(TEXT_RGB, np.uint8), axis=-1).sum() > 100, f"{task}: no status text"
