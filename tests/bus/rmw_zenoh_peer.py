"""A ROS 2 process on rmw_zenoh as zenoh sees it, run as its own process by
tests/bus/test_rmw_zenoh.py (no otgym import): a zenoh session with rmw_zenoh's default
session configuration, or, with ``--router``, a stand-in for rmw_zenoh's router
``rmw_zenohd`` with its default router configuration.

The settings that decide who finds whom are rmw_zenoh's, read from ros2/rmw_zenoh
``rmw_zenoh_cpp/config/DEFAULT_RMW_ZENOH_SESSION_CONFIG.json5`` and
``DEFAULT_RMW_ZENOH_ROUTER_CONFIG.json5`` (commit 30f3030 and 076f2e7; ``SESSION`` and
``ROUTER`` below); only the endpoint differs: the test's loopback port in place of
7447, so that the test never meets a router or simulator already on this machine.

As a peer (``rmw_zenoh_peer.py ENDPOINT STARTS DEADLINE_S NODES TOPICS``) it opens a
session ``STARTS`` times in turn, each a new zenoh session with a new random zenoh id (as
a ROS 2 process started anew), closed before the next. Each start waits, at most
``DEADLINE_S``, until it has seen the liveliness token of every ROS 2 node named in
``NODES`` (comma-separated) in the domain ``ROS_DOMAIN_ID`` (what ``ros2 node list``
reads) and received a message with rmw_zenoh's 33-byte attachment on every topic of
``TOPICS`` (what ``ros2 topic echo`` reads), and prints one line
``start: {"nodes": [...], "topics": {...}, "seconds": ..., "zid": ...}``.

As the router (``rmw_zenoh_peer.py --router ENDPOINT``) it prints ``ready`` and runs
until it is stopped.
"""

from __future__ import annotations

import json
import os
import sys
import threading
import time

import zenoh

SESSION = {
    "mode": '"peer"',
    "listen/endpoints": '["tcp/localhost:0"]',
    "connect/timeout_ms": '{"router": -1, "peer": -1, "client": 0}',
    "connect/exit_on_failure": '{"router": false, "peer": false, "client": true}',
    "open/return_conditions": '{"connect_scouted": true, "declares": true}',
    "scouting/delay": "500",
    "scouting/multicast/enabled": "false",
    "scouting/gossip/enabled": "true",
    "scouting/gossip/multihop": "false",
    "scouting/gossip/target": '{"router": ["router", "peer"], "peer": ["router"]}',
    "scouting/gossip/autoconnect": '{"router": [], "peer": ["router", "peer"]}',
    "scouting/gossip/autoconnect_strategy": '{"peer": {"to_router": "always", "to_peer": "greater-zid"}}',
    "timestamping/enabled": '{"router": true, "peer": true, "client": true}',
    "queries_default_timeout": "60000",
    "routing/router/peers_failover_brokering": "true",
}
"""rmw_zenoh's session settings that decide discovery and routing (see the module's
docstring); ``connect/endpoints`` is ``tcp/localhost:<port>``."""
ROUTER = {
    "mode": '"router"',
    "connect/endpoints": "[]",
    "scouting/multicast/enabled": "false",
    "scouting/gossip/enabled": "true",
    "scouting/gossip/multihop": "false",
    "scouting/gossip/target": '{"router": ["router", "peer"], "peer": ["router"]}',
    "scouting/gossip/autoconnect": '{"router": [], "peer": ["router", "peer"]}',
    "scouting/gossip/autoconnect_strategy": '{"router": {"to_router": "always", "to_peer": "always"}}',
    "timestamping/enabled": '{"router": true, "peer": true, "client": true}',
    "routing/router/peers_failover_brokering": "false",
}
"""rmw_zenohd's settings (its listen endpoint, ``tcp/[::]:7447`` there, is the test's)."""
ATTACHMENT_BYTES = 33


def config(settings: dict, **endpoints: str) -> zenoh.Config:
    result = zenoh.Config()
    for key, value in settings.items():
        result.insert_json5(key, value)
    for key, endpoint in endpoints.items():
        result.insert_json5(f"{key}/endpoints", json.dumps([endpoint]))
    return result


def one_start(endpoint: str, domain: int, deadline_s: float, nodes: list[str], topics: list[str]) -> dict:
    """What one new session saw (see the module's docstring)."""
    port = endpoint.rsplit(":", 1)[1]
    session = zenoh.open(config(SESSION, connect=f"tcp/localhost:{port}"))
    started = time.monotonic()
    seen_nodes: set[str] = set()
    received = {topic: 0 for topic in topics}
    lock = threading.Lock()

    def on_token(sample) -> None:
        parts = str(sample.key_expr).split("/")
        if sample.kind == zenoh.SampleKind.PUT and len(parts) >= 9 and parts[5] == "NN":
            with lock:
                seen_nodes.add(parts[8].replace("%", "/"))

    def on_data(topic: str):
        def count(sample) -> None:
            attachment = sample.attachment
            if attachment is not None and len(attachment.to_bytes()) == ATTACHMENT_BYTES:
                with lock:
                    received[topic] += 1

        return count

    try:
        handles = [session.liveliness().declare_subscriber(f"@ros2_lv/{domain}/**", on_token, history=True)]
        handles += [session.declare_subscriber(f"{domain}/{t.strip('/')}/*/*", on_data(t)) for t in topics]

        def complete() -> bool:
            with lock:
                return set(nodes) <= seen_nodes and all(received.values())

        while not complete() and time.monotonic() - started < deadline_s:
            time.sleep(0.01)
        seconds = time.monotonic() - started
        with lock:
            return {
                "nodes": sorted(seen_nodes),
                "topics": dict(received),
                "seconds": round(seconds, 3),
                "zid": str(session.zid()),
                "routers": [str(z) for z in session.info.routers_zid()],
                "peers": [str(z) for z in session.info.peers_zid()],
            }
    finally:
        session.close()


def main(argv: list[str]) -> int:
    if argv[0] == "--router":
        router = zenoh.open(config(ROUTER, listen=argv[1]))
        print(f"ready: rmw_zenohd stand-in {router.zid()} on {argv[1]}", flush=True)
        try:
            threading.Event().wait()
        finally:
            router.close()
    endpoint, starts, deadline_s = argv[0], int(argv[1]), float(argv[2])
    nodes, topics = argv[3].split(","), argv[4].split(",")
    domain = int(os.environ.get("ROS_DOMAIN_ID", "0"))
    for _ in range(starts):
        print("start: " + json.dumps(one_start(endpoint, domain, deadline_s, nodes, topics)), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
