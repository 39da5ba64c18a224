"""otgym's bus as a ROS 2 peer using rmw_zenoh sees it. No ROS 2 install exists here, so
the peer is a bare zenoh session of this test: it reads the ``@ros2_lv`` liveliness
tokens with a parser written from rmw_zenoh's ``liveliness_utils.cpp`` (``Entity::make``:
13 '/'-separated parts, ``%`` for '/', the QoS text of ``qos_to_keyexpr``) and builds
data keys and attachments as ``rmw_publisher_data.cpp`` and ``attachment_helpers.cpp``
do. Type hashes are checked against values published elsewhere (each cites its source)."""

from __future__ import annotations

import struct
import threading
import time

import numpy as np
import pytest
import zenoh

from otgym.bus import messages as msg
from otgym.bus import ros_graph, schemas
from otgym.bus.intake import TYPE_HASH, Counts, Intake
from otgym.bus.transport import Node
from tests.bus.test_nodes import free_endpoint, poll_until, wait_until

PUBLISHED = [
    # (type, hash, where it is published)
    (
        "std_msgs/msg/String",
        "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18",
        "ros2/rmw_zenoh docs/design.md (the chatter key); ros2/rclpy rclpy/test/test_type_hash.py",
    ),
    (
        "geometry_msgs/msg/Twist",
        "RIHS01_9c45bf16fe0983d80e3cfe750d6835843d265a9a6c46bd2e609fcddde6fb8d2a",
        "ZettaScaleLabs/ros-z docs/bindings/python-codegen.md",
    ),
    (
        "geometry_msgs/msg/TwistStamped",
        "RIHS01_5f0fcd4f81d5d06ad9b4c4c63e3ea51b82d6ae4d0558f1d475229b1121db6f64",
        "ZettaScaleLabs/ros-z crates/ros-z-codegen/tests/hash_regression.rs",
    ),
    (
        "std_msgs/msg/Header",
        "RIHS01_f49fb3ae2cf070f793645ff749683ac6b06203e41c891e17701b1cb597ce6a01",
        "ZettaScaleLabs/ros-z crates/ros-z-codegen/tests/hash_regression.rs",
    ),
    (
        "geometry_msgs/msg/PoseStamped",
        "RIHS01_10f3786d7d40fd2b54367835614bff85d4ad3b5dab62bf8bca0cc232d73b4cd8",
        "ZettaScaleLabs/ros-z crates/ros-z-codegen/tests/hash_regression.rs",
    ),
    (
        "geometry_msgs/msg/Accel",
        "RIHS01_dc448243ded9b1fcbcca24aba0c22f013dae06c354ba2d849571c0a2a3f57ca0",
        "ternaris/rosbags tests/rosbags/typesys/test_hashing.py",
    ),
    (
        "builtin_interfaces/msg/Time",
        "RIHS01_b106235e25a4c5ed35098aa0a61a3ee9c9b18d197f398b0e4206cea9acf9c197",
        "ZettaScaleLabs/ros-z crates/ros-z-schema/src/hash.rs (its own regression value)",
    ),
]


@pytest.mark.parametrize("type_name, expected, source", PUBLISHED, ids=[p[0] for p in PUBLISHED])
def test_type_hashes_equal_the_published_ones(type_name, expected, source):
    """The type store otgym takes its definitions and hashes from (rosbags' ROS 2
    Jazzy) gives the values published elsewhere; otgym's own types among them carry
    those hashes in their keys."""
    assert schemas.STORE.hash_rihs01(type_name) == expected, source
    if type_name in TYPE_HASH:
        assert TYPE_HASH[type_name] == expected, source


def test_every_type_otgym_uses_hashes_alike_in_jazzy_and_the_latest_distribution():
    """No published hash was found for PoseArray, WrenchStamped, Joy, Float64, Path and
    CompressedImage; their definitions (and so their hashes) are the same in ROS 2
    Jazzy, whose store otgym uses, and in the latest distribution rosbags knows."""
    from rosbags.typesys import Stores, get_typestore

    latest = get_typestore(Stores.LATEST)
    for type_name in schemas.SCHEMAS:
        assert TYPE_HASH[type_name] == latest.hash_rihs01(type_name), type_name


