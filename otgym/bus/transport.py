"""One process's place on the bus: a zenoh session, loopback only by default, with a
liveliness token and checked subscriptions (eclipse-zenoh 1.x, https://zenoh.io/docs/).

Network (endpoints, scouting, routing): ``otgym.bus.zenoh_session``.

Keys and the ROS 2 graph (``otgym.bus.ros_graph``: rmw_zenoh's layout). A topic
``/otgym/traps`` of a node in namespace ``/`` and domain ``ROS_DOMAIN_ID`` (0) travels on
the key ``0/otgym/traps/geometry_msgs::msg::dds_::PoseArray_/RIHS01_...``; payloads are
the messages' CDR bytes, each with rmw_zenoh's attachment (sequence number, source
time, publisher GID). otgym's topics are relative to the node's namespace: with
``--namespace /rig1`` they are ``/rig1/otgym/...``. Each node declares the liveliness
tokens a ROS 2 node declares (``@ros2_lv/...``: the node, and each publisher and
subscription with its type, type hash and QoS), so ``ros2 node list`` and ``ros2 topic
list -t`` on a ROS 2 system with rmw_zenoh on the same zenoh network show it. A node
also declares otgym's own token ``otgym/node/<role>/<name>``; zenoh withdraws both when
the session closes or its link drops (a killed process's sockets close at once, so peers
hear of it within milliseconds: ``benchmarks/bus.py`` measures it), which is how a
simulator learns that a device node died.

Latched topics (``messages.LATCHED``: the session's description, chip and route, and
the mode) are published through zenoh-ext's ``AdvancedPublisher`` with a cache of the
last message, and ``subscribe`` to such a topic (or to a pattern with ``*``: to each
latched topic it matches) declares an ``AdvancedSubscriber`` that asks the publishers'
caches for history, also from publishers that appear later: a recorder or window that
joins a running simulator still gets the chip, the route and the current mode. This is
how rmw_zenoh carries ROS 2's transient-local durability; it needs zenoh's timestamping,
which every node's configuration turns on. The other topics a pattern matches come
through a plain subscriber: an advanced one drops a sample of a plain publisher whose
timestamp is not newer than the last it passed from that publisher's session, and a
node's threads that publish at once (the sim's ticks and events, its answers to the
devices' twists) may send theirs out of timestamp order (a distributed session lost its
``session_end`` so).

Congestion. A stream's publisher (every tick's messages, device twists) is express
and drops a message that waits longer than ``WAIT_BEFORE_DROP_US`` (one tick) for room;
trial events and commands (``NOT_TO_DROP``) and the latched topics block instead, so
none of them is lost. A configuration file's own ``wait_before_drop`` is kept. A
subscriber stalled longer than zenoh's ``wait_before_close`` (5 s) has its link closed
and loses what was queued on it; the trial events (``RECOVERED``) come back: their
publisher keeps a cache and a heartbeat, and their subscribers ask it for what they
missed once reconnected (zenoh's missed-sample recovery), delivered in order.

QoS (what the tokens declare, as the publishers behave): latched topics reliable,
transient local, depth 1; events and commands reliable, keep all (the publisher
blocks); streams reliable, volatile, depth 1 (the publisher drops what waits longer
than a tick). A ROS 2 publisher whose QoS cannot serve a subscription, or whose type
differs, is reported once (``otgym.bus.intake``).

Checks. ``subscribe`` checks each sample (``otgym.bus.intake``: type and type hash from
its key, attachment and sequence number, size, then ``messages.decode_as``) before the
callback sees it; one that fails is dropped and counted in ``dropped`` (per topic) and
``drop_reasons`` (per topic and reason), never passed on.
"""

from __future__ import annotations

import itertools
import logging
import threading
import time
from collections.abc import Callable

import zenoh
import zenoh.ext

