"""A training sweep gives the same files run serially and as Ray tasks (same seeds, on
the CPU): the cells run the same entry point with the same arguments, and nothing in
training depends on the process or the order the cells run in."""

import json
import os
from pathlib import Path

import numpy as np
import pytest

from otgym.cluster.engine import LOCAL_NODE_IP
from tests.cluster.helpers import REPO, read_cells, write_sweep_file
from tests.otgym_cli import run_cli
from tests.rl.canonical import TRAIN_ENVS, TRAIN_STEPS


@pytest.mark.slow
def test_a_training_sweep_writes_the_same_files_serially_and_on_ray(tmp_path, monkeypatch):
    """Seed 1 of the tests' canonical training (``tests.rl.canonical``: 12800 steps x 64
    environments; the Q-network learns from step 5000 on, so its updates are compared
    too, and its chunk compiles once for all tests that train) serially in this process,
    and seeds 0 and 1 on a Ray started here with 2 workers. Compared for seed 1:
    learning_curve.png byte for byte; policy.npz array by array, bit for bit (the .npz
    container records the time it was written); training.json field by field except its
    wall time. Seed 0's policy differs from seed 1's, so each Ray cell ran its own seed.
    Fails if a seed reached the wrong cell or a worker computed anything differently."""
    monkeypatch.setenv("PYTHONPATH", str(REPO))  # the Ray workers import this checkout
    cache = os.environ.get("OTGYM_JAX_CACHE", str(Path.home() / ".cache" / "otgym" / "jax"))  # as conftest.py's
    monkeypatch.setenv("JAX_COMPILATION_CACHE_DIR", cache)
    options = {"steps": TRAIN_STEPS, "envs": TRAIN_ENVS}
    one_seed = write_sweep_file(tmp_path / "serial.toml", "train", options, {"seed": [1]})
    two_seeds = write_sweep_file(tmp_path / "ray.toml", "train", options, {"seed": [0, 1]})
    serial, ray = tmp_path / "serial", tmp_path / "ray"
    assert run_cli(["sweep", str(one_seed), "--out", str(serial), "--serial"]) == 0
    assert run_cli(["sweep", str(two_seeds), "--out", str(ray), "--workers", "2"]) == 0
    assert {row["node"] for row in read_cells(ray).values()} == {LOCAL_NODE_IP}
    cell = "seed-1"
    assert (serial / cell / "learning_curve.png").read_bytes() == (ray / cell / "learning_curve.png").read_bytes()
    with np.load(serial / cell / "policy.npz") as a, np.load(ray / cell / "policy.npz") as b:
        assert a.files == b.files and len(a.files) > 1
        for name in a.files:
            assert a[name].tobytes() == b[name].tobytes(), f"{cell}: {name}"
    summaries = [json.loads((folder / cell / "training.json").read_text()) for folder in (serial, ray)]
    for summary in summaries:
        summary.pop("wall_s")
    assert summaries[0] == summaries[1] and summaries[0]["seed"] == 1
    with np.load(ray / "seed-0" / "policy.npz") as a, np.load(ray / "seed-1" / "policy.npz") as b:
        assert any(a[name].tobytes() != b[name].tobytes() for name in a.files if name != "__meta__")
    assert json.loads((ray / "seed-0" / "training.json").read_text())["seed"] == 0
    assert (ray / "training.csv").is_file() and (ray / "learning_curves.png").is_file()