# --- a ROS 2 peer's view -----------------------------------------------------------------------
def parse_token(key: str) -> dict:
    """A liveliness token as rmw_zenoh's ``Entity::make`` reads it."""
    parts = key.split("/")
    assert parts[0] == "@ros2_lv" and len(parts) >= 9 and all(parts), key
    entity = {
        "domain": int(parts[1]),
        "zid": parts[2],
        "nid": parts[3],
        "id": parts[4],
        "kind": parts[5],
        "enclave": parts[6].replace("%", "/"),
        "namespace": parts[7].replace("%", "/"),
        "node": parts[8].replace("%", "/"),
    }
    if entity["kind"] in ("MP", "MS"):
        assert len(parts) == 13, key
        qos = parts[12].split(":")
        assert len(qos) == 6, key
        history = qos[2].split(",")
        entity.update(
            topic=parts[9].replace("%", "/"),
            type=parts[10].replace("%", "/"),
            hash=parts[11].replace("%", "/"),
            reliability=int(qos[0] or 1),
            durability=int(qos[1] or 2),
            history=int(history[0] or 1),
            depth=int(history[1] or 42),
        )
    return entity


def peer_session(endpoint: str) -> zenoh.Session:
    """A zenoh peer as rmw_zenoh configures one (no multicast), connected to ``endpoint``."""
    config = zenoh.Config()
    config.insert_json5("mode", '"peer"')
    config.insert_json5("connect/endpoints", f'["{endpoint}"]')
    config.insert_json5("listen/endpoints", '["tcp/127.0.0.1:0"]')
    config.insert_json5("scouting/multicast/enabled", "false")
    return zenoh.open(config)


class Graph:
    """The tokens a peer sees under ``@ros2_lv/<domain>/**``, kept as they come and go."""

    def __init__(self, session: zenoh.Session, domain: int = 0):
        self.tokens: set[str] = set()
        self.lock = threading.Lock()
        self.handle = session.liveliness().declare_subscriber(f"@ros2_lv/{domain}/**", self.on_sample, history=True)

    def on_sample(self, sample) -> None:
        with self.lock:
            (self.tokens.add if sample.kind == zenoh.SampleKind.PUT else self.tokens.discard)(str(sample.key_expr))

    def entities(self, **match) -> list[dict]:
        with self.lock:
            parsed = [parse_token(t) for t in self.tokens]
        return [e for e in parsed if all(e.get(k) == v for k, v in match.items())]


