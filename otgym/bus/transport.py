"""One process's place on the bus: a zenoh session in peer mode, loopback only by
default, with a liveliness token and checked subscriptions (eclipse-zenoh 1.x,
https://zenoh.io/docs/).

Network. Every node is a zenoh peer (``mode: "peer"``) with multicast scouting off,
so nothing is sent to or accepted from outside loopback unless endpoints say so. The
simulator listens on ``SIM_ENDPOINT`` (tcp/127.0.0.1:7447); every other node listens on
an ephemeral loopback port and connects to the simulator's endpoint, retried every
0.1-0.5 s for as long as it runs (zenoh's ``connect/retry``), so a restarted simulator
is found again; gossip scouting (on by default) tells peers each other's loopback
listeners, so they stay meshed while the simulator is away. ``--listen``/``--connect``
replace these endpoints (another machine's address to span machines); a zenoh
configuration file (``config_file``) adds TLS or user/password authentication. What the
file sets (endpoints, multicast scouting) is kept unless ``--listen``/``--connect`` are
given; what it leaves out gets the loopback defaults above, never zenoh's own (which
listen on every interface and scout by multicast).

Keys. A ROS 2 topic ``/otgym/traps`` travels on the zenoh key ``otgym/traps`` (the
leading slash dropped); payloads are the messages' CDR bytes. A node declares the
liveliness token ``otgym/node/<role>/<name>``; zenoh withdraws it when the session
closes or its link drops (a killed process's sockets close at once, so peers hear of
it within milliseconds: ``benchmarks/bus.py`` measures it), which is how a simulator
learns that a device node died.

Latched topics (``messages.LATCHED``: the session's description, chip and route, and
the mode) are published through zenoh-ext's ``AdvancedPublisher`` with a cache of the
last message, and ``subscribe`` to such a topic (or to a pattern with ``*``) declares an
``AdvancedSubscriber`` that asks the publishers' caches for history, also from
publishers that appear later: a recorder or window that joins a running simulator
still gets the chip, the route and the current mode. This is how rmw_zenoh carries ROS 2's
transient-local durability; it needs zenoh's timestamping, which every node's
configuration turns on.

Congestion. A stream's publisher (every tick's messages, device twists) is express
and drops a message that waits longer than ``WAIT_BEFORE_DROP_US`` (one tick) for room;
trial events and commands (``NOT_TO_DROP``) and the latched topics block instead, so
none of them is lost. A configuration file's own ``wait_before_drop`` is kept.

Checks. ``subscribe`` decodes and checks each payload (``messages.decode``) before the
callback sees it; a malformed one is dropped and counted in ``dropped`` (per topic),
never passed on.
"""

from __future__ import annotations

import json
import logging
import threading
from collections.abc import Callable

import zenoh
import zenoh.ext

from otgym.bus import messages as msg

SIM_ENDPOINT = "tcp/127.0.0.1:7447"
EPHEMERAL_ENDPOINT = "tcp/127.0.0.1:0"
WAIT_BEFORE_DROP_US = 20_000
"""How long a publisher of a stream (every tick's traps, bodies, alpha, feedback,
twists) waits for room in a congested queue before it drops the message: one tick.
zenoh's default, 1 ms, lost 1-2 % of ticks' messages on a loaded 2-core machine; a
message later than a tick is stale anyway."""
NOT_TO_DROP = (msg.EVENTS, msg.COMMAND)
"""Topics whose every message matters (trial events carry the trials' rows, commands
change the session): their publishers block when congested instead of dropping."""
ROLES = ("sim", "device", "autonomy", "recorder", "ui")
log = logging.getLogger(__name__)


def key_of(topic: str) -> str:
    """The zenoh key of a ROS 2 topic name."""
    return topic.lstrip("/")


def topic_of(key: str) -> str:
    return "/" + key


def zenoh_config(
    role: str, listen: list[str] | None = None, connect: list[str] | None = None, config_file: str | None = None
) -> zenoh.Config:
    """The session configuration of a node of ``role`` (see the module's docstring)."""
    if role not in ROLES:
        raise ValueError(f"unknown node role {role!r}; choose one of {', '.join(ROLES)}")
    config = zenoh.Config.from_file(config_file) if config_file else zenoh.Config()
    unset = zenoh.Config()  # what a file leaves out reads as zenoh's defaults: replaced by ours below
    default_listen = [SIM_ENDPOINT] if role == "sim" else [EPHEMERAL_ENDPOINT]
    default_connect = [] if role == "sim" else [SIM_ENDPOINT]
    config.insert_json5("mode", '"peer"')
    config.insert_json5("timestamping/enabled", "true")  # latched topics' publishers need it
    for key, given, default in (
        ("listen/endpoints", listen, default_listen),
        ("connect/endpoints", connect, default_connect),
    ):
        if given or config.get_json(key) == unset.get_json(key):
            config.insert_json5(key, json.dumps(list(given or default)))
    if config.get_json("scouting/multicast/enabled") == unset.get_json("scouting/multicast/enabled"):
        config.insert_json5("scouting/multicast/enabled", "false")
    drop_key = "transport/link/tx/queue/congestion_control/drop/wait_before_drop"
    if config.get_json(drop_key) == unset.get_json(drop_key):
        config.insert_json5(drop_key, str(WAIT_BEFORE_DROP_US))
    config.insert_json5("connect/retry", '{"period_init_ms": 100, "period_max_ms": 500, "period_increase_factor": 2}')
    return config


