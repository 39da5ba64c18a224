"""``otgym experiment sort-cells``: bad input refused in one ``error:`` line before any
work; the shipped learned policy loads and acts on the task's observations; a tiny run
(4 paired episodes on a development seed) writes its report files, marked as a
development seed's."""

from __future__ import annotations

import json

import jax.numpy as jnp
import numpy as np
import pytest

from otgym.experiments.common import seeds
from otgym.experiments.task_report import run as task_report
from otgym.rl.network import QNetwork
from otgym.rl.policy import load_policy
from otgym.tasks.sort_cells import core
from tests.otgym_cli import run_otgym


@pytest.mark.parametrize(
    "argv, named",
    [
        (["--episodes", "0"], "--episodes"),
        (["--policy", "missing.npz"], "--policy"),
        (["--policy", "broken.npz"], "--policy"),
        (["--policy", "other.npz"], "--policy"),
    ],
)
def test_bad_input_is_one_error_line_and_nothing_is_written(tmp_path, monkeypatch, argv, named):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "broken.npz").write_bytes(b"not a policy")
    other = task_report.SHIPPED_POLICIES["orient"]  # a policy of another task: 17 observations, 5 actions
    (tmp_path / "other.npz").write_bytes(other.read_bytes())
    result = run_otgym(["experiment", "sort-cells", *argv, "--out", "out"])
    lines = result.stderr.strip().splitlines()
    assert result.returncode == 2 and len(lines) == 1 and lines[0].startswith("error:"), result.stderr
    assert named in lines[0]
    assert not (tmp_path / "out").exists()


def test_the_shipped_policy_loads_and_acts_on_the_tasks_observations():
    path = task_report.SHIPPED_POLICIES["sort-cells"]
    q_params, meta = load_policy(path, *task_report.policy_shape("sort-cells"))
    assert (meta["task"], meta["preset"], meta["seed"]) == ("sort-cells", "robots", seeds.TRAINING_SEEDS["sort-cells"])
    # two observations of the task's layout (core.observe): a small and a large target cell
    # halfway along the inlet, on the axis, not yet held; the next cell absent; 10 % elapsed
    obs = jnp.zeros((2, core.OBS_SIZE)).at[:, 0].set(1.0).at[:, 1].set(jnp.array([1.0, -1.0])).at[:, 2].set(0.5)
    obs = obs.at[:, 9].set(0.1).at[:, 10].set(0.25)
    q = QNetwork(core.N_ACTIONS, tuple(meta["hidden"])).apply(q_params, obs)
    assert q.shape == (2, core.N_ACTIONS) and np.all(np.isfinite(np.asarray(q)))
    actions = np.asarray(jnp.argmax(q, axis=-1))
    assert np.all((0 <= actions) & (actions < core.N_ACTIONS))


@pytest.mark.slow
def test_a_tiny_run_writes_its_report_files(tmp_path):
    out = tmp_path / "report"
    result = run_otgym(["experiment", "sort-cells", "--episodes", "4", "--seed", "100", "--out", out])
    assert result.returncode == 0, result.stderr
    data = json.loads((out / "results.json").read_text())
    assert data["task"] == "sort-cells" and data["episodes"] == 4 and data["seed_status"] == "development seed"
    comparison = data["comparison"]
    assert comparison["secondary"] == "throughput_cells_per_min" and comparison["episodes"] == 4
    assert comparison["table"]["both"] + comparison["table"]["baseline_only"] == comparison["baseline_successes"]
    assert set(data["baseline"]) == set(data["learned"]) >= {"mean_purity", "cells_sorted", "cells_lost"}
    summary = (out / "summary.md").read_text()
    assert summary.startswith("**development seed") and "Verdict:" in summary
