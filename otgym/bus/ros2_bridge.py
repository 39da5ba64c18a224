"""``otgym node ros2``: a bridge between otgym's bus (zenoh, ``otgym.bus.transport``)
and a ROS 2 graph reached through rclpy, on whatever middleware ``RMW_IMPLEMENTATION``
names (Fast DDS, rmw_fastrtps_cpp, when unset), in the domain ``ROS_DOMAIN_ID``.

It is one ROS 2 node, ``otgym_ros2`` in the namespace of ``--namespace``, and one otgym
node (role ``ros2``). Messages cross as their CDR bytes, unchanged: rclpy publishes and
takes serialized messages (``raw=True``), and otgym's bus carries the same bytes
(``otgym.bus.messages``). Topic names, types and QoS are otgym's (``otgym.bus.topics``,
``transport.qos_of``): latched topics reliable, transient local, depth 1; trial events
and commands reliable, keep all; streams reliable, volatile, depth 1.

- To ROS 2: every topic of otgym's table that is not an input below (the traps, the
  bodies, alpha, the mode, the phase, trial events, the current trial, the session, the
  chip, the route, the contact force, each device's feedback, and the twist and buttons
  of devices not in ``devices``), and ``/otgym/markers``
  (``visualization_msgs/msg/MarkerArray``, ``otgym.bus.ros2_markers``), at most one
  array every ``markers_period_s``. The publishers of the table's fixed topics and of
  ``/otgym/markers`` are declared at start, so that ROS 2 subscribers have matched them
  (discovery takes seconds under load) before the session's first message; a device's
  topics are declared with its first message.
- To otgym: for each device in ``devices``, ``/otgym/device/<device>/twist``
  (``geometry_msgs/msg/TwistStamped``) and ``/otgym/device/<device>/buttons``
  (``sensor_msgs/msg/Joy``); ``/otgym/command`` (``std_msgs/msg/String``); with
  ``autonomy``, ``/otgym/autonomy/increments`` (``geometry_msgs/msg/PoseArray``); with
  ``rig``, ``/otgym/rig/poses`` (``PoseArray``: a rig's measured spheres, for
  ``otgym node sim --plant rig``); and
  ``twist_topics`` (``geometry_msgs/msg/Twist``) and ``twist_stamped_topics``
  (``TwistStamped``), such as teleop_twist_keyboard's ``/cmd_vel``, for
  ``otgym node device --device twist``. A topic goes one way only, so nothing the
  bridge sends comes back to it. Each message from ROS 2 passes otgym's checks
  (``messages.decode_as``) before it is sent on; one that fails is dropped and counted.

Back-pressure: a slow side never holds up the other. Each direction has its own
``otgym.bus.handover.Handover``: the receiving callback (zenoh's, or rclpy's executor)
only hands the message over and returns, and one thread per direction sends on. A
stream (QoS keep last, depth 1: traps, bodies, alpha, feedback, twists, increments, a
rig's poses) keeps only its latest message until that thread takes it, so a bridge
starved of CPU sends fewer, newer messages instead of falling behind, and zenoh's links
from the simulator never fill on its account; trial events, commands and latched
topics are all sent, in order.

The bridge declares otgym's liveliness token of each device in ``devices`` (and of an
autonomy node with ``autonomy``): the simulator answers the devices' twists with
feedback, and if the bridge goes away it takes their input as released (the traps
hold) and stops using the increments, as for otgym's own device and autonomy nodes.
Do not also run otgym nodes of those names.

Settings are ROS 2 parameters, given as ``--ros-args -p NAME:=VALUE`` (``PARAMETERS``).
rclpy is imported only here, inside the functions: otgym imports without ROS 2.
"""

from __future__ import annotations

import importlib
import math
import threading
import time
from collections.abc import Callable

from otgym.bus import messages as msg
from otgym.bus import ros2_markers, ros_graph, transport
from otgym.bus.handover import Handover

