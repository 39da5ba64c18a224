"""A sweep's own Ray (``--workers N``, no ``--address``) is started by the sweep whatever
Ray state the machine holds: a ``RAY_ADDRESS`` in the environment and the cluster Ray
recorded in its temporary folder (what ``ray start`` and a later ``ray stop`` leave
behind) both name a cluster that is gone, and the sweep still runs every cell on a Ray of
its own. The recorded cluster lives in a temporary folder of the test's (``RAY_TMPDIR``),
so the test neither reads nor changes the machine's ``/tmp/ray``."""

import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

from otgym.cluster.engine import LOCAL_NODE_IP
from tests.cluster.helpers import REPO, read_cells, write_sweep_file
from tests.cluster.loopback import HEAD_IP, free_port

pytestmark = pytest.mark.slow

DRIVER_DEADLINE_S = 600


@pytest.fixture
def ray_tmpdir():
    # Ray's socket paths grow under this folder and must stay under 108 bytes (AF_UNIX)
    folder = Path(tempfile.mkdtemp(prefix="otgym-ray-", dir="/tmp"))
    try:
        yield folder
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def test_a_sweep_starts_its_own_ray_when_a_recorded_cluster_is_gone(tmp_path, ray_tmpdir):
    gone = f"{HEAD_IP}:{free_port(HEAD_IP)}"  # a GCS address nothing listens on
    (ray_tmpdir / "ray").mkdir()
    (ray_tmpdir / "ray" / "ray_current_cluster").write_text(gone + "\n")
    env = dict(os.environ, PYTHONPATH=str(REPO), RAY_TMPDIR=str(ray_tmpdir), RAY_ADDRESS=gone, JAX_PLATFORMS="cpu")
    env["RAY_USAGE_STATS_ENABLED"] = "0"
    sweep = write_sweep_file(tmp_path / "sweep.toml", "fake", {}, {"value": [1, 2, 3]})
    out = tmp_path / "out"
    command = [sys.executable, "-m", "tests.cluster.drive_sweep", str(sweep), str(out), "here:2"]
    driver = subprocess.run(
        command, env=env, cwd=REPO, capture_output=True, text=True, timeout=DRIVER_DEADLINE_S, check=False
    )
    assert driver.returncode == 0, driver.stdout + driver.stderr
    cells = read_cells(out)
    assert {name: row["status"] for name, row in cells.items()} == {f"value-{v}": "done" for v in (1, 2, 3)}
    assert {row["node"] for row in cells.values()} == {LOCAL_NODE_IP}
    assert [(out / f"value-{v}" / "value.txt").read_text() for v in (1, 2, 3)] == ["1\n", "4\n", "9\n"]
    assert (ray_tmpdir / "ray" / "ray_current_cluster").read_text().strip() == gone  # ours left as it was
