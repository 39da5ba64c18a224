"""ROS 2 nodes on rmw_zenoh find every otgym node, each side its own process.

The ROS 2 side is ``tests/bus/rmw_zenoh_peer.py``: zenoh sessions with rmw_zenoh's own
default session configuration (gossip to routers only, a peer dialled only by the one of
greater zenoh id, nothing passed on between two other peers), each start a new session
with a new random id. Against a simulator that was a zenoh peer, each otgym node other
than the simulator was found or not by a coin flip of those ids; the simulator is now a
zenoh router (``otgym.bus.router``), and joins an ``rmw_zenohd`` already on its port.

The simulator here is its bus side only (``SIM``: the sim node's placement and zenoh
session, publishing traps at 50 Hz, without the physics, whose start takes minutes on
this machine under load); the other otgym node is ``otgym node device``.
"""

from __future__ import annotations

import json
import random

import pytest

from otgym.bus import messages as msg
from otgym.bus.router import PlacementError, place_sim
from otgym.bus.transport import Node
from tests.bus.test_nodes import ROOT, STARTUP_S, children, free_endpoint, spawn, wait_for_line  # noqa: F401  (fixture)

PEER = str(ROOT / "tests" / "bus" / "rmw_zenoh_peer.py")
SIM = """
import sys, time
import numpy as np
from otgym.bus import messages as m
from otgym.bus.router import place_sim
from otgym.bus.transport import Node
placement = place_sim([sys.argv[1]])
print("sim:", placement.describe(), flush=True)
with Node("sim", "sim", listen=placement.listen, connect=placement.connect, mode=placement.mode) as node:
    print("ready", flush=True)
    while True:
        node.publish(m.TRAPS, m.pose_array(np.zeros((4, 2)), time.time()))
        time.sleep(0.02)
"""
NODES = "otgym_sim,otgym_device_device0"
TOPICS = f"{msg.TRAPS},{msg.twist_topic('device0')}"
START_DEADLINE_S = 20.0
"""A bound on one start (a guard against hangs: each start reports how long it took)."""


@pytest.fixture
def ros_domain(monkeypatch) -> int:
    """A ROS 2 domain of this test's own, for the processes it starts."""
    domain = random.SystemRandom().randrange(1, 233)
    monkeypatch.setenv("ROS_DOMAIN_ID", str(domain))
    return domain


def _starts(endpoint: str, starts: int) -> list[dict]:
    peer = spawn(PEER, endpoint, str(starts), str(START_DEADLINE_S), NODES, TOPICS)
    output, _ = peer.communicate(timeout=starts * (START_DEADLINE_S + 30))
    assert peer.returncode == 0, output[-3000:]
    return [json.loads(line[len("start: ") :]) for line in output.splitlines() if line.startswith("start: ")]


def _complete(start: dict) -> bool:
    return set(NODES.split(",")) <= set(start["nodes"]) and all(start["topics"].values())


@pytest.mark.slow
def test_a_ros2_peer_with_rmw_zenohs_configuration_finds_every_otgym_node_in_20_starts_of_20(ros_domain, children):  # noqa: F811
    """Each start (a new session, a new zenoh id) sees the tokens of the ROS 2 nodes
    otgym_sim and otgym_device_device0 and receives the sim's traps and the device's
    twists, with rmw_zenoh's attachment."""
    endpoint = free_endpoint()
    children.append(spawn("-c", SIM, endpoint))
    assert "a zenoh router on" in wait_for_line(children[-1], "sim:", STARTUP_S)
    wait_for_line(children[-1], "ready", STARTUP_S)
    children.append(spawn("-m", "otgym", "node", "device", "--device", "simulated", "--connect", endpoint))
    wait_for_line(children[-1], "ready", STARTUP_S)
    starts = _starts(endpoint, 20)
    assert len(starts) == 20
    missed = [start for start in starts if not _complete(start)]
    assert not missed, missed


