"""The environment axis split over several devices (``otgym.physics.sharding``) gives the
one-device results. Run on the CPU with two host devices
(``XLA_FLAGS=--xla_force_host_platform_device_count=2``, which must be set before JAX
starts, hence a fresh process: ``sharded_rollouts.py``). That one process computes every
part on one device (no mesh: the programs of a one-device process) and then split over
both devices.

Per-environment results are bitwise equal at these sizes (4 physics environments, 64
training, 4 evaluation): JAX's partitionable threefry PRNG gives every element of a draw
the same value however the draw is split. Not at every size: an evaluation of 32
environments split 16/16 differed by round-off (up to 1.8e-4 pN), so these sizes are
the claim, not a general one (docs/cluster.md). Sums over environments
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
PARTS = ["physics", "training", "evaluation"]

pytestmark = [pytest.mark.slow, pytest.mark.xdist_group("sharded_rollouts")]  # one worker runs the process once


@pytest.fixture(scope="module")
def rollouts(tmp_path_factory) -> tuple[dict, dict]:
    """Every part's arrays on one device and split over two, from one fresh process."""
    out = tmp_path_factory.mktemp("sharded")
    env = dict(os.environ, PYTHONPATH=str(REPO), XLA_FLAGS="--xla_force_host_platform_device_count=2")
    env.setdefault("JAX_COMPILATION_CACHE_DIR", str(Path.home() / ".cache" / "otgym" / "jax"))
    subprocess.run(
        [sys.executable, "-m", "tests.experiments.sharded_rollouts", str(out), *PARTS],
        cwd=REPO,
        env=env,
        check=True,
        timeout=3600,
    )
    loaded = []
    for devices in (1, 2):
        with np.load(out / f"devices{devices}.npz") as data:
            loaded.append({name: data[name] for name in data.files})
    return loaded[0], loaded[1]


def check_same(rollouts, parts):
    one, two = rollouts
    for part in parts:  # fails if nothing was split: the sharding would be a no-op
        assert one[f"devices_{part}"] == 1 and two[f"devices_{part}"] == 2, part
    prefixes = tuple({"physics": "physics_", "training": "train_", "evaluation": "eval_"}[part] for part in parts)
    arrays = [name for name in one if name.startswith(prefixes)]
    assert arrays and sorted(arrays) == sorted(name for name in two if name.startswith(prefixes))
    for name in arrays:
        if name in SUMS_OVER_ENVIRONMENTS:
            np.testing.assert_allclose(two[name], one[name], rtol=2e-6, atol=1e-6, err_msg=name)
        else:
            assert two[name].tobytes() == one[name].tobytes(), f"{name} differs when split over 2 devices"


def test_physics_rollout_split_over_two_devices_is_bitwise_the_one_device_rollout(rollouts):
    """Four environments, four control steps of 20 substeps with moving traps."""
    check_same(rollouts, ["physics"])


def test_training_and_evaluation_split_over_two_devices_match_one_device(rollouts):
    """Two chunks of DQN training (the tests' canonical configuration, ``tests.rl.canonical``:
    64 environments, the Q-network learning from the 79th of 200 iterations) and an
    evaluation rollout of 2 episodes x 2 policies on the paper preset."""
    check_same(rollouts, ["training", "evaluation"])
