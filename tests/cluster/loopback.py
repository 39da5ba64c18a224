"""A two-node Ray cluster on this machine's loopback interface, for the cluster tests.

Ray rewrites 127.0.0.1 and localhost in a cluster address to the machine's outward IP,
so each node gets a loopback address of its own: the head 127.0.0.2, the worker
127.0.0.3, one CPU each. Every port Ray opens is chosen here (the GCS port outside
Ray's worker port range 10002-19999, each node's workers in a range of their own), and
each node runs as ``ray start --block``, so all its processes (GCS, raylet, agents,
workers) descend from one process this module started and are ended by pid, never by
a global ``ray stop``. Token authentication with a token made for the test.
"""

from __future__ import annotations

import ipaddress
import json
import os
import secrets
import shutil
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import psutil

from tests.cluster.helpers import REPO

HEAD_IP, WORKER_IP = "127.0.0.2", "127.0.0.3"
POLL_S = 0.5
STARTUP_DEADLINE_S = 600.0


_HANDED_OUT: set[int] = set()
"""Ports this process has handed out: nothing listens on them until Ray starts, so a
later draw must not take one again (Ray refuses to start two components on one port)."""


def free_port(ip: str, low: int = 20000, high: int = 29999) -> int:
    """A TCP port in [low, high] that nothing listens on at ``ip`` now and that this
    process has not handed out before."""
    for _ in range(200):
        port = secrets.randbelow(high - low) + low
        if port in _HANDED_OUT:
            continue
        with socket.socket() as probe:
            try:
                probe.bind((ip, port))
            except OSError:
                continue
            _HANDED_OUT.add(port)
            return port
    raise RuntimeError(f"no free port in {low}-{high} on {ip}")


def wait_for(condition, what: str, deadline_s: float = STARTUP_DEADLINE_S):
    """Poll ``condition()`` until it returns something true; its value."""
    deadline = time.monotonic() + deadline_s
    while True:
        value = condition()
        if value:
            return value
        if time.monotonic() > deadline:
            raise TimeoutError(f"gave up waiting for {what}")
        time.sleep(POLL_S)


