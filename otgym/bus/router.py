"""Where the simulator sits in a zenoh network that ROS 2 nodes on rmw_zenoh share.

rmw_zenoh's nodes (ROS 2 Jazzy and newer, ``RMW_IMPLEMENTATION=rmw_zenoh_cpp``) are
zenoh peers whose session configuration (ros2/rmw_zenoh,
``rmw_zenoh_cpp/config/DEFAULT_RMW_ZENOH_SESSION_CONFIG.json5``) expects a zenoh router
on ``tcp/localhost:7447`` (``rmw_zenohd``, ``DEFAULT_RMW_ZENOH_ROUTER_CONFIG.json5``):
they connect to it, send their gossip to routers only (``scouting/gossip/target``, peer:
``["router"]``), dial a peer they hear of only when their own zenoh id is the greater
(``autoconnect_strategy``, ``to_peer: "greater-zid"``), and as peers in peer-to-peer
routing pass nothing on between two others. Against a simulator that is itself a peer,
such a node hears of otgym's other nodes only by chance and reaches one only if its id
happens to be the greater: each otgym node but the simulator appears in its graph by a
coin flip. So the simulator is a router (``otgym.bus.transport``): it gossips to peers,
so each peer hears of every other, otgym's peers dial every peer they hear of, and it
forwards between two peers that are not linked. A ROS 2 node then finds every otgym node
as it would through ``rmw_zenohd``, and its router check (``ZENOH_ROUTER_CHECK_ATTEMPTS``)
passes.

Only one program can listen on a port. ``place_sim`` looks, before the simulator opens
its session, at each TCP endpoint it is to listen on (7447 by default): a free port is
taken as usual; a port where a zenoh router or peer answers (``rmw_zenohd``, or a router
of the lab's) is joined instead: the simulator becomes a peer that connects to it and
listens on an ephemeral port of the same address; otgym's other nodes connect to the
same endpoint and meet the simulator there. Refused, with the reason (``PlacementError``):
a port held by a program that does not answer as zenoh, and a port where an otgym
simulator of the same ROS 2 domain and namespace already runs.
"""

from __future__ import annotations

import dataclasses
import errno
import json
import re
import socket

import zenoh

from otgym.bus import ros_graph
from otgym.bus.zenoh_session import zenoh_config

PROBE_TIMEOUT_S = 2.0
"""How long the simulator waits for a zenoh answer on a port another program holds."""
_TCP = re.compile(r"^tcp/(?P<host>\[[^\]]+\]|[^:/?#\[\]]+):(?P<port>\d+)(?P<rest>[?#].*)?$")
_WILDCARD = {"0.0.0.0": "127.0.0.1", "[::]": "[::1]"}


class PlacementError(ValueError):
    """The simulator cannot listen where it was told; ``str()`` is one line for the user."""


@dataclasses.dataclass(frozen=True)
class Listener:
    """What answered on a port: zenoh's ``kind`` (``router`` or ``peer``) and its id, and
    whether an otgym simulator of the domain and namespace asked about is on it."""

    kind: str
    zid: str
    otgym_sim: bool


@dataclasses.dataclass(frozen=True)
class Placement:
    """The simulator's zenoh ``mode``, ``listen`` and ``connect`` endpoints; ``joined``:
    the endpoint of the router (or peer) it joins, with what answered there, or None."""

    mode: str
    listen: list[str]
    connect: list[str]
    joined: tuple[str, Listener] | None = None

    def describe(self) -> str:
        if self.joined is None:
            return f"a zenoh router on {', '.join(self.listen)}"
        endpoint, listener = self.joined
        return (
            f"a zenoh {listener.kind} (id {listener.zid}) already listens on {endpoint}: joined as a peer, "
            f"listening on {', '.join(self.listen)}"
        )


def _host_port(endpoint: str) -> tuple[str, int] | None:
    match = _TCP.match(endpoint)
    return None if match is None else (match["host"], int(match["port"]))