from otgym.bus import messages as msg
from otgym.bus import ros_graph
from otgym.bus.intake import DDS_NAME, TYPE_HASH, Counts, Intake, qos_problem
from otgym.bus.zenoh_session import zenoh_config

NOT_TO_DROP = (msg.EVENTS, msg.COMMAND)
"""Topics whose every message matters (trial events carry the trials' rows, commands
change the session): their publishers block when congested instead of dropping."""
RECOVERED = (msg.EVENTS,)
"""Topics whose subscribers recover a missed message from the publisher's cache (zenoh's
missed-sample recovery): a subscriber stalled longer than zenoh's ``wait_before_close``
(5 s) loses its link and what was queued on it, and gets it back once reconnected."""
RECOVERY_CACHE_SAMPLES = 1024
"""Messages a recovered topic's publisher keeps for subscribers that missed them (a
session's events: a few per trial)."""
MISS_HEARTBEAT_S = 0.5
"""Period of the heartbeat that tells a subscriber the publisher's last sequence number.
A latched publisher's is sporadic (sent only after a new message), as rmw_zenoh's for
reliable, transient-local publishers (``SAMPLE_MISS_DETECTION_HEARTBEAT_PERIOD``), so a
ROS 2 subscriber's recovery of a missed last sample works as with a ROS 2 publisher. A
recovered topic's is periodic: a subscriber that reconnects after the last message's
heartbeat would otherwise never learn what it missed."""
LATCHED_QOS = ros_graph.Qos(ros_graph.RELIABLE, ros_graph.TRANSIENT_LOCAL, ros_graph.KEEP_LAST, 1)
ALL_QOS = ros_graph.Qos(ros_graph.RELIABLE, ros_graph.VOLATILE, ros_graph.KEEP_ALL, ros_graph.DEFAULT_DEPTH)
STREAM_QOS = ros_graph.Qos(ros_graph.RELIABLE, ros_graph.VOLATILE, ros_graph.KEEP_LAST, 1)
log = logging.getLogger(__name__)


def qos_of(topic: str) -> ros_graph.Qos:
    """The QoS an otgym topic is published and subscribed with (see the module's docstring)."""
    if topic in msg.LATCHED:
        return LATCHED_QOS
    return ALL_QOS if topic in NOT_TO_DROP else STREAM_QOS


def ros_node_name(role: str, name: str) -> str:
    """The ROS 2 name of an otgym node: ``otgym_<role>``, a device node ``otgym_device_<name>``."""
    return f"otgym_device_{name}" if role == "device" else f"otgym_{role}"


class _Publisher:
    """One topic's zenoh publisher, its liveliness token and GID; ``put`` attaches
    rmw_zenoh's attachment with the next sequence number (numbered and sent under one
    lock, so that messages from several threads leave in the order of their numbers)."""

    def __init__(self, publisher, token, gid: bytes, matching=None):
        self.publisher, self.token, self.gid = publisher, token, gid
        self.matching = matching or publisher
        """A plain publisher on the same key, for zenoh's matching status (an advanced
        publisher has none)."""
        self._sequence = itertools.count(1)
        self._lock = threading.Lock()

    def put(self, data: bytes) -> None:
        with self._lock:
            self.publisher.put(data, attachment=ros_graph.attachment(next(self._sequence), time.time_ns(), self.gid))


