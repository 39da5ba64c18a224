"""The "Write your own task" tutorial (docs/tutorial-own-task.md) as a user runs it: its
package ``examples/push_bead`` is pip-installed into a temporary folder (never into the
test's environment), and with that folder on ``PYTHONPATH`` fresh processes find the
task by its ``otgym.tasks`` entry point: ``otgym list tasks`` names it, ``gymnasium.make
("otgym/push-bead-v0")`` passes Gymnasium's ``check_env`` (and SB3's, where
stable-baselines3 is installed), ``otgym train --task push-bead`` trains one chunk and
``otgym play --task push-bead`` plays one second (in an X window on the ``xvfb``
fixture's server where Xvfb is installed, else with SDL's dummy drivers) and draws the
chip.

Slow: the install and each process's JAX start and compile (read back from the
persistent cache after the first run)."""

from __future__ import annotations

import csv
import importlib.util
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from otgym.sim.render import CHANNEL_RGB

pytestmark = [pytest.mark.slow, pytest.mark.xdist_group("tutorial")]

REPO = Path(__file__).resolve().parents[2]
EXAMPLE = REPO / "examples" / "push_bead"
TIMEOUT_S = 900


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    """The tutorial's package installed into a folder of its own (built from a copy, so
    no build files land in the repository)."""
    root = tmp_path_factory.mktemp("tutorial")
    source = root / "push_bead"
    shutil.copytree(EXAMPLE, source, ignore=shutil.ignore_patterns("build", "*.egg-info", "__pycache__"))
    target = root / "site"
    subprocess.run(
        [sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--no-build-isolation", "--target", target, source],
        check=True,
        capture_output=True,
        timeout=TIMEOUT_S,
    )
    assert (target / "push_bead.py").is_file()
    return target


def run(site: Path | None, argv: list[str], cwd: Path, base_env: dict | None = None) -> subprocess.CompletedProcess:
    """``python ARGV`` in a fresh process, otgym from this repository and ``site`` (if
    given) on its path; ``base_env``: its environment before that (default: this one's)."""
    env = dict(os.environ if base_env is None else base_env)
    env["PYTHONPATH"] = os.pathsep.join([*([str(site)] if site else []), str(REPO)])
    return subprocess.run([sys.executable, *argv], cwd=cwd, env=env, capture_output=True, text=True, timeout=TIMEOUT_S)


def test_otgym_list_tasks_shows_the_installed_task_and_only_then(site, tmp_path):
    listed = run(site, ["-m", "otgym", "list", "tasks"], tmp_path)
    assert listed.returncode == 0, listed.stderr
    line = next((row for row in listed.stdout.splitlines() if row.startswith("push-bead ")), None)
    assert line is not None, listed.stdout
    assert "Carry one trapped bead" in line  # the first line of the class's docstring
    without = run(None, ["-m", "otgym", "list", "tasks"], tmp_path)
    assert without.returncode == 0 and "push-bead" not in without.stdout


GYM_CHECK = """
import json, sys, warnings
import gymnasium
import otgym  # registers every task's Gymnasium id
for checker in sys.argv[1:]:
    env = gymnasium.make("otgym/push-bead-v0")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        if checker == "gymnasium":
            from gymnasium.utils.env_checker import check_env
            check_env(env.unwrapped, skip_render_check=True)
        else:
            from stable_baselines3.common.env_checker import check_env
            check_env(env.unwrapped, warn=True)
    obs, _ = env.reset(seed=0)
    steps, done = 0, False
    while not done:
        obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
        steps, done = steps + 1, terminated or truncated
    print("report: " + json.dumps({"checker": checker, "spec": env.spec.id, "space": str(env.action_space),
                                   "obs": len(obs), "steps": steps,
                                   "warnings": [f"{w.filename}: {w.message}" for w in caught]}), flush=True)
"""


def _sb3_usable() -> bool:
    """Both installed; found, not imported: every xdist worker collects this module, and
    torch takes seconds to import (the check itself runs in a child process)."""
    return all(importlib.util.find_spec(name) is not None for name in ("stable_baselines3", "torch"))


@pytest.fixture(scope="module")
def checks(site, tmp_path_factory) -> dict[str, dict]:
    """Gymnasium's ``check_env`` and then (where it is installed) SB3's, each on a fresh
    environment from ``gymnasium.make``, then an episode of random actions: one fresh
    process runs both, one after the other (a user's process that imports otgym and
    Gymnasium once), and prints a report per checker."""
    checkers = ["gymnasium"] + (["sb3"] if _sb3_usable() else [])
    result = run(site, ["-c", GYM_CHECK, *checkers], tmp_path_factory.mktemp("checks"))
    assert result.returncode == 0, result.stderr[-3000:]
    reports = [
        json.loads(line.removeprefix("report: ")) for line in result.stdout.splitlines() if line.startswith("report: ")
    ]
    assert [report["checker"] for report in reports] == checkers, result.stdout[-3000:]
    return {report["checker"]: report for report in reports}


def test_gymnasium_make_and_check_env(checks):
    report = checks["gymnasium"]
    assert report["spec"] == "otgym/push-bead-v0" and report["space"] == "Discrete(5)" and report["obs"] == 5
    assert 1 <= report["steps"] <= 60  # an episode ends by the task's own limit
    assert _unexpected(report["warnings"]) == []


UNBOUNDED = "A Box observation space m"
"""Gymnasium's warning about a Box with infinite bounds, the observation space every
task gets from ``Task.observation_space`` by design (otgym's observations are scaled
to order one, not clipped); any other warning fails."""


def _unexpected(warnings: list[str]) -> list[str]:
    return [w for w in warnings if UNBOUNDED not in w]


@pytest.mark.skipif(not _sb3_usable(), reason="needs stable-baselines3 and torch (pip install '.[sb3]')")
def test_stable_baselines3_check_env(checks):
    report = checks["sb3"]
    assert report["spec"] == "otgym/push-bead-v0" and _unexpected(report["warnings"]) == []


def test_otgym_train_trains_one_chunk(site, tmp_path):
    result = run(
        site,
        ["-m", "otgym", "train", "--task", "push-bead", "--steps", "200", "--envs", "2", "--out", "train"],
        tmp_path,
    )
    assert result.returncode == 0, result.stderr[-3000:]
    summary = json.loads((tmp_path / "train" / "training.json").read_text())
    assert summary["task"] == "push-bead" and summary["env_steps"] == 200 and summary["n_actions"] == 5
    assert (tmp_path / "train" / "policy.npz").stat().st_size > 0


def test_otgym_play_plays_one_second(site, tmp_path, request):
    from tests.xserver import available

    xvfb = request.getfixturevalue("xvfb") if available() else None  # a real X window where Xvfb is installed
    argv = ["-m", "otgym", "play", "--task", "push-bead", "--duration", "1", "--out", "play"]
    argv += ["--screenshot", "play/shot.png"] + ([] if xvfb else ["--headless"])
    result = run(site, argv, tmp_path, xvfb.env() if xvfb else None)
    assert result.returncode == 0, result.stderr[-3000:]
    with open(tmp_path / "play" / "episodes.csv") as handle:
        rows = list(csv.DictReader(handle))
    assert sum(int(row["steps"]) for row in rows) == 10  # 1 s of 0.1 s steps
    assert rows[-1]["ended_by"] in ("stopped", "terminated", "truncated")
    from otgym.record.mcap_file import read_recording
    from otgym.record.replay import summary

    recorded = summary(read_recording(tmp_path / "play" / "session.mcap"))["task"]  # the session's recording
    assert (recorded["task"], recorded["episodes"]) == ("push-bead", len(rows))
    import pygame

    shot = pygame.surfarray.array3d(pygame.image.load(tmp_path / "play" / "shot.png"))
    channel = np.all(shot == CHANNEL_RGB.astype(np.uint8), axis=-1).mean()  # the chip's channel, drawn
    assert 0.1 < channel < 0.9, channel