NODE_NAME = "otgym_ros2"
PARAMETERS = {
    "devices": (["device0"], "devices the ROS 2 graph drives: their twist and buttons go from ROS 2 to otgym"),
    "autonomy": (False, "carry /otgym/autonomy/increments from ROS 2 (for otgym node sim --autonomy remote)"),
    "rig": (False, "carry /otgym/rig/poses from ROS 2: a rig's measured spheres (for otgym node sim --plant rig)"),
    "twist_topics": (["/cmd_vel"], "geometry_msgs/msg/Twist topics carried to otgym (for --device twist)"),
    "twist_stamped_topics": ([], "geometry_msgs/msg/TwistStamped topics carried to otgym (for --device twist)"),
    "markers_period_s": (0.1, "least time between two MarkerArrays on /otgym/markers (0: every tick)"),
}
"""The bridge's ROS 2 parameters: (default, description)."""


def available() -> bool:
    """Whether rclpy and the message wheels import (``pip install 'otgym[ros2]'``)."""
    try:
        import geometry_msgs.msg  # noqa: F401
        import rclpy  # noqa: F401
        import visualization_msgs.msg  # noqa: F401
    except ImportError:
        return False
    return True


def install_hint() -> str:
    return (
        "needs ROS 2's Python wheels: pip install ros-rclpy ros-rmw-fastrtps-cpp ros-std-msgs ros-geometry-msgs "
        "ros-sensor-msgs ros-nav-msgs ros-visualization-msgs (otgym's extra [ros2])"
    )


def message_class(type_name: str):
    """The rclpy message class of ``pkg/msg/Type``."""
    package, _, name = type_name.split("/")
    return getattr(importlib.import_module(f"{package}.msg"), name)


def qos_profile(qos: ros_graph.Qos):
    """rclpy's QoSProfile of an otgym QoS (``transport.qos_of``)."""
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

    return QoSProfile(
        history=HistoryPolicy.KEEP_ALL if qos.history == ros_graph.KEEP_ALL else HistoryPolicy.KEEP_LAST,
        depth=qos.depth,
        reliability=ReliabilityPolicy.RELIABLE
        if qos.reliability == ros_graph.RELIABLE
        else ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.TRANSIENT_LOCAL
        if qos.durability == ros_graph.TRANSIENT_LOCAL
        else DurabilityPolicy.VOLATILE,
    )


def _keep_all(topic: str) -> bool:
    """Whether every message of ``topic`` crosses (events, commands, latched topics), not
    only the latest (streams: ``transport.STREAM_QOS``, also ROS 2 topics of other names)."""
    return transport.qos_of(topic) != transport.STREAM_QOS


class Settings:
    """The parameters' values, checked (ValueError with the reason otherwise)."""

    def __init__(self, values: dict):
        for name in ("devices", "twist_topics", "twist_stamped_topics"):
            if not isinstance(values[name], (list, tuple)) or not all(isinstance(v, str) for v in values[name]):
                raise ValueError(f"parameter {name} must be a list of names, e.g. [device0], not {values[name]!r}")
        self.devices = [msg.check_name(d) for d in values["devices"]]
        self.autonomy = bool(values["autonomy"])
        self.rig = bool(values["rig"])
        self.twist_topics = [ros_graph.check_topic_name(t) for t in values["twist_topics"]]
        self.twist_stamped_topics = [ros_graph.check_topic_name(t) for t in values["twist_stamped_topics"]]
        self.markers_period_s = float(values["markers_period_s"])
        if not (math.isfinite(self.markers_period_s) and 0.0 <= self.markers_period_s <= 3600.0):
            raise ValueError(f"parameter markers_period_s must lie in [0, 3600] s, not {values['markers_period_s']}")
        ros_inputs = set(self.twist_topics) & set(self.twist_stamped_topics)
        if ros_inputs:
            raise ValueError(f"{', '.join(sorted(ros_inputs))} cannot be both a Twist and a TwistStamped topic")