@pytest.mark.slow
def test_the_sim_joins_an_rmw_zenoh_router_on_its_port_and_a_ros2_peer_finds_every_otgym_node(ros_domain, children):  # noqa: F811
    """An rmw_zenohd stand-in (rmw_zenoh's router configuration) holds the sim's port:
    the sim joins it as a peer instead of failing, otgym's device node connects to the
    same port, and a ROS 2 peer there finds both nodes and their messages in 5 starts."""
    endpoint = free_endpoint()
    children.append(spawn(PEER, "--router", endpoint))
    wait_for_line(children[-1], "ready", STARTUP_S)
    children.append(spawn("-c", SIM, endpoint))
    assert f"already listens on {endpoint}: joined as a peer" in wait_for_line(children[-1], "sim:", STARTUP_S)
    wait_for_line(children[-1], "ready", STARTUP_S)
    children.append(spawn("-m", "otgym", "node", "device", "--device", "simulated", "--connect", endpoint))
    wait_for_line(children[-1], "ready", STARTUP_S)
    starts = _starts(endpoint, 5)
    assert len(starts) == 5
    missed = [start for start in starts if not _complete(start)]
    assert not missed, missed


def test_place_sim_listens_on_a_free_port_and_joins_a_zenoh_router_on_a_taken_one():
    endpoint = free_endpoint()
    free = place_sim([endpoint], domain=7)
    assert (free.mode, free.listen, free.joined) == ("router", [endpoint], None)
    with Node("sim", "sim", listen=[endpoint], mode="peer", domain=8):  # a zenoh peer, an otgym sim of another domain
        joined = place_sim([endpoint], domain=7)
    assert joined.mode == "peer" and joined.listen == ["tcp/127.0.0.1:0"] and joined.connect == [endpoint]
    assert joined.joined[0] == endpoint and joined.joined[1].kind == "peer"


def test_place_sim_refuses_a_port_of_another_otgym_sim_or_of_a_program_that_is_not_zenoh():
    import socket

    endpoint = free_endpoint()
    with Node("sim", "sim", listen=[endpoint], domain=7, namespace="/rig1"):
        with pytest.raises(PlacementError, match="an otgym sim of namespace /rig1 in ROS domain 7 already runs"):
            place_sim([endpoint], domain=7, namespace="/rig1")
        assert place_sim([endpoint], domain=7, namespace="/rig2").mode == "peer"  # another rig's namespace
    host, port = endpoint[len("tcp/") :].split(":")
    with socket.socket() as other:
        other.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        other.bind((host, int(port)))
        other.listen()
        with pytest.raises(PlacementError, match="taken by a program that does not answer as zenoh"):
            place_sim([endpoint], domain=7, timeout_s=0.5)


def test_otgym_node_sim_on_a_port_a_program_that_is_not_zenoh_holds_is_one_error_line(tmp_path, monkeypatch):
    """Run in this process (``tests.otgym_cli``): refused before the simulation starts."""
    import signal
    import socket

    from otgym.bus import router
    from tests.otgym_cli import run_otgym

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(router, "PROBE_TIMEOUT_S", 0.3)  # no zenoh answer is coming: wait less for it
    endpoint = free_endpoint()
    host, port = endpoint[len("tcp/") :].split(":")
    handlers = {signum: signal.getsignal(signum) for signum in (signal.SIGINT, signal.SIGTERM)}
    try:
        with socket.socket() as other:
            other.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            other.bind((host, int(port)))
            other.listen()
            run = run_otgym(["node", "sim", "--listen", endpoint])
    finally:
        for signum, handler in handlers.items():  # the node's own handlers, installed before the refusal
            signal.signal(signum, handler)
    lines = run.stderr.strip().splitlines()
    assert run.returncode == 2 and len(lines) == 1, run.stderr
    assert lines[0].startswith(f"error: {endpoint} is taken by a program that does not answer as zenoh"), lines
    assert "starting the simulation" not in run.stdout and not any(tmp_path.iterdir())