class Node:
    """A zenoh session for one node: ``publish``, checked ``subscribe``, its liveliness
    tokens (otgym's and the ROS 2 graph's), and ``watch`` for other nodes' tokens.
    ``namespace``: the ROS 2 namespace of the node and of otgym's topics; ``domain``:
    the ROS 2 domain id (default ``ROS_DOMAIN_ID``); ``ros_name``: its ROS 2 node name
    (default ``ros_node_name``); ``mode``: zenoh's (``zenoh_config``). ``close``
    withdraws everything."""

    def __init__(
        self,
        role: str,
        name: str,
        listen: list[str] | None = None,
        connect: list[str] | None = None,
        config_file: str | None = None,
        *,
        namespace: str = "/",
        domain: int | None = None,
        ros_name: str | None = None,
        mode: str | None = None,
    ):
        msg.check_name(name)
        self.role, self.name = role, name
        self.namespace = ros_graph.check_namespace(namespace)
        self.domain = ros_graph.domain_id() if domain is None else int(domain)
        self.ros_name = ros_graph.check_node_name(ros_name or ros_node_name(role, name))
        self.session = zenoh.open(zenoh_config(role, listen, connect, config_file, mode))
        self.zid = str(self.session.zid())
        self.token = self.session.liveliness().declare_token(f"otgym/node/{role}/{name}")
        self._entity_ids = itertools.count(1)
        self.graph_tokens = [self._declare_graph_token(ros_graph.NODE, 0)]
        self.counts = Counts()
        self.dropped, self.received, self.drop_reasons = self.counts.dropped, self.counts.received, self.counts.reasons
        """Messages dropped per topic, passed on per topic, dropped per (topic, reason)."""
        self._publishers: dict[str, _Publisher] = {}
        self._handles: list = []
        self._lock = threading.Lock()
        self._subscribed: dict[str, tuple[set, ros_graph.Qos]] = {}
        self._published: dict[str, tuple[tuple[str, str], ros_graph.Qos]] = {}
        self._remote: list[ros_graph.Entity] = []
        self._closed = False
        self._handles.append(
            self.session.liveliness().declare_subscriber(
                f"{ros_graph.ADMIN_SPACE}/{self.domain}/**", self._on_graph_token, history=True
            )
        )

    # --- names ----------------------------------------------------------------------------
    def fqn(self, topic: str) -> str:
        """The fully qualified ROS 2 name of otgym's ``topic`` in this node's namespace."""
        return ros_graph.resolve_topic(topic.lstrip("/"), self.namespace)

    def _topic_of(self, parts: list[str]) -> str:
        fqn = "/" + "/".join(parts[1:-2])
        if self.namespace != "/" and fqn.startswith(self.namespace + "/"):
            return fqn[len(self.namespace) :]
        return fqn

    def _declare_graph_token(self, kind: str, entity_id: int, fqn=None, type_name=None, qos=None):
        key = ros_graph.entity_token(
            self.domain,
            self.zid,
            0,
            entity_id,
            kind,
            self.namespace,
            self.ros_name,
            fqn,
            type_name,
            None if type_name is None else TYPE_HASH[type_name],
            qos,
        )
        return key, self.session.liveliness().declare_token(key)

    # --- publishing ---------------------------------------------------------------------
    def publish(self, topic: str, data: bytes) -> None:
        """Send ``data`` on ``topic``; a latched topic's publisher keeps the last message
        for subscribers that join later (see the module's docstring)."""
        publisher = self._publishers.get(topic)
        if publisher is None:
            publisher = self._declare_publisher(topic)
        try:
            publisher.put(data)
        except zenoh.ZError:
            if not self._closed:  # a callback that answers while the node closes sends nothing
                raise

    def publish_ros(self, topic: str, type_name: str, data: bytes) -> str:
        """Send ``data`` (CDR of ``type_name``) on a ROS 2 topic that is not otgym's
        (``topic`` resolved in this node's namespace by ROS 2's rules, as ``subscribe_ros``
        does), as a stream; returns its fully qualified name."""
        fqn = ros_graph.resolve_topic(topic, self.namespace)
        publisher = self._publishers.get(fqn)
        if publisher is None:
            publisher = self._declare_publisher(fqn, type_name, fqn)
        publisher.put(data)
        return fqn

    def wait_for_subscribers(self, topic: str, timeout_s: float = 60.0) -> None:
        """Block until a subscriber elsewhere on the bus matches this node's publisher of
        ``topic`` (zenoh's matching status: the link is up and the subscriber declared),
        so that what is published next reaches it; TimeoutError after ``timeout_s``.
        For a stream or an event topic (a latched topic's late subscribers get its
        history instead)."""
        if topic in msg.LATCHED:
            raise ValueError(f"{topic} is latched: a late subscriber gets its last message anyway")
        publisher = self._publishers.get(topic) or self._declare_publisher(topic)
        deadline = time.monotonic() + timeout_s
        while not publisher.matching.matching_status.matching:
            if time.monotonic() > deadline:
                raise TimeoutError(f"no subscriber of {topic} within {timeout_s:g} s")
            time.sleep(0.005)

    def _declare_publisher(self, topic: str, type_name: str | None = None, fqn: str | None = None) -> _Publisher:
        with self._lock:
            if topic in self._publishers:
                return self._publishers[topic]
            type_name, fqn = type_name or msg.topic_type(topic), fqn or self.fqn(topic)
            key = ros_graph.data_key(self.domain, fqn, type_name, TYPE_HASH[type_name])
            if topic in msg.LATCHED:
                publisher = zenoh.ext.declare_advanced_publisher(  # rare and not to be lost: blocks when congested
                    self.session,
                    key,
                    congestion_control=zenoh.CongestionControl.BLOCK,
                    cache=zenoh.ext.CacheConfig(1),
                    publisher_detection=True,
                    sample_miss_detection=zenoh.ext.MissDetectionConfig(sporadic_heartbeat=MISS_HEARTBEAT_S),
                )
            elif topic in RECOVERED:
                publisher = zenoh.ext.declare_advanced_publisher(  # blocks when congested, resends what was missed
                    self.session,
                    key,
                    congestion_control=zenoh.CongestionControl.BLOCK,
                    cache=zenoh.ext.CacheConfig(RECOVERY_CACHE_SAMPLES),
                    sample_miss_detection=zenoh.ext.MissDetectionConfig(heartbeat=MISS_HEARTBEAT_S),
                )
            elif topic in NOT_TO_DROP:
                publisher = self.session.declare_publisher(key, congestion_control=zenoh.CongestionControl.BLOCK)
            else:
                publisher = self.session.declare_publisher(
                    key, congestion_control=zenoh.CongestionControl.DROP, express=True
                )
            qos = qos_of(topic)
            token_key, token = self._declare_graph_token(
                ros_graph.PUBLISHER, next(self._entity_ids), fqn, type_name, qos
            )
            matching = self.session.declare_publisher(key) if topic in RECOVERED else None
            self._publishers[topic] = _Publisher(publisher, token, ros_graph.gid_of(token_key), matching)
            self._published[fqn] = ((DDS_NAME[type_name], TYPE_HASH[type_name]), qos)
            remote = list(self._remote)
        for entity in remote:
            self._check_entity(entity)
        return self._publishers[topic]

    # --- subscribing --------------------------------------------------------------------
    def subscribe(self, topic_pattern: str, callback: Callable[[str, object, bytes], None]) -> None:
        """Call ``callback(topic, message, data)`` for each checked message on topics
        matching ``topic_pattern`` (a topic, or a zenoh key expression with ``*``/``**``
        written with the leading slash); others are dropped and counted. A latched topic,
        or a pattern, also receives the latest message of each latched publisher, however
        late either side joins."""
        pattern = "*" in topic_pattern
        if pattern:
            topics = [
                t for t in msg.fixed_topics() if zenoh.KeyExpr(t.lstrip("/")).intersects(topic_pattern.lstrip("/"))
            ]
        else:
            topics = [topic_pattern]
        for topic in topics:
            type_name = msg.topic_type(topic)
            self._register_subscription(self.fqn(topic), {(DDS_NAME[type_name], TYPE_HASH[type_name])}, qos_of(topic))
        intake = Intake(self.counts)
        if not pattern:
            key = f"{self.domain}/{self.fqn(topic_pattern).strip('/')}/*/*"
            self._subscribe_key(
                key, intake, callback, history=topic_pattern in msg.LATCHED, recovery=topic_pattern in RECOVERED
            )
            return
        # the pattern's latched topics each through an advanced subscriber (their history),
        # the rest through a plain one: an advanced subscriber drops a plain publisher's
        # sample not newer (by zenoh's timestamp) than the last it passed from that session,
        # and a node's threads publishing at once send theirs out of timestamp order
        latched = [topic for topic in topics if topic in msg.LATCHED]
        recovered = [topic for topic in topics if topic in RECOVERED]
        key = f"{self.domain}/{self.fqn(topic_pattern).strip('/')}"
        self._subscribe_key(key, intake, callback, history=False, skip=frozenset(latched + recovered))
        for topic in latched + recovered:
            self._subscribe_key(
                f"{self.domain}/{self.fqn(topic).strip('/')}/*/*",
                intake,
                callback,
                history=topic in latched,
                recovery=topic in recovered,
            )

    def subscribe_ros(
        self, topic: str, type_names: tuple[str, ...], callback: Callable[[str, object, bytes], None]
    ) -> str:
        """Subscribe to a ROS 2 topic that is not otgym's (``topic`` resolved in this
        node's namespace by ROS 2's rules) taking any of ``type_names``; the callback gets
        the fully qualified topic. Returns that name."""
        fqn = ros_graph.resolve_topic(topic, self.namespace)
        accepted = {(DDS_NAME[t], TYPE_HASH[t]): t for t in type_names}
        self._register_subscription(fqn, set(accepted), STREAM_QOS)
        intake = Intake(self.counts, accepted)

        def forward(_topic, message, data) -> None:
            callback(fqn, message, data)

        self._subscribe_key(f"{self.domain}/{fqn.strip('/')}/*/*", intake, forward, history=False, topic=fqn)
        return fqn

    def _register_subscription(self, fqn: str, accepted: set, qos: ros_graph.Qos) -> None:
        with self._lock:
            if fqn not in self._subscribed:
                for dds_type, _hash in sorted(accepted):
                    type_name = ros_graph.ros_type_name(dds_type)
                    self.graph_tokens.append(
                        self._declare_graph_token(ros_graph.SUBSCRIPTION, next(self._entity_ids), fqn, type_name, qos)
                    )
            known = self._subscribed.get(fqn, (set(), qos))[0]
            self._subscribed[fqn] = (known | accepted, qos)
            remote = list(self._remote)
        for entity in remote:
            self._check_entity(entity)

    def _subscribe_key(
        self,
        key: str,
        intake: Intake,
        callback,
        history: bool,
        topic: str | None = None,
        skip: frozenset = frozenset(),
        recovery: bool = False,
    ) -> None:
        """``callback`` for each sample on ``key`` that passes ``intake``, except those of
        the topics in ``skip`` (another subscription takes them); ``history``: an
        advanced subscriber that also asks the latched publishers' caches; ``recovery``:
        an advanced subscriber that asks a publisher's cache for what it missed (told by
        the publisher's heartbeat or the next message's sequence number)."""

        def on_sample(sample: zenoh.Sample) -> None:
            parts = str(sample.key_expr).split("/")
            if len(parts) < 4:
                return
            name = topic or self._topic_of(parts)
            if name in skip:
                return
            data = sample.payload.to_bytes()
            attachment = sample.attachment
            message = intake.check(
                name, parts[-2], parts[-1], None if attachment is None else attachment.to_bytes(), data
            )
            if message is not None:
                callback(name, message, data)

        if history:
            config = zenoh.ext.HistoryConfig(detect_late_publishers=True)
            self._handles.append(zenoh.ext.declare_advanced_subscriber(self.session, key, on_sample, history=config))
        elif recovery:
            config = zenoh.ext.RecoveryConfig(heartbeat=True)
            self._handles.append(zenoh.ext.declare_advanced_subscriber(self.session, key, on_sample, recovery=config))
        else:
            self._handles.append(self.session.declare_subscriber(key, on_sample))

    # --- the ROS 2 graph ----------------------------------------------------------------------
    def _on_graph_token(self, sample: zenoh.Sample) -> None:
        if sample.kind != zenoh.SampleKind.PUT:
            return
        entity = ros_graph.parse_entity(str(sample.key_expr))
        if entity is None or entity.zid == self.zid:
            return
        with self._lock:
            self._remote.append(entity)
        self._check_entity(entity)

    def _check_entity(self, entity: ros_graph.Entity) -> None:
        """Report once a remote publisher or subscription on one of this node's topics
        whose type or QoS does not match (``intake.qos_problem``)."""
        offered = (entity.dds_type, entity.type_hash)
        who = f"ROS 2 node {entity.namespace.rstrip('/')}/{entity.node_name}"
        if entity.kind == ros_graph.PUBLISHER and entity.topic in self._subscribed:
            accepted, qos = self._subscribed[entity.topic]
            if offered not in accepted:
                self.counts.report(
                    ("graph-type", entity.topic, offered),
                    f"{who} publishes {entity.dds_type} ({entity.type_hash}) on {entity.topic}, which takes "
                    + ", ".join(f"{t} ({h})" for t, h in sorted(accepted)),
                )
            problem = qos_problem(entity.qos, qos)
            if problem:
                self.counts.report(("graph-qos", entity.topic, entity.qos), f"{who} on {entity.topic}: {problem}")
        if entity.kind == ros_graph.SUBSCRIPTION and entity.topic in self._published:
            published, qos = self._published[entity.topic]
            if offered != published:
                self.counts.report(
                    ("graph-type", entity.topic, offered),
                    f"{who} subscribes to {entity.topic} as {entity.dds_type} ({entity.type_hash}); "
                    f"it carries {published[0]} ({published[1]})",
                )
            problem = qos_problem(qos, entity.qos)
            if problem:
                self.counts.report(("graph-qos", entity.topic, entity.qos), f"{who} on {entity.topic}: {problem}")

    # --- otgym's own liveliness ---------------------------------------------------------------
    def watch(self, role: str, on_change: Callable[[str, bool], None]) -> None:
        """``on_change(name, alive)`` whenever a node of ``role`` appears or goes away
        (those alive now are reported at once)."""

        def on_sample(sample: zenoh.Sample) -> None:
            name = str(sample.key_expr).rsplit("/", 1)[-1]
            on_change(name, sample.kind == zenoh.SampleKind.PUT)

        self._handles.append(
            self.session.liveliness().declare_subscriber(f"otgym/node/{role}/*", on_sample, history=True)
        )

    def announce(self, fact: str) -> None:
        """Declare that this node has done ``fact`` (a liveliness token
        ``otgym/done/<fact>/<role>/<name>``, withdrawn with the node), for ``wait_for``."""
        self._handles.append(self.session.liveliness().declare_token(f"otgym/done/{fact}/{self.role}/{self.name}"))

    def wait_for(self, fact: str, role: str, timeout_s: float) -> list[str]:
        """Wait, at most ``timeout_s``, until every live node of ``role`` has announced
        ``fact`` (a node that goes away no longer counts); the names of those that had not."""
        liveliness, deadline = self.session.liveliness(), time.monotonic() + timeout_s

        def names(key: str) -> set[str]:
            return {str(r.ok.key_expr).rsplit("/", 1)[-1] for r in liveliness.get(key, timeout=1.0) if r.ok}

        while True:
            waiting = sorted(names(f"otgym/node/{role}/*") - names(f"otgym/done/{fact}/{role}/*"))
            if not waiting or time.monotonic() > deadline:
                return waiting
            time.sleep(0.05)

    def close(self) -> None:
        self._closed = True
        self.session.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc_info):
        self.close()
