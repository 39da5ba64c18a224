"""A session as Foxglove shows it: the 3D scene (``foxglove.SceneUpdate``) and plottable
values, built from what the simulator publishes on the bus (``otgym.bus.messages``), so
the live node (``otgym node foxglove``) and a recording (its ``/otgym/scene`` channel)
draw the same thing.

``SceneTracker.take(topic, message)`` keeps the latched description, chip and route and
answers each tick's ``/otgym/bodies`` with what to send (``Output``: a Foxglove topic,
and protobuf bytes or a JSON-able dict):

- ``SCENE_TOPIC`` (``foxglove.SceneUpdate``, frame ``chip``, um, the chip's own axes: x
  right, y down): entity ``chip`` (the walls: the chip image's half-gray contours as
  line strips; the route as a line strip; the goal as a disc of the goal tolerance),
  re-sent every ``STATIC_PERIOD_S`` of stamps so a viewer that seeks or joins late has
  it; entity ``bodies`` every tick (each sphere at its centre with its radius, coloured
  by kind: robot, cell, obstacle, bead) and entity ``traps`` (a small cross per trap);
- ``ALPHA_TOPIC`` ``{"alpha"}`` on each ``/otgym/shared/alpha``;
- ``CONTACT_TOPIC`` ``{"x_pn", "y_pn", "magnitude_pn"}`` on each ``/otgym/contact_force``;
- ``LAG_TOPIC`` ``{"lag_um": [per trap], "max_um"}`` each tick: each trap's distance to
  the sphere it holds.

Nothing is drawn before the session's description has arrived (the radii and kinds
come from it). foxglove-sdk (``pip install otgym[foxglove]``) provides the schemas; the
module imports without it and ``available()`` says whether it can run.
"""

from __future__ import annotations

import dataclasses
import io
import json
import threading

import numpy as np

from otgym.bus import messages as msg

SCENE_TOPIC = "/otgym/scene"
ALPHA_TOPIC = "/otgym/plot/alpha"
CONTACT_TOPIC = "/otgym/plot/contact_force"
LAG_TOPIC = "/otgym/plot/handle_lag"
STATIC_PERIOD_S = 1.0
KIND_COLOURS = {
    "robot": (0.95, 0.6, 0.1, 1.0),
    "cell": (0.2, 0.75, 0.3, 0.9),
    "obstacle": (0.85, 0.2, 0.2, 0.9),
    "bead": (0.6, 0.6, 0.9, 0.9),
}
WALL_COLOUR, ROUTE_COLOUR, GOAL_COLOUR, TRAP_COLOUR = (
    (0.8, 0.8, 0.8, 1.0),
    (0.3, 0.6, 1.0, 1.0),
    (0.3, 1.0, 0.5, 0.4),
    (1.0, 1.0, 0.2, 1.0),
)


def available() -> bool:
    try:
        import foxglove.messages  # noqa: F401
    except ImportError:
        return False
    return True


@dataclasses.dataclass(frozen=True)
class Output:
    topic: str
    payload: object
    """protobuf bytes (the scene) or a dict (sent as JSON)."""
    stamp_ns: int


def load_contour_tools() -> None:
    """Import what ``wall_contours_um`` needs: Pillow, and scikit-image's contour functions
    with the SciPy modules they load lazily (about 1 s of CPU cold). A tracker calls it
    when it is made, so that the session's first chip image does not hold up the
    messages behind it."""
    from PIL import Image  # noqa: F401
    from skimage import measure

    measure.find_contours, measure.approximate_polygon  # noqa: B018  (lazy attributes: loaded here)


