"""``otgym node foxglove``: the running session served to Foxglove (foxglove-sdk's
WebSocket server, subprotocol ``foxglove.sdk.v1``, the one its handshake accepts) on ``--host``/``--port``
(127.0.0.1:8765: loopback only unless told otherwise). It subscribes to the sim's
topics like any node (``--connect``, ``--namespace``) and sends what
``otgym.bus.foxglove_scene`` makes of them: the 3D scene on ``/otgym/scene``
(``foxglove.SceneUpdate``, protobuf) and alpha, contact force and handle lag as JSON
topics to plot. In Foxglove: *Open connection* -> *Foxglove WebSocket* ->
``ws://127.0.0.1:8765``; a 3D panel showing ``/otgym/scene`` with display frame
``chip``, a Plot panel with ``/otgym/plot/alpha.alpha``."""

from __future__ import annotations

import threading


def foxglove_node(stop: threading.Event, endpoints: dict, *, host: str, port: int) -> None:
    """Serve the session until ``stop`` is set; one ``ready`` line with the address."""
    from otgym.bus import foxglove_scene as scene

    if not scene.available():
        raise ValueError("the foxglove node needs foxglove-sdk: pip install 'otgym[foxglove]'")
    import foxglove

    from otgym.bus.transport import Node

    context = foxglove.Context()
    name, encoding, data = scene.scene_schema()
    channels = {
        scene.SCENE_TOPIC: foxglove.Channel(
            scene.SCENE_TOPIC,
            schema=foxglove.Schema(name=name, encoding=encoding, data=data),
            message_encoding="protobuf",
            context=context,
        )
    }
    for topic in (scene.ALPHA_TOPIC, scene.CONTACT_TOPIC, scene.LAG_TOPIC):
        channels[topic] = foxglove.Channel(topic, message_encoding="json", context=context)
    try:
        server = foxglove.start_server(name="otgym", host=host, port=port, context=context)
    except Exception as error:  # noqa: BLE001  foxglove-sdk raises its own error types for a busy port
        raise ValueError(f"cannot serve Foxglove on {host}:{port}: {error}") from None
    tracker, lock, sent = scene.SceneTracker(), threading.Lock(), [0]

    def on_message(topic, message, data) -> None:
        with lock:
            outputs = tracker.take(topic, message)
        for output in outputs:
            channels[output.topic].log(output.payload, log_time=output.stamp_ns or None)
            sent[0] += 1

    try:
        with Node("foxglove", "foxglove", **endpoints) as node:
            node.subscribe("/otgym/**", on_message)
            print(f"ready: foxglove on ws://{host}:{server.port}", flush=True)
            while not stop.wait(0.25):
                pass
            dropped = sum(node.dropped.values())
    finally:
        server.stop()
    print(f"foxglove: {sent[0]} messages sent; {dropped} bus messages dropped by the checks", flush=True)
