"""``otgym sweep`` on a real two-node Ray cluster on the loopback interface
(``loopback.LoopbackCluster``: head 127.0.0.2, worker 127.0.0.3, one CPU each):
cells land on both nodes, a worker node killed mid-sweep loses nothing, and no
connection of the cluster leaves 127.0.0.0/8. One cluster (started, then ended by pid)
runs both sweeps, the one that kills a worker node last. Waits are for events (nodes
alive in the state API, files), with deadlines."""

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


def watching(driver, tmp_path, cluster, condition):
    """``condition`` that raises as soon as the driver or (unless ``cluster`` is None) a
    node has exited instead."""

    def check():
        if driver.poll() is not None:
            raise RuntimeError("the sweep's driver exited early:\n" + (tmp_path / "driver.log").read_text())
        if cluster is not None:
            cluster.check_running()
        return condition()

    return check


def running_cells(cluster):
    tasks = [task for task in cluster.state().get("tasks", []) if task["state"] == "RUNNING"]
    return len(tasks) == 2 and tasks


def finish(driver, tmp_path):
    assert driver.wait(timeout=600) == 0, (tmp_path / "driver.log").read_text()


def stop(driver):
    """End the driver of a failed test (its cells may be waiting for a release)."""
    driver.kill()
    driver.wait(timeout=60)


def test_cells_land_on_both_nodes_stay_on_loopback_and_survive_a_killed_worker_node(cluster, tmp_path):
    """The two sweeps below on one cluster (its start is most of either's cost): the
    second kills the worker node, so it runs last."""
    cells_land_on_both_nodes_and_stay_on_loopback(cluster, tmp_path / "both")
    a_worker_node_killed_mid_sweep_loses_no_cell(cluster, tmp_path / "killed")


def cells_land_on_both_nodes_and_stay_on_loopback(cluster, tmp_path):
    """Two cells that hold until released, so they run at once, one per node's only
    CPU: once both have started, the state API shows both running, on the two nodes,
    and every TCP connection of the cluster and the driver is in 127.0.0.0/8
    (``ss -tnp``); released, they finish and cells.csv names both nodes."""
    hold = tmp_path / "hold"
    hold.mkdir(parents=True)
    driver, out = start_driver(cluster, tmp_path, {"hold": str(hold)})
    nodes = cluster.wait_for_alive_nodes(2)
    try:
        started = wait_for(
            watching(driver, tmp_path, cluster, lambda: len(files := list(hold.glob("holding-*"))) == 2 and files),
            "both cells to start",
        )
        assert sorted(path.name.split("@")[1] for path in started) == [HEAD_IP, WORKER_IP]
        running = wait_for(watching(driver, tmp_path, cluster, lambda: running_cells(cluster)), "the state API")
        assert {task["node_id"] for task in running} == set(nodes.values())
        pids = cluster.pids() | {driver.pid}
        assert connection_count(pids) > 0
        assert tcp_connections_outside_loopback(pids) == []
        for value in (1, 2):
            (hold / f"release-{value}").touch()
    except BaseException:
        stop(driver)
        raise
    finish(driver, tmp_path)
    cells = read_cells(out)
    assert {row["status"] for row in cells.values()} == {"done"}
    assert {row["node"] for row in cells.values()} == {HEAD_IP, WORKER_IP}
    assert {row["node_id"] for row in cells.values()} == set(nodes.values())
    assert tcp_connections_outside_loopback(cluster.pids()) == []


def a_worker_node_killed_mid_sweep_loses_no_cell(cluster, tmp_path):
    """Two held cells, one per node. The head's cell is let go; the worker node's raylet
    is killed (SIGKILL, by pid) while its cell runs. Ray reruns that cell on the head
    (seen by the rerun's own start file there), it finishes, and the sweep ends with
    both cells done and their files in place."""
    hold = tmp_path / "hold"
    hold.mkdir(parents=True)
    driver, out = start_driver(cluster, tmp_path, {"hold": str(hold)})
    try:
        started = wait_for(
            watching(driver, tmp_path, cluster, lambda: len(files := list(hold.glob("holding-*"))) == 2 and files),
            "both cells to start",
        )
        on_node = {path.name.split("@")[1]: path.name.split("@")[0].removeprefix("holding-") for path in started}
        assert set(on_node) == {HEAD_IP, WORKER_IP}
        (hold / f"release-{on_node[HEAD_IP]}").touch()
        wait_for(
            watching(driver, tmp_path, cluster, (out / f"value-{on_node[HEAD_IP]}").is_dir),
            "the head's cell to finish",
        )
        raylet = cluster.node_process("worker", "raylet")
        raylet.kill()
        rerun = hold / f"holding-{on_node[WORKER_IP]}@{HEAD_IP}"
        wait_for(watching(driver, tmp_path, None, rerun.exists), "the lost cell to start again on the head")
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