class Node:
    """A zenoh session for one node: ``publish``, checked ``subscribe``, its liveliness
    token, and ``watch`` for other nodes' tokens. ``close`` withdraws everything."""

    def __init__(
        self,
        role: str,
        name: str,
        listen: list[str] | None = None,
        connect: list[str] | None = None,
        config_file: str | None = None,
    ):
        msg.check_name(name)
        self.role, self.name = role, name
        self.session = zenoh.open(zenoh_config(role, listen, connect, config_file))
        self.token = self.session.liveliness().declare_token(f"otgym/node/{role}/{name}")
        self._publishers: dict[str, zenoh.Publisher] = {}
        self._handles: list = []
        self._lock = threading.Lock()
        self.dropped: dict[str, int] = {}
        """Malformed messages dropped, per topic."""
        self.received: dict[str, int] = {}
        """Checked messages passed on, per topic."""

    def publish(self, topic: str, data: bytes) -> None:
        """Send ``data`` on ``topic``; a latched topic's publisher keeps the last message
        for subscribers that join later (see the module's docstring)."""
        publisher = self._publishers.get(topic)
        if publisher is None:
            if topic in msg.LATCHED:
                publisher = zenoh.ext.declare_advanced_publisher(  # rare and not to be lost: blocks when congested
                    self.session,
                    key_of(topic),
                    congestion_control=zenoh.CongestionControl.BLOCK,
                    cache=zenoh.ext.CacheConfig(1),
                    publisher_detection=True,
                )
            elif topic in NOT_TO_DROP:
                publisher = self.session.declare_publisher(
                    key_of(topic), congestion_control=zenoh.CongestionControl.BLOCK
                )
            else:
                publisher = self.session.declare_publisher(
                    key_of(topic), congestion_control=zenoh.CongestionControl.DROP, express=True
                )
            self._publishers[topic] = publisher
        publisher.put(data)

    def subscribe(self, topic_pattern: str, callback: Callable[[str, object, bytes], None]) -> None:
        """Call ``callback(topic, message, data)`` for each checked message on topics
        matching ``topic_pattern`` (a topic, or a zenoh key expression with ``*``/``**``
        written with the leading slash); malformed messages are dropped and counted. A
        latched topic, or a pattern, also receives the latest message of each latched
        publisher, however late either side joins."""

        def on_sample(sample: zenoh.Sample) -> None:
            topic = topic_of(str(sample.key_expr))
            data = sample.payload.to_bytes()
            try:
                message = msg.decode(topic, data)
            except msg.MessageError as error:
                with self._lock:
                    self.dropped[topic] = self.dropped.get(topic, 0) + 1
                    if self.dropped[topic] <= 3:
                        log.warning("dropped a malformed message: %s", error)
                return
            with self._lock:
                self.received[topic] = self.received.get(topic, 0) + 1
            callback(topic, message, data)

        if topic_pattern in msg.LATCHED or "*" in topic_pattern:
            history = zenoh.ext.HistoryConfig(detect_late_publishers=True)
            self._handles.append(
                zenoh.ext.declare_advanced_subscriber(self.session, key_of(topic_pattern), on_sample, history=history)
            )
        else:
            self._handles.append(self.session.declare_subscriber(key_of(topic_pattern), on_sample))

    def watch(self, role: str, on_change: Callable[[str, bool], None]) -> None:
        """``on_change(name, alive)`` whenever a node of ``role`` appears or goes away
        (those alive now are reported at once)."""

        def on_sample(sample: zenoh.Sample) -> None:
            name = str(sample.key_expr).rsplit("/", 1)[-1]
            on_change(name, sample.kind == zenoh.SampleKind.PUT)

        self._handles.append(
            self.session.liveliness().declare_subscriber(f"otgym/node/{role}/*", on_sample, history=True)
        )

    def close(self) -> None:
        self.session.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc_info):
        self.close()
