"""Foxglove: ``otgym node foxglove`` (a process this test starts) serves a session that
this test publishes on the bus; a WebSocket client written here speaks Foxglove's
protocol (subprotocol ``foxglove.sdk.v1``, formerly ``foxglove.websocket.v1``: ``serverInfo``, ``advertise``,
``subscribe``, binary ``messageData`` = opcode 1, subscription id u32, log time u64,
payload), decodes the scene with the protobuf schema the server advertises, and checks
it against what was published. A recording gets the same scene channel. Foxglove
itself (the app) is not run here."""

from __future__ import annotations

import asyncio
import base64
import json
import struct
import time

import numpy as np
import pytest

from otgym.bus import messages as msg
from otgym.bus import task_messages
from otgym.bus.transport import Node
from tests.bus.test_nodes import children, free_endpoint, spawn, wait_for_line  # noqa: F401  (fixture)

pytest.importorskip("foxglove")
websockets = pytest.importorskip("websockets")
SUBPROTOCOLS = ("foxglove.sdk.v1", "foxglove.websocket.v1")
"""The WebSocket protocol's names: foxglove-sdk 0.30 answers only the first, the
protocol's newer name; Foxglove apps before it spoke the second."""


def scene_class(schema_b64: str):
    """The protobuf class of ``foxglove.SceneUpdate`` from an advertised FileDescriptorSet."""
    from google.protobuf import descriptor_pb2, descriptor_pool, message_factory

    files = descriptor_pb2.FileDescriptorSet.FromString(base64.b64decode(schema_b64))
    pool = descriptor_pool.DescriptorPool()
    for file in files.file:
        pool.Add(file)
    return message_factory.GetMessageClass(pool.FindMessageTypeByName("foxglove.SceneUpdate"))


def _has_bodies(update) -> bool:
    return any(entity.id == "bodies" for entity in update.entities)


async def first_scene(url: str, publish, deadline_s: float = 60.0, wanted=_has_bodies):
    """Connect, subscribe to /otgym/scene, call ``publish()`` until a scene that is
    ``wanted`` (default: one with bodies) arrives; returns (advertised channel, decoded
    SceneUpdate)."""
    async with websockets.connect(url, subprotocols=list(SUBPROTOCOLS)) as socket:
        assert socket.subprotocol in SUBPROTOCOLS
        info = json.loads(await socket.recv())
        assert info["op"] == "serverInfo"
        channel = None
        end = time.monotonic() + deadline_s
        while time.monotonic() < end:
            publish()
            try:
                frame = await asyncio.wait_for(socket.recv(), 0.2)
            except TimeoutError:
                continue
            if isinstance(frame, str):
                message = json.loads(frame)
                if message["op"] == "advertise" and channel is None:
                    scenes = [c for c in message["channels"] if c["topic"] == "/otgym/scene"]
                    if scenes:
                        channel = scenes[0]
                        await socket.send(
                            json.dumps({"op": "subscribe", "subscriptions": [{"id": 7, "channelId": channel["id"]}]})
                        )
                continue
            opcode, subscription, _log_time_ns = struct.unpack_from("<BIQ", frame)
            if opcode == 1 and subscription == 7:
                update = scene_class(channel["schema"]).FromString(frame[13:])
                if wanted(update):
                    return channel, update
        raise AssertionError(f"no scene that {wanted.__name__} arrived")


def session(stamp_s: float):
    from tests.bus.test_messages import stand_in_task

    task = stand_in_task()
    return task, task_messages.session_messages(task, [], stamp_s)


@pytest.mark.slow
def test_the_foxglove_node_serves_the_scene_of_the_running_session(children):  # noqa: F811
    endpoint = free_endpoint()
    children.append(spawn("-m", "otgym", "node", "foxglove", "--port", "0", "--connect", endpoint))
    with Node("sim", "sim", listen=[endpoint]) as sim:
        line = wait_for_line(children[0], "ready")
        url = line.split(" on ")[-1].strip()
        assert url.startswith("ws://127.0.0.1:")
        task, described = session(time.time())
        for topic, data in described:
            sim.publish(topic, data)
        spheres_um = np.array([[10.0, 20.0], [13.0, 20.0], [40.5, 60.25]])  # robot, robot, cell
        traps_um = np.array([[10.5, 20.0]])

        def publish():
            sim.publish(msg.TRAPS, msg.pose_array(traps_um, time.time()))
            sim.publish(msg.BODIES, msg.pose_array(spheres_um, time.time()))

        def whole(update) -> bool:
            """Bodies with the chip's static entity once the latched route is in: the
            route and the goal come by their own topic and may follow the first bodies."""
            return _has_bodies(update) and any(e.id == "chip" and e.cylinders for e in update.entities)

        channel, update = asyncio.run(first_scene(url, publish, wanted=whole))
    assert channel["encoding"] == "protobuf" and channel["schemaName"] == "foxglove.SceneUpdate"
    bodies = next(e for e in update.entities if e.id == "bodies")
    assert bodies.frame_id == "chip" and len(bodies.spheres) == 3
    positions = np.array([(s.pose.position.x, s.pose.position.y) for s in bodies.spheres])
    np.testing.assert_array_equal(positions, spheres_um)
    np.testing.assert_allclose([s.size.x for s in bodies.spheres], [3.0, 3.0, 8.0])  # diameters from the radii
    chip = next(e for e in update.entities if e.id == "chip")
    assert len(chip.lines) >= 2 and len(chip.cylinders) == 1  # walls and route; the goal
    goal = chip.cylinders[0].pose.position
    assert (goal.x, goal.y) == tuple(task.route_um[-1])
    traps = next(e for e in update.entities if e.id == "traps")
    crosses = np.array([(p.x, p.y) for p in traps.lines[0].points]).reshape(-1, 4, 2).mean(axis=1)
    np.testing.assert_allclose(crosses, traps_um)


def test_a_recording_carries_the_scene_foxglove_replays(tmp_path):
    from mcap.reader import make_reader

    from otgym.ui.recording import SessionRecording

    recording = SessionRecording(tmp_path / "session.mcap", clock_s=lambda: 1_700_000_000.0)
    task, described = session(1_700_000_000.0)
    for topic, data in described:
        recording.write(topic, data)
    spheres_um = np.array([[1.0, 2.0], [4.0, 2.0], [30.0, 31.0]])
    for tick in range(3):
        recording.write(msg.TRAPS, msg.pose_array(np.array([[1.0, 2.0]]), 1_700_000_000.0 + tick))
        recording.write(msg.BODIES, msg.pose_array(spheres_um + tick, 1_700_000_000.0 + tick))
    recording.close()
    with open(tmp_path / "session.mcap", "rb") as stream:
        scenes = [
            (schema, message) for schema, channel, message in make_reader(stream).iter_messages(topics=["/otgym/scene"])
        ]
    assert len(scenes) == 3
    schema, message = scenes[-1]
    assert (schema.name, schema.encoding) == ("foxglove.SceneUpdate", "protobuf")
    update = scene_class(base64.b64encode(schema.data).decode()).FromString(message.data)
    bodies = next(e for e in update.entities if e.id == "bodies")
    np.testing.assert_array_equal([(s.pose.position.x, s.pose.position.y) for s in bodies.spheres], spheres_um + 2)
    assert message.log_time == (1_700_000_000 + 2) * 1_000_000_000