def open_ros_node(ros_args: list[str], namespace: str):
    """(context, rclpy node, Settings): rclpy started with ``ros_args`` (``--ros-args
    ...``; rclpy's own signal handlers off: the caller's handle SIGINT and SIGTERM) and
    the parameters declared and checked; ValueError for bad arguments or values."""
    import rclpy
    from rcl_interfaces.msg import ParameterDescriptor
    from rclpy.signals import SignalHandlerOptions

    context = rclpy.Context()
    try:
        rclpy.init(args=["otgym", *ros_args], context=context, signal_handler_options=SignalHandlerOptions.NO)
    except Exception as error:  # noqa: BLE001  rclpy raises its own error types for bad arguments
        raise ValueError(f"--ros-args: rclpy refused them ({str(error).splitlines()[0]})") from None
    try:
        node = rclpy.create_node(NODE_NAME, namespace=namespace, context=context)
        values = {}
        for name, (default, description) in PARAMETERS.items():
            # a list's type follows its value (rclpy reads an empty list as a byte array);
            # Settings checks that it holds text only
            descriptor = ParameterDescriptor(description=description, dynamic_typing=isinstance(default, list))
            value = node.declare_parameter(name, default, descriptor).value
            values[name] = [] if value is None else value  # "[]" on the command line reads as unset
        return context, node, Settings(values)
    except Exception as error:
        rclpy.try_shutdown(context=context)
        if isinstance(error, ValueError):
            raise
        raise ValueError(f"--ros-args: {str(error).splitlines()[0]}") from None


class Bridge:
    """Carries messages between the otgym node ``bus`` and the rclpy node ``ros`` (see
    the module's docstring); ``start`` declares everything and starts the two sending
    threads, then the caller spins ``ros``."""

    def __init__(self, bus: transport.Node, ros, settings: Settings, clock: Callable[[], float] = time.monotonic):
        self.bus, self.ros, self.settings, self.clock = bus, ros, settings, clock
        self.to_ros = 0
        self.to_otgym = 0
        self.dropped: dict[str, int] = {}
        """Messages from ROS 2 that failed otgym's checks, per topic."""
        self._publishers: dict[str, object] = {}
        self._lock = threading.Lock()
        self._send_lock = threading.Lock()
        """Held while a message from the bus goes to ROS 2, and by ``close``: nothing
        touches rclpy's publishers once they are being destroyed."""
        self._closed = False
        self._markers = ros2_markers.MarkerTracker()
        self._markers_sent_s: float | None = None
        self._tokens: list = []
        self.inputs: dict[str, str] = {msg.COMMAND: msg.STRING}
        for device in settings.devices:
            self.inputs[msg.twist_topic(device)] = msg.TWIST_STAMPED
            self.inputs[msg.buttons_topic(device)] = msg.JOY
        if settings.autonomy:
            self.inputs[msg.AUTONOMY] = msg.POSE_ARRAY
        if settings.rig:
            self.inputs[msg.RIG_POSES] = msg.POSE_ARRAY
        self._out = Handover(self._send_to_ros, _keep_all, "otgym-ros2-to-ros")
        self._in = Handover(self._send_to_otgym, _keep_all, "otgym-ros2-to-otgym")

    @property
    def superseded(self) -> int:
        """Stream messages, both ways, replaced by a newer one before they were sent."""
        return self._out.replaced + self._in.replaced

    def ros_topics(self) -> list[str]:
        """The ROS 2 topics of other names it carries to otgym, each with its type."""
        return [f"{t} (Twist)" for t in self.settings.twist_topics] + [
            f"{t} (TwistStamped)" for t in self.settings.twist_stamped_topics
        ]

    def start(self) -> None:
        """Declare the ROS 2 subscriptions and publishers, otgym's tokens and the bus subscription."""
        for topic, type_name in self.inputs.items():
            self._from_ros(topic, type_name, transport.qos_of(topic), otgym_topic=True)
        for type_name, topics in (
            (msg.TWIST, self.settings.twist_topics),
            (msg.TWIST_STAMPED, self.settings.twist_stamped_topics),
        ):
            for topic in topics:
                self._from_ros(topic, type_name, transport.STREAM_QOS, otgym_topic=False)
        for topic in msg.fixed_topics():  # matched by ROS 2 subscribers before the session's first message
            if topic not in self.inputs:
                self._declare(topic)
        self._markers_publisher = self.ros.create_publisher(
            message_class(ros2_markers.MARKER_ARRAY),
            ros2_markers.MARKERS_TOPIC.lstrip("/"),
            qos_profile(transport.STREAM_QOS),
        )
        self._out.start()
        self._in.start()
        liveliness = self.bus.session.liveliness()
        self._tokens = [liveliness.declare_token(f"otgym/node/device/{d}") for d in self.settings.devices]
        if self.settings.autonomy:
            self._tokens.append(liveliness.declare_token(f"otgym/node/autonomy/{self.bus.name}"))
        self.bus.subscribe("/otgym/**", self._on_bus)

    # --- ROS 2 -> otgym ----------------------------------------------------------------
    def _from_ros(self, topic: str, type_name: str, qos: ros_graph.Qos, otgym_topic: bool) -> None:
        def forward(data: bytes) -> None:
            self._in.put(topic, (type_name, otgym_topic, data))

        # otgym's topics are relative to the namespace (as on the bus); a ROS 2 topic as given
        name = topic.lstrip("/") if otgym_topic else topic
        self.ros.create_subscription(message_class(type_name), name, forward, qos_profile(qos), raw=True)

    def _send_to_otgym(self, topic: str, item) -> None:
        type_name, otgym_topic, data = item
        try:
            msg.decode_as(type_name, data, topic)
        except msg.MessageError:
            with self._lock:
                self.dropped[topic] = self.dropped.get(topic, 0) + 1
            return
        if otgym_topic:
            self.bus.publish(topic, data)
        else:
            self.bus.publish_ros(topic, type_name, data)
        with self._lock:
            self.to_otgym += 1

    # --- otgym -> ROS 2 ----------------------------------------------------------------
    def _on_bus(self, topic: str, message, data: bytes) -> None:
        if topic in self.inputs:
            return  # sent by this bridge, or another otgym node's input the graph drives
        self._out.put(topic, (message, data))

    def _send_to_ros(self, topic: str, item) -> None:
        with self._send_lock:
            if not self._closed:
                self._send(topic, *item)

    def _send(self, topic: str, message, data: bytes) -> None:
        publisher = self._publishers.get(topic) or self._declare(topic)
        publisher.publish(data)
        with self._lock:
            self.to_ros += 1
            markers = self._markers.take(topic, message)
            if markers is not None:
                now = self.clock()
                due = self._markers_sent_s is None or now - self._markers_sent_s >= self.settings.markers_period_s
                if not due:
                    markers = None
                else:
                    self._markers_sent_s = now
        if markers is not None:
            self._markers_publisher.publish(ros2_markers.marker_array(markers))

    def _declare(self, topic: str):
        with self._lock:
            if topic not in self._publishers:
                type_name = msg.topic_type(topic)
                self._publishers[topic] = self.ros.create_publisher(
                    message_class(type_name), topic.lstrip("/"), qos_profile(transport.qos_of(topic))
                )
            return self._publishers[topic]

    def close(self) -> None:
        """Stop sending both ways (after this, rclpy's node may be destroyed; what is still
        pending is not sent) and withdraw the devices' and autonomy's tokens."""
        self._out.close()
        self._in.close()
        with self._send_lock:
            self._closed = True
        for token in self._tokens:
            token.undeclare()
        self._tokens = []