class LoopbackCluster:
    def __init__(self, root: Path):
        self.root = Path(root)
        self.root.mkdir(parents=True, exist_ok=True)
        self.port = free_port(HEAD_IP)
        self.address = f"{HEAD_IP}:{self.port}"
        self.env = dict(
            os.environ,
            PYTHONPATH=str(REPO),
            RAY_AUTH_MODE="token",
            RAY_AUTH_TOKEN=secrets.token_hex(32),
            RAY_USAGE_STATS_ENABLED="0",
            JAX_PLATFORMS="cpu",
        )
        self.processes: dict[str, subprocess.Popen] = {}
        # Ray's socket paths grow under its temp dir and must stay under 108 bytes (AF_UNIX)
        self.ray_temp = tempfile.mkdtemp(prefix="otgym-ray-", dir="/tmp")

    def _node_ports(self, ip: str, workers: tuple[int, int]) -> list[str]:
        ports = {
            "--node-manager-port": free_port(ip),
            "--object-manager-port": free_port(ip),
            "--metrics-export-port": free_port(ip),
            "--dashboard-agent-listen-port": free_port(ip),
            "--dashboard-agent-grpc-port": free_port(ip),
            "--runtime-env-agent-port": free_port(ip),
        }
        arguments = [item for flag, port in ports.items() for item in (flag, str(port))]
        return arguments + ["--min-worker-port", str(workers[0]), "--max-worker-port", str(workers[1])]

    def _start(self, name: str, arguments: list[str]) -> None:
        log = open(self.root / f"{name}.log", "w")
        command = [sys.executable, "-m", "ray.scripts.scripts", "start", "--block", "--num-cpus", "1", *arguments]
        self.processes[name] = subprocess.Popen(command, env=self.env, stdout=log, stderr=subprocess.STDOUT, cwd=REPO)

    def start(self) -> LoopbackCluster:
        self._start(
            "head",
            [
                "--head",
                "--node-ip-address",
                HEAD_IP,
                "--port",
                str(self.port),
                "--ray-client-server-port",
                str(free_port(HEAD_IP)),
                "--dashboard-host",
                HEAD_IP,
                "--dashboard-port",
                str(free_port(HEAD_IP)),
                "--temp-dir",
                self.ray_temp,
                "--disable-usage-stats",
                *self._node_ports(HEAD_IP, (11000, 11999)),
            ],
        )
        self.wait_for_alive_nodes(1)
        self._start(
            "worker",
            [
                "--address",
                self.address,
                "--node-ip-address",
                WORKER_IP,
                "--disable-usage-stats",
                *self._node_ports(WORKER_IP, (12000, 12999)),
            ],
        )
        self.wait_for_alive_nodes(2)
        return self

    def state(self) -> dict:
        """Nodes and cell tasks from Ray's state API (in a subprocess); {} if it did not answer."""
        result = subprocess.run(
            [sys.executable, "-m", "tests.cluster.cluster_state", self.address],
            env=self.env,
            cwd=REPO,
            capture_output=True,
            text=True,
            timeout=300,
        )
        lines = result.stdout.strip().splitlines()
        return json.loads(lines[-1]) if result.returncode == 0 and lines else {}

    def alive_nodes(self) -> dict:
        """IP address -> node id of the nodes the state API lists as alive."""
        nodes = self.state().get("nodes", [])
        return {node["node_ip"]: node["node_id"] for node in nodes if node["state"] == "ALIVE"}

    def check_running(self) -> None:
        """Raise if a node's ``ray start --block`` has exited (it stays up while its node does)."""
        for name, process in self.processes.items():
            if process.poll() is not None:
                raise RuntimeError(f"ray start of the {name} exited: see {self.root / (name + '.log')}")

    def wait_for_alive_nodes(self, count: int) -> dict:
        def alive():
            self.check_running()
            nodes = self.alive_nodes()
            return len(nodes) == count and nodes

        return wait_for(alive, f"{count} alive nodes")

    def pids(self) -> set[int]:
        """Every live process of the cluster (the ``ray start`` processes and their descendants)."""
        found = set()
        for process in self.processes.values():
            try:
                parent = psutil.Process(process.pid)
                found |= {parent.pid} | {child.pid for child in parent.children(recursive=True)}
            except psutil.NoSuchProcess:
                pass
        return found

    def node_process(self, name: str, process_name: str) -> psutil.Process:
        """The process called ``process_name`` (e.g. ``raylet``) of node ``name``."""
        parent = psutil.Process(self.processes[name].pid)
        return next(child for child in parent.children(recursive=True) if child.name() == process_name)

    def stop(self) -> None:
        """End every process of the cluster by pid: SIGTERM, then SIGKILL what is left."""
        processes = []
        for pid in self.pids():
            try:
                processes.append(psutil.Process(pid))
            except psutil.NoSuchProcess:
                pass
        for process in processes:
            try:
                process.terminate()
            except psutil.NoSuchProcess:
                pass
        _, alive = psutil.wait_procs(processes, timeout=5)  # some of Ray's processes ignore SIGTERM
        for process in alive:
            try:
                process.kill()
            except psutil.NoSuchProcess:
                pass
        psutil.wait_procs(alive, timeout=30)
        for process in self.processes.values():
            process.wait(timeout=30)
        shutil.rmtree(self.ray_temp, ignore_errors=True)


def tcp_connections_outside_loopback(pids: set[int]) -> list[str]:
    """Lines of ``ss -tnp`` (established TCP connections with their processes) of the
    processes ``pids`` whose local or peer address is outside 127.0.0.0/8."""
    listing = subprocess.run(["ss", "-tnp"], capture_output=True, text=True, check=True).stdout
    outside = []
    for line in listing.splitlines()[1:]:
        fields = line.split()
        if len(fields) < 6 or "pid=" not in line:
            continue
        owners = {int(part.split(",")[0]) for part in line.split("pid=")[1:]}
        if not owners & pids:
            continue
        for endpoint in fields[3:5]:
            host = endpoint.rsplit(":", 1)[0].strip("[]")
            host = host.removeprefix("::ffff:")
            if not ipaddress.ip_address(host).is_loopback:
                outside.append(line)
                break
    return outside


def connection_count(pids: set[int]) -> int:
    """Established TCP connections of ``pids`` in ``ss -tnp`` (to check the check sees some)."""
    listing = subprocess.run(["ss", "-tnp"], capture_output=True, text=True, check=True).stdout
    return sum(
        1
        for line in listing.splitlines()[1:]
        if "pid=" in line and {int(part.split(",")[0]) for part in line.split("pid=")[1:]} & pids
    )