def test_a_ros2_peer_sees_the_node_its_publishers_and_subscriptions_with_types_hashes_and_qos():
    endpoint = free_endpoint()
    sim = Node("sim", "sim", listen=[endpoint])
    peer = peer_session(endpoint)
    try:
        graph = Graph(peer)
        samples, sample_lock = [], threading.Lock()

        def keep(sample):
            with sample_lock:
                samples.append((str(sample.key_expr), sample.attachment.to_bytes(), sample.payload.to_bytes()))

        peer.declare_subscriber("0/otgym/traps/**", keep)
        sim.subscribe(msg.COMMAND, lambda *_: None)
        traps = np.array([[1.0, 2.0], [3.0, 4.0]])
        sim.wait_for_subscribers(msg.TRAPS)  # numbered from 1: nothing published before the peer listens
        for _ in range(3):
            sim.publish(msg.TRAPS, msg.pose_array(traps, 5.0))
        wait_until(lambda: len(samples) >= 3, 10.0)
        sim.publish(msg.MODE, msg.string("shared"))
        wait_until(lambda: graph.entities(kind="MP", topic=msg.MODE), 10.0)
        (node,) = graph.entities(kind="NN")
        assert node["node"] == "otgym_sim" and node["namespace"] == "/" and node["nid"] == node["id"] == "0"
        (traps_pub,) = graph.entities(kind="MP", topic="/otgym/traps")
        assert traps_pub["type"] == "geometry_msgs::msg::dds_::PoseArray_"
        assert traps_pub["hash"] == TYPE_HASH[msg.POSE_ARRAY]
        assert (traps_pub["reliability"], traps_pub["durability"], traps_pub["depth"]) == (1, 2, 1)
        (mode_pub,) = graph.entities(kind="MP", topic=msg.MODE)  # latched: transient local, depth 1
        assert (mode_pub["type"], mode_pub["durability"], mode_pub["depth"]) == (
            "std_msgs::msg::dds_::String_",
            1,
            1,
        )
        (command_sub,) = graph.entities(kind="MS", topic=msg.COMMAND)  # every command matters: keep all
        assert command_sub["history"] == 2 and command_sub["hash"] == TYPE_HASH[msg.STRING]
        assert {e["zid"] for e in graph.entities()} == {sim.zid}
        with sample_lock:
            received = list(samples)
        token = next(t for t in graph.tokens if "/MP/" in t and "%otgym%traps/" in t)
        for index, (key, attachment, payload) in enumerate(received[:3]):
            assert key == f"0/otgym/traps/geometry_msgs::msg::dds_::PoseArray_/{TYPE_HASH[msg.POSE_ARRAY]}"
            sequence, stamp_ns, length = struct.unpack_from("<qqB", attachment)
            assert len(attachment) == 33 and length == 16 and attachment[17:] == ros_graph.gid_of(token)
            assert sequence == index + 1 and abs(stamp_ns * 1e-9 - time.time()) < 60
            np.testing.assert_array_equal(msg.xy_um(msg.decode(msg.TRAPS, payload)), traps)
        sim.close()
        wait_until(lambda: not graph.entities(), 5.0)  # the node closed: its tokens went
    finally:
        sim.close()
        peer.close()


def test_namespace_and_domain_place_keys_and_tokens():
    endpoint = free_endpoint()
    with Node("device", "device0", listen=[endpoint], namespace="/rig1", domain=7) as node:
        peer = peer_session(endpoint)
        try:
            graph = Graph(peer, domain=7)
            seen = []
            peer.declare_subscriber("7/rig1/otgym/**", lambda sample: seen.append(str(sample.key_expr)))
            wait_until(lambda: (node.publish(msg.twist_topic("device0"), _twist_stamped(1.0)), seen)[1], 10.0)
            assert seen[0].startswith("7/rig1/otgym/device/device0/twist/geometry_msgs::msg::dds_::TwistStamped_/")
            wait_until(lambda: graph.entities(kind="MP"), 10.0)  # the token travels apart from the data
            (entity,) = graph.entities(kind="MP")
            assert entity["namespace"] == "/rig1" and entity["topic"] == "/rig1/otgym/device/device0/twist"
            assert entity["node"] == "otgym_device_device0" and entity["domain"] == 7
        finally:
            peer.close()


def _twist_stamped(vx_m_s: float) -> bytes:
    from otgym.teleop.device import Sample

    return msg.twist(Sample(0.0, 0, np.zeros(3), (vx_m_s * 1e3, 0.0, 0.0), 1), time.time(), "device0")


@pytest.mark.parametrize(
    "call, text",
    [
        (lambda: ros_graph.check_namespace("/rig 1"), "namespace"),
        (lambda: ros_graph.check_namespace("/rig1/"), "trailing"),
        (lambda: ros_graph.check_namespace("/1rig"), "not starting with a digit"),
        (lambda: ros_graph.check_node_name("otgym-sim"), "node name"),
        (lambda: ros_graph.domain_id({"ROS_DOMAIN_ID": "300"}), "ROS_DOMAIN_ID"),
        (lambda: ros_graph.domain_id({"ROS_DOMAIN_ID": "x"}), "ROS_DOMAIN_ID"),
        (lambda: ros_graph.check_topic_name("/cmd vel"), "topic name"),
    ],
)
def test_names_follow_ros2_rules(call, text):
    with pytest.raises(ValueError, match=text):
        call()