def port_taken(host: str, port: int) -> bool:
    """Whether a program listens on ``host:port`` (TCP): a bind as zenoh binds
    (``SO_REUSEADDR``, so connections closing on the port do not count) fails with
    EADDRINUSE. Port 0 is never taken."""
    if port == 0:
        return False
    for family, kind, _, _, address in socket.getaddrinfo(host.strip("[]"), port, type=socket.SOCK_STREAM):
        with socket.socket(family, kind) as trial:
            trial.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            try:
                trial.bind(address)
            except OSError as error:
                if error.errno == errno.EADDRINUSE:
                    return True
                raise PlacementError(f"cannot listen on {host}:{port}: {error.strerror}") from None
    return False


def probe(
    endpoint: str, domain: int, namespace: str, config_file: str | None = None, timeout_s: float = PROBE_TIMEOUT_S
) -> Listener | None:
    """What answers as zenoh on ``endpoint`` (a zenoh client session that connects to it,
    with ``config_file``'s authentication), or None within ``timeout_s``."""
    config = zenoh_config("device", [], [endpoint], config_file)
    config.insert_json5("mode", '"client"')
    config.insert_json5("listen/endpoints", "[]")
    config.insert_json5("connect/timeout_ms", str(int(timeout_s * 1000)))
    config.insert_json5("transport/unicast/open_timeout", str(int(timeout_s * 1000)))
    config.insert_json5("connect/exit_on_failure", "true")
    try:
        session = zenoh.open(config)
    except zenoh.ZError:
        return None
    try:
        routers = [str(z) for z in session.info.routers_zid()]
        peers = [str(z) for z in session.info.peers_zid()]
        if not routers and not peers:
            return None
        key = "/".join(
            [ros_graph.ADMIN_SPACE, str(domain), "*", "*", "*", ros_graph.NODE, "*", ros_graph.mangle(namespace)]
            + [ros_graph.mangle("otgym_sim")]
        )
        replies = session.liveliness().get(key, timeout=timeout_s)
        otgym_sim = any(reply.ok is not None for reply in replies)
        return Listener("router" if routers else "peer", (routers or peers)[0], otgym_sim)
    finally:
        session.close()


def listen_endpoints(listen: list[str], connect: list[str], config_file: str | None) -> list[str] | None:
    """The endpoints the simulator would listen on (``--listen``, else the file's, else
    ``zenoh_session.SIM_ENDPOINT``); None where the file gives them per mode."""
    endpoints = json.loads(zenoh_config("sim", listen, connect, config_file).get_json("listen/endpoints"))
    return endpoints if isinstance(endpoints, list) else None


def place_sim(
    listen: list[str] | None = None,
    connect: list[str] | None = None,
    config_file: str | None = None,
    *,
    domain: int | None = None,
    namespace: str = "/",
    timeout_s: float | None = None,
) -> Placement:
    """The simulator's mode and endpoints (see the module's docstring); PlacementError
    where it can neither listen nor join. Only TCP endpoints with a fixed port are
    looked at; the others are left to zenoh. ``timeout_s``: the wait for a zenoh answer
    (default ``PROBE_TIMEOUT_S``)."""
    listen, connect = list(listen or []), list(connect or [])
    timeout_s = PROBE_TIMEOUT_S if timeout_s is None else timeout_s
    endpoints = listen_endpoints(listen, connect, config_file)
    if endpoints is None:
        return Placement("router", endpoints, connect)
    domain = ros_graph.domain_id() if domain is None else domain
    for index, endpoint in enumerate(endpoints):
        host_port = _host_port(endpoint)
        if host_port is None or not port_taken(*host_port):
            continue
        host, port = host_port
        target = f"tcp/{_WILDCARD.get(host, host)}:{port}"
        listener = probe(target, domain, namespace, config_file, timeout_s)
        if listener is None:
            raise PlacementError(
                f"{endpoint} is taken by a program that does not answer as zenoh within {timeout_s:g} s; "
                f"give the sim another port (--listen tcp/{host}:PORT)"
            )
        if listener.otgym_sim:
            raise PlacementError(
                f"an otgym sim of namespace {namespace} in ROS domain {domain} already runs on {endpoint}; "
                "stop it, or give this one another namespace (--namespace) or port (--listen)"
            )
        rest = endpoints[:index] + [f"tcp/{host}:0"] + endpoints[index + 1 :]
        return Placement("peer", rest, [*connect, target], (endpoint, listener))
    return Placement("router", endpoints, connect)
