"""``otgym sweep`` on a real two-node Ray cluster on the loopback interface
(``loopback.LoopbackCluster``: head 127.0.0.2, worker 127.0.0.3, one CPU each):
cells land on both nodes, a worker node killed mid-sweep loses nothing, and no
connection of the cluster leaves 127.0.0.0/8. Each test starts its cluster and ends it
by pid. Waits are for events (nodes alive in the state API, files), with deadlines."""

import subprocess
import sys

import pytest

from tests.cluster.helpers import REPO, read_cells, write_sweep_file
from tests.cluster.loopback import (
    HEAD_IP,
    WORKER_IP,
    LoopbackCluster,
    connection_count,
    tcp_connections_outside_loopback,
    wait_for,
)

pytestmark = pytest.mark.slow


@pytest.fixture
def cluster(tmp_path):
    cluster = LoopbackCluster(tmp_path / "cluster")
    try:
        yield cluster.start()
    finally:
        cluster.stop()
        assert not cluster.pids()


def start_driver(cluster, tmp_path, options):
    sweep = write_sweep_file(tmp_path / "sweep.toml", "fake", options, {"value": [1, 2]})
    out = tmp_path / "out"
    command = [sys.executable, "-m", "tests.cluster.drive_sweep", str(sweep), str(out), cluster.address]
    log = open(tmp_path / "driver.log", "w")
    driver = subprocess.Popen(command, env=cluster.env, cwd=REPO, stdout=log, stderr=subprocess.STDOUT)
    return driver, out


def finish(driver, tmp_path):
    assert driver.wait(timeout=600) == 0, (tmp_path / "driver.log").read_text()


def stop(driver):
    """End the driver of a failed test (its cells may be waiting for a release)."""
    driver.kill()
    driver.wait(timeout=60)


def test_cells_land_on_both_nodes_and_stay_on_loopback(cluster, tmp_path):
    """Two cells that wait for each other to start (so they run at once, one per
    node's only CPU): the state API shows both running, on the two nodes; cells.csv
    names both nodes; every TCP connection of the cluster and the driver stays in
    127.0.0.0/8 (``ss -tnp``)."""
    barrier = tmp_path / "barrier"
    barrier.mkdir()
    driver, out = start_driver(cluster, tmp_path, {"barrier": str(barrier), "count": 2})
    nodes = cluster.wait_for_alive_nodes(2)
    try:
        running = wait_for(
            lambda: (
                (tasks := [t for t in cluster.state().get("tasks", []) if t["state"] == "RUNNING"])
                and len(tasks) == 2
                and tasks
            ),
            "two cells running at once",
        )
        assert {task["node_id"] for task in running} == set(nodes.values())
        pids = cluster.pids() | {driver.pid}
        assert connection_count(pids) > 0
        assert tcp_connections_outside_loopback(pids) == []
    except BaseException:
        stop(driver)
        raise
    finish(driver, tmp_path)
    cells = read_cells(out)
    assert {row["status"] for row in cells.values()} == {"done"}
    assert {row["node"] for row in cells.values()} == {HEAD_IP, WORKER_IP}
    assert {row["node_id"] for row in cells.values()} == set(nodes.values())
    assert sorted(path.name.split("@")[1] for path in barrier.iterdir()) == [HEAD_IP, WORKER_IP]
    assert tcp_connections_outside_loopback(cluster.pids()) == []


def test_a_worker_node_killed_mid_sweep_loses_no_cell(cluster, tmp_path):
    """Two held cells, one per node. The head's cell is let go; the worker node's raylet
    is killed (SIGKILL, by pid) while its cell runs. Ray reruns that cell on the head
    (seen by the rerun's own start file there), it finishes, and the sweep ends with
    both cells done and their files in place."""
    hold = tmp_path / "hold"
    hold.mkdir()
    driver, out = start_driver(cluster, tmp_path, {"hold": str(hold)})
    try:
        started = wait_for(lambda: len(files := list(hold.glob("holding-*"))) == 2 and files, "both cells to start")
        on_node = {path.name.split("@")[1]: path.name.split("@")[0].removeprefix("holding-") for path in started}
        assert set(on_node) == {HEAD_IP, WORKER_IP}
        (hold / f"release-{on_node[HEAD_IP]}").touch()
        wait_for(lambda: (out / f"value-{on_node[HEAD_IP]}").is_dir(), "the head's cell to finish")
        raylet = cluster.node_process("worker", "raylet")
        raylet.kill()
        rerun = hold / f"holding-{on_node[WORKER_IP]}@{HEAD_IP}"
        wait_for(rerun.exists, "the lost cell to start again on the head")
        (hold / f"release-{on_node[WORKER_IP]}").touch()
    except BaseException:
        stop(driver)
        raise
    finish(driver, tmp_path)
    cells = read_cells(out)
    assert {row["status"] for row in cells.values()} == {"done"}
    assert {row["node"] for row in cells.values()} == {HEAD_IP}
    for value in on_node.values():
        assert (out / f"value-{value}" / "value.txt").read_text() == f"{int(value) ** 2}\n"