def test_valid_names_pass():
    assert ros_graph.check_namespace("rig1/arm_2") == "/rig1/arm_2" and ros_graph.check_namespace("/") == "/"
    assert ros_graph.domain_id({}) == 0 and ros_graph.domain_id({"ROS_DOMAIN_ID": "42"}) == 42
    assert ros_graph.resolve_topic("cmd_vel", "/rig1") == "/rig1/cmd_vel"
    assert ros_graph.resolve_topic("/cmd_vel", "/rig1") == "/cmd_vel"


# --- bad input from outside ----------------------------------------------------------------------
def _attachment(sequence: int, gid: bytes = bytes(range(16))) -> bytes:
    return struct.pack("<qqB", sequence, time.time_ns(), 16) + gid


TWIST_TOPIC = msg.twist_topic("device0")
TWIST_KEY = ("geometry_msgs::msg::dds_::TwistStamped_", TYPE_HASH[msg.TWIST_STAMPED])


def test_intake_drops_and_counts_each_kind_of_bad_input_and_reports_a_mismatch_once():
    counts = Counts()
    intake = Intake(counts)
    good = _twist_stamped(0.001)
    sequence = iter(range(1, 1000))

    def check(data=good, key=TWIST_KEY, attachment=None):
        return intake.check(TWIST_TOPIC, *key, _attachment(next(sequence)) if attachment is None else attachment, data)

    assert check() is not None
    for _ in range(5):
        assert check(key=(TWIST_KEY[0], "RIHS01_" + "0" * 64)) is None  # a TwistStamped of another definition
    assert check(key=("geometry_msgs::msg::dds_::Twist_", TYPE_HASH[msg.TWIST])) is None  # another type
    assert check(data=b"\x00\x00" + good[2:]) is None  # big-endian encapsulation
    assert check(data=good + bytes(5000)) is None  # larger than any TwistStamped can be
    assert check(data=_twist_stamped(20.0)) is None  # 20 m/s: out of range
    assert check(data=_twist_stamped(float("nan"))) is None
    assert check(attachment=b"") is None and check(attachment=_attachment(10_000)[:20]) is None
    assert check(attachment=_attachment(999)) is not None
    assert check(attachment=_attachment(999)) is None  # the same sequence number again: a replay
    assert check(attachment=_attachment(3)) is None  # older
    assert check(attachment=_attachment(3, gid=bytes(16))) is not None  # another publisher has its own numbers
    reasons = {reason: n for (topic, reason), n in counts.reasons.items()}
    assert reasons == {"hash": 5, "type": 1, "malformed": 3, "size": 1, "attachment": 2, "stale": 2}
    assert counts.received[TWIST_TOPIC] == 3 and counts.dropped[TWIST_TOPIC] == 14
    assert len(counts.reports) == 2  # the wrong hash and the wrong type, once each


