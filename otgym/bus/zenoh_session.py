"""The zenoh session configuration of an otgym node (``zenoh_config``): loopback only by
default, the simulator a router, every other node a peer (eclipse-zenoh 1.x,
https://zenoh.io/docs/).

Network. The simulator is a zenoh router (``mode: "router"``) listening on
``SIM_ENDPOINT`` (tcp/127.0.0.1:7447, the port of rmw_zenoh's router ``rmw_zenohd``);
every other node is a zenoh peer that listens on an ephemeral loopback port and connects
to the simulator's endpoint, retried every 0.1-0.5 s for as long as it runs (zenoh's
``connect/retry``), so a restarted simulator is found again. Multicast scouting is off,
so nothing is sent to or accepted from outside loopback unless endpoints say so. Gossip
scouting is on: the router tells every peer linked to it of the others (its gossip goes
to routers and peers), each peer dials every peer it hears of, and the router forwards
between two peers that are not linked (``peers_failover_brokering``). So a ROS 2 node on
rmw_zenoh, a peer that sends its gossip only to routers and dials only peers of a smaller
zenoh id, finds every otgym node through the simulator as through ``rmw_zenohd``
(``otgym.bus.router``, which also lets the simulator join an ``rmw_zenohd`` already on
its port), and otgym's peers stay meshed while the simulator is away.
``--listen``/``--connect`` replace these endpoints (another machine's address to span
machines); a zenoh configuration file (``config_file``) adds TLS or user/password
authentication. What the file sets (endpoints, multicast and gossip scouting) is kept
unless ``--listen``/``--connect`` are given; what it leaves out gets the defaults above,
never zenoh's own (which listen on every interface and scout by multicast).
"""

from __future__ import annotations

import json

import zenoh

SIM_ENDPOINT = "tcp/127.0.0.1:7447"
EPHEMERAL_ENDPOINT = "tcp/127.0.0.1:0"
WAIT_BEFORE_DROP_US = 20_000
"""How long a publisher of a stream (every tick's traps, bodies, alpha, feedback,
twists) waits for room in a congested queue before it drops the message: one tick.
zenoh's default, 1 ms, lost 1-2 % of ticks' messages on a loaded 2-core machine; a
message later than a tick is stale anyway."""
ROLES = ("sim", "device", "autonomy", "recorder", "ui", "foxglove", "ros2")
GOSSIP = {
    "scouting/multicast/enabled": "false",
    "scouting/gossip/enabled": "true",
    "scouting/gossip/target": '{"router": ["router", "peer"], "peer": ["router", "peer"]}',
    "scouting/gossip/autoconnect": '{"router": [], "peer": ["router", "peer"]}',
    "scouting/gossip/autoconnect_strategy": '{"peer": {"to_router": "always", "to_peer": "always"}}',
    "routing/router/peers_failover_brokering": "true",
}
"""Scouting and routing (see the module's docstring), each kept where a configuration
file sets it: no multicast; gossip from the router to routers and peers (and from a peer
to both); a peer dials every router and peer it hears of, whatever their zenoh ids; the
router forwards between two peers that are not linked to each other."""


def zenoh_config(
    role: str,
    listen: list[str] | None = None,
    connect: list[str] | None = None,
    config_file: str | None = None,
    mode: str | None = None,
) -> zenoh.Config:
    """The session configuration of a node of ``role`` (see the module's docstring);
    ``mode``: zenoh's mode, by default ``router`` for the simulator, ``peer`` for the
    others (a simulator that joins a router is a peer: ``otgym.bus.router``)."""
    if role not in ROLES:
        raise ValueError(f"unknown node role {role!r}; choose one of {', '.join(ROLES)}")
    mode = mode or ("router" if role == "sim" else "peer")
    if mode not in ("router", "peer"):
        raise ValueError(f"a node is a zenoh router or peer, not {mode!r}")
    config = zenoh.Config.from_file(config_file) if config_file else zenoh.Config()
    unset = zenoh.Config()  # what a file leaves out reads as zenoh's defaults: replaced by ours below
    default_listen = [SIM_ENDPOINT] if role == "sim" else [EPHEMERAL_ENDPOINT]
    default_connect = [] if role == "sim" else [SIM_ENDPOINT]
    config.insert_json5("mode", json.dumps(mode))
    config.insert_json5("timestamping/enabled", "true")  # latched topics' publishers need it
    for key, given, default in (
        ("listen/endpoints", listen, default_listen),
        ("connect/endpoints", connect, default_connect),
    ):
        if given or config.get_json(key) == unset.get_json(key):
            config.insert_json5(key, json.dumps(list(given or default)))
    for key, value in GOSSIP.items():
        if config.get_json(key) == unset.get_json(key):
            config.insert_json5(key, value)
    drop_key = "transport/link/tx/queue/congestion_control/drop/wait_before_drop"
    if config.get_json(drop_key) == unset.get_json(drop_key):
        config.insert_json5(drop_key, str(WAIT_BEFORE_DROP_US))
    config.insert_json5("connect/retry", '{"period_init_ms": 100, "period_max_ms": 500, "period_increase_factor": 2}')
    return config