def serve(
    stop: threading.Event, endpoints: dict, ros_args: list[str], on_ready: Callable[[str], None]
) -> dict[str, int]:
    """Run the bridge until ``stop`` is set; ``on_ready(text)`` once both sides are up.
    Returns its counts. ValueError (before the bus is opened) for bad ROS 2 arguments or
    parameters, or without rclpy."""
    if not available():
        raise ValueError(f"the ros2 node {install_hint()}")
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.utilities import get_rmw_implementation_identifier

    context, ros, settings = open_ros_node(ros_args, endpoints["namespace"])
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(ros)
    try:
        with transport.Node("ros2", "ros2", **endpoints) as bus:
            bridge = Bridge(bus, ros, settings)
            try:
                bridge.start()
                on_ready(
                    f"ros2 bridge as ROS 2 node {ros.get_fully_qualified_name()} on "
                    f"{get_rmw_implementation_identifier()}, domain {ros_graph.domain_id()}; "
                    f"from ROS 2: {', '.join([*sorted(bridge.inputs), *bridge.ros_topics()])}"
                )
                while not stop.is_set():
                    executor.spin_once(timeout_sec=0.1)
            finally:
                bridge.close()  # before rclpy's node is destroyed: a late zenoh callback sends nothing
            dropped = sum(bus.dropped.values()) + sum(bridge.dropped.values())
    finally:
        executor.shutdown()
        ros.destroy_node()
        rclpy.try_shutdown(context=context)
    return {"to_ros": bridge.to_ros, "to_otgym": bridge.to_otgym, "dropped": dropped, "superseded": bridge.superseded}
