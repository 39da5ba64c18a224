"""The environment axis split over several devices (``otgym.physics.sharding``) gives the
one-device results. Run on the CPU with two host devices
(``XLA_FLAGS=--xla_force_host_platform_device_count=2``, which must be set before JAX
starts, hence a fresh process per device count: ``sharded_rollouts.py``).

Per-environment results are bitwise equal: each environment's arithmetic is the same
elementwise code on either device, and JAX's partitionable threefry PRNG gives every
element of a draw the same value however the draw is split. Sums over environments
(the training's return and loss per iteration) may be added in another order when split,
so they are held to float32 round-off (they too came out bitwise when this was written).
"""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]
SUMS_OVER_ENVIRONMENTS = ("train_return_sum", "train_loss")


def run_rollouts(tmp_path: Path, devices: int, parts: list[str]) -> dict:
    out = tmp_path / f"devices{devices}.npz"
    env = dict(os.environ, PYTHONPATH=str(REPO), XLA_FLAGS=f"--xla_force_host_platform_device_count={devices}")
    env.setdefault("JAX_COMPILATION_CACHE_DIR", str(Path.home() / ".cache" / "otgym" / "jax"))
    subprocess.run(
        [sys.executable, "-m", "tests.experiments.sharded_rollouts", str(out), *parts],
        cwd=REPO,
        env=env,
        check=True,
        timeout=3600,
    )
    with np.load(out) as data:
        return {name: data[name] for name in data.files}


def check_same(tmp_path, parts):
    one, two = run_rollouts(tmp_path, 1, parts), run_rollouts(tmp_path, 2, parts)
    for part in parts:  # fails if nothing was split: the sharding would be a no-op
        assert one[f"devices_{part}"] == 1 and two[f"devices_{part}"] == 2, part
    arrays = [name for name in one if not name.startswith("devices_")]
    assert arrays and sorted(arrays) == sorted(name for name in two if not name.startswith("devices_"))
    for name in arrays:
        if name in SUMS_OVER_ENVIRONMENTS:
            np.testing.assert_allclose(two[name], one[name], rtol=2e-6, atol=1e-6, err_msg=name)
        else:
            assert two[name].tobytes() == one[name].tobytes(), f"{name} differs when split over 2 devices"


@pytest.mark.slow
def test_physics_rollout_split_over_two_devices_is_bitwise_the_one_device_rollout(tmp_path):
    """Four environments, four control steps of 20 substeps with moving traps."""
    check_same(tmp_path, ["physics"])


@pytest.mark.slow
def test_training_and_evaluation_split_over_two_devices_match_one_device(tmp_path):
    """Two chunks of DQN training (4 environments, learning from iteration 16) and an
    evaluation rollout of 2 episodes x 2 policies on the paper preset."""
    check_same(tmp_path, ["training", "evaluation"])