def wall_contours_um(png: bytes, pixel_size_um: float) -> list[np.ndarray]:
    """The chip's walls: the half-gray contours of its image (simplified to half a
    pixel), each (N, 2) um; pixel centres at +0.5 pixel (``otgym.sim.chip``)."""
    from PIL import Image
    from skimage import measure

    image = np.asarray(Image.open(io.BytesIO(png)).convert("L"), float) / 255.0
    padded = np.pad(image, 1, constant_values=0.0)  # the image border is a wall too
    contours = [measure.approximate_polygon(c, tolerance=0.5) for c in measure.find_contours(padded, 0.5)]
    return [(contour[:, ::-1] - 1 + 0.5) * pixel_size_um for contour in contours]


class SceneTracker:
    """Turns bus messages into Foxglove outputs (see the module's docstring)."""

    def __init__(self):
        load_contour_tools()
        self.description: dict | None = None
        self.walls_um: list[np.ndarray] = []
        self.route_um = np.zeros((0, 2))
        self._png: bytes | None = None
        self._traps: np.ndarray | None = None
        self._static_sent_s: float | None = None

    def take(self, topic: str, message) -> list[Output]:
        if topic == msg.SESSION:
            self.description = json.loads(message.data)
            self._walls_from_png()
            self._static_sent_s = None
        elif topic == msg.CHIP:
            self._png = bytes(message.data)
            self._walls_from_png()
            self._static_sent_s = None
        elif topic == msg.ROUTE:
            self.route_um = np.array([(p.pose.position.x, p.pose.position.y) for p in message.poses]).reshape(-1, 2)
            self._static_sent_s = None
        elif topic == msg.TRAPS:
            self._traps = msg.xy_um(message)
        elif topic == msg.ALPHA:
            return [Output(ALPHA_TOPIC, {"alpha": float(message.data)}, 0)]
        elif topic == msg.CONTACT_FORCE:
            force_pn = msg.force_n(message)[:2] * 1e12
            stamp_ns = _stamp_ns(message)
            values = {"x_pn": float(force_pn[0]), "y_pn": float(force_pn[1])}
            return [Output(CONTACT_TOPIC, {**values, "magnitude_pn": float(np.hypot(*force_pn))}, stamp_ns)]
        elif topic == msg.BODIES and self.description is not None:
            return self._tick(msg.xy_um(message), _stamp_ns(message))
        return []

    def _walls_from_png(self) -> None:
        if self._png is not None and self.description is not None:
            self.walls_um = wall_contours_um(self._png, float(self.description["chip"]["pixel_size_um"]))

    def _tick(self, spheres_um: np.ndarray, stamp_ns: int) -> list[Output]:
        from foxglove import messages as fm

        kinds = self.description["sphere_kind"]
        radii = self.description.get("sphere_radius_um") or [1.0] * len(kinds)
        if len(spheres_um) != len(kinds):
            return []  # not this session's bodies
        stamp = fm.Timestamp(sec=stamp_ns // 1_000_000_000, nsec=stamp_ns % 1_000_000_000)
        entities = [
            fm.SceneEntity(
                timestamp=stamp,
                frame_id="chip",
                id="bodies",
                spheres=[
                    fm.SpherePrimitive(
                        pose=_pose(fm, x, y),
                        size=fm.Vector3(x=2 * r, y=2 * r, z=2 * r),
                        color=_colour(fm, KIND_COLOURS.get(kind, (1, 1, 1, 1))),
                    )
                    for (x, y), kind, r in zip(spheres_um, kinds, radii)
                ],
                metadata=[fm.KeyValuePair(key="kinds", value=",".join(kinds))],
            )
        ]
        outputs = []
        if self._traps is not None:
            entities.append(_traps_entity(fm, stamp, self._traps))
            handles = np.asarray(self.description["handle_spheres"], int)
            if len(handles) == len(self._traps):
                lag = np.linalg.norm(self._traps - spheres_um[handles], axis=1)
                outputs.append(Output(LAG_TOPIC, {"lag_um": lag.tolist(), "max_um": float(lag.max())}, stamp_ns))
        stamp_s = stamp_ns * 1e-9
        if self._static_sent_s is None or stamp_s - self._static_sent_s >= STATIC_PERIOD_S:
            entities.append(self._static_entity(fm, stamp))
            self._static_sent_s = stamp_s
        return [Output(SCENE_TOPIC, fm.SceneUpdate(entities=entities).encode(), stamp_ns), *outputs]

    def _static_entity(self, fm, stamp):
        line_strip = fm.LinePrimitiveLineType.LineStrip
        lines = [
            fm.LinePrimitive(
                type=line_strip,
                thickness=0.5,
                points=[fm.Point3(x=float(x), y=float(y), z=0.0) for x, y in contour],
                color=_colour(fm, WALL_COLOUR),
            )
            for contour in self.walls_um
        ]
        cylinders = []
        if len(self.route_um):
            lines.append(
                fm.LinePrimitive(
                    type=line_strip,
                    thickness=0.8,
                    points=[fm.Point3(x=float(x), y=float(y), z=0.0) for x, y in self.route_um],
                    color=_colour(fm, ROUTE_COLOUR),
                )
            )
            tolerance = float(self.description.get("goal_tolerance_um", 1.0))
            goal_x, goal_y = self.route_um[-1]
            cylinders.append(
                fm.CylinderPrimitive(
                    pose=_pose(fm, goal_x, goal_y),
                    size=fm.Vector3(x=2 * tolerance, y=2 * tolerance, z=0.2),
                    bottom_scale=1.0,
                    top_scale=1.0,
                    color=_colour(fm, GOAL_COLOUR),
                )
            )
        return fm.SceneEntity(timestamp=stamp, frame_id="chip", id="chip", lines=lines, cylinders=cylinders)


def _traps_entity(fm, stamp, traps_um: np.ndarray):
    arm = 1.0
    points = []
    for x, y in traps_um:
        points += [fm.Point3(x=float(x - arm), y=float(y), z=0.0), fm.Point3(x=float(x + arm), y=float(y), z=0.0)]
        points += [fm.Point3(x=float(x), y=float(y - arm), z=0.0), fm.Point3(x=float(x), y=float(y + arm), z=0.0)]
    line = fm.LinePrimitive(
        type=fm.LinePrimitiveLineType.LineList, thickness=0.3, points=points, color=_colour(fm, TRAP_COLOUR)
    )
    return fm.SceneEntity(timestamp=stamp, frame_id="chip", id="traps", lines=[line])


def _pose(fm, x: float, y: float):
    return fm.Pose(
        position=fm.Vector3(x=float(x), y=float(y), z=0.0), orientation=fm.Quaternion(x=0.0, y=0.0, z=0.0, w=1.0)
    )


def _colour(fm, rgba):
    r, g, b, a = rgba
    return fm.Color(r=r, g=g, b=b, a=a)


def _stamp_ns(message) -> int:
    return int(message.header.stamp.sec) * 1_000_000_000 + int(message.header.stamp.nanosec)


def scene_schema():
    """(name, encoding, data) of the scene's schema (a protobuf FileDescriptorSet)."""
    from foxglove import messages as fm

    schema = fm.SceneUpdate.get_schema()
    return schema.name, schema.encoding, bytes(schema.data)


class SceneRecording:
    """Adds the scene to a recording: ``take(topic, message)`` for each message recorded;
    each scene update goes to ``write(topic, schema, message_encoding, data, log_time_ns)``
    (``McapRecorder.write_encoded``). Does nothing without foxglove-sdk."""

    def __init__(self, write):
        self.write = write
        self.enabled = available()
        self.tracker = SceneTracker()
        self._schema = scene_schema() if self.enabled else None
        self._lock = threading.Lock()

    def take(self, topic: str, message) -> None:
        if not self.enabled:
            return
        with self._lock:
            outputs = self.tracker.take(topic, message)
        for output in outputs:
            if output.topic == SCENE_TOPIC:
                self.write(SCENE_TOPIC, self._schema, "protobuf", output.payload, output.stamp_ns)