def test_bad_messages_over_the_wire_are_dropped_counted_and_never_applied():
    """A raw peer publishes on a device's twist key: a good twist is applied; a wrong
    hash, a stale sequence number and a missing attachment are not."""
    from otgym.bus.nodes import RemoteDevice

    endpoint = free_endpoint()
    with Node("sim", "sim", listen=[endpoint]) as sim:
        remote = RemoteDevice(sim, "device0")
        remote.start()
        peer = peer_session(endpoint)
        try:
            good_key = f"0/otgym/device/device0/twist/{TWIST_KEY[0]}/{TWIST_KEY[1]}"
            wrong_key = f"0/otgym/device/device0/twist/{TWIST_KEY[0]}/RIHS01_{'1' * 64}"
            counter = iter(range(1, 10_000))
            wait_until(
                lambda: (
                    peer.put(good_key, _twist_stamped(0.001), attachment=_attachment(next(counter))),
                    remote.read(),
                )[1],
                10.0,
            )
            # a peer's puts arrive in order: once the last one put is in, nothing put
            # before it is still on the way (each try marked by its own speed)
            for tries in range(1, 21):
                last = next(counter)
                peer.put(good_key, _twist_stamped(0.002 * tries), attachment=_attachment(last))
                if poll_until(lambda: remote.read().velocity_mm_s[0] == pytest.approx(2.0 * tries), 5.0):
                    break
            applied = sim.received[TWIST_TOPIC]
            assert not sim.dropped.get(TWIST_TOPIC, 0)
            for _ in range(3):
                peer.put(wrong_key, _twist_stamped(0.005), attachment=_attachment(next(counter)))
            peer.put(good_key, _twist_stamped(0.005), attachment=_attachment(last))  # replayed number
            peer.put(good_key, _twist_stamped(0.005))  # no attachment
            wait_until(lambda: sim.dropped.get(TWIST_TOPIC, 0) == 5, 5.0)
            assert sim.received[TWIST_TOPIC] == applied
            np.testing.assert_allclose(remote.read().velocity_mm_s, [2.0 * tries, 0.0, 0.0])  # the last good one
            reasons = {reason: n for (topic, reason), n in sim.drop_reasons.items() if topic == TWIST_TOPIC}
            assert reasons == {"hash": 3, "stale": 1, "attachment": 1}
            assert sum("dropping messages" in r for r in sim.counts.reports) == 1
        finally:
            peer.close()


def test_a_ros2_publisher_of_another_type_or_qos_is_reported_once():
    endpoint = free_endpoint()
    with Node("sim", "sim", listen=[endpoint]) as sim:
        sim.subscribe(msg.COMMAND, lambda *_: None)
        peer = peer_session(endpoint)
        try:
            zid = str(peer.zid())
            best_effort = ros_graph.Qos(ros_graph.BEST_EFFORT, ros_graph.VOLATILE, ros_graph.KEEP_ALL, 42)
            wrong = ros_graph.entity_token(
                0, zid, 0, 1, "MP", "/", "talker", "/otgym/command", msg.STRING, "RIHS01_" + "2" * 64, best_effort
            )
            tokens = [peer.liveliness().declare_token(wrong)]
            wait_until(lambda: len(sim.counts.reports) == 2, 10.0)
            tokens.append(peer.liveliness().declare_token(wrong.replace("/0/1/MP/", "/0/2/MP/")))  # same offence again
            # tokens arrive in order: once a third publisher's new offence is reported, the
            # repeated one has been seen, and must have added no report
            other = wrong.replace("/0/1/MP/", "/0/3/MP/").replace("RIHS01_" + "2" * 64, "RIHS01_" + "3" * 64)
            tokens.append(peer.liveliness().declare_token(other))
            wait_until(lambda: any("RIHS01_3333" in r for r in sim.counts.reports), 10.0)
            assert len(sim.counts.reports) == 3
            assert any("RIHS01_2222" in r for r in sim.counts.reports)
            assert any("best effort" in r for r in sim.counts.reports)
        finally:
            peer.close()


@pytest.mark.parametrize(
    "args, env, message",
    [
        (["sim", "--namespace", "/1rig"], {}, "namespace"),
        (["device", "--device", "twist", "--twist-topic", "cmd vel"], {}, "topic name"),
        (["foxglove", "--port", "70000"], {}, "--port must lie in [0, 65535], not 70000"),
        (["recorder", "--out", "x"], {"ROS_DOMAIN_ID": "999"}, "ROS_DOMAIN_ID"),
    ],
)
def test_bad_ros2_options_end_in_one_error_line_and_exit_2(args, env, message, tmp_path, monkeypatch):
    """Run in this process (``tests.otgym_cli``): each is refused before a node starts."""
    from tests.otgym_cli import run_otgym

    monkeypatch.chdir(tmp_path)
    for name, value in env.items():
        monkeypatch.setenv(name, value)
    run = run_otgym(["node", *args])
    lines = run.stderr.strip().splitlines()
    assert run.returncode == 2 and len(lines) == 1 and lines[0].startswith("error:") and message in lines[0], run.stderr
    assert not any(tmp_path.iterdir())  # nothing written
