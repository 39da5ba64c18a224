"""The session as RViz and Foxglove draw it from ROS 2: ``visualization_msgs/msg/MarkerArray``
on ``MARKERS_TOPIC`` (``/otgym/markers``), built from what the simulator publishes on
the bus (``otgym.bus.messages``), as ``otgym.bus.foxglove_scene`` builds Foxglove's scene.

``MarkerTracker.take(topic, message)`` keeps the latched description, chip and route
and the latest traps, and answers each tick's ``/otgym/bodies`` with the markers'
content (``Markers``: plain data, no ROS 2 import here); ``marker_array`` turns it into
the ROS 2 message (visualization_msgs, imported there). Frame ``chip``, lengths in um
as every otgym topic (x right, y down), z = 0. Namespaces (``ns``), each marker with id
0, 1, ... within its namespace:

- ``walls``: one ``LINE_STRIP`` per contour of the chip image's walls
  (``foxglove_scene.wall_contours_um``);
- ``route``: one ``LINE_STRIP`` of the planned route; ``goal``: a flat ``CYLINDER`` of
  the goal tolerance's radius at its end;
- ``robots``, ``cells``, ``obstacles``, ``beads``: one ``SPHERE`` per body of the kind,
  at its centre with its radius (the session's ``sphere_radius_um``);
- ``traps``: one ``LINE_LIST`` of a small cross per trap.

Every array starts with a ``DELETEALL`` marker, so a viewer drops what the previous
array drew (a body count that changes between sessions leaves nothing stale). Nothing
is drawn before the session's description has arrived (kinds and radii come from it).
"""

from __future__ import annotations

import dataclasses
import json

import numpy as np

from otgym.bus import messages as msg
from otgym.bus.foxglove_scene import (
    GOAL_COLOUR,
    KIND_COLOURS,
    ROUTE_COLOUR,
    TRAP_COLOUR,
    WALL_COLOUR,
    load_contour_tools,
    wall_contours_um,
)

MARKERS_TOPIC = "/otgym/markers"
MARKER_ARRAY = "visualization_msgs/msg/MarkerArray"
FRAME = "chip"
KIND_NAMESPACES = {"robot": "robots", "cell": "cells", "obstacle": "obstacles", "bead": "beads"}
TRAP_ARM_UM = 1.0
WALL_WIDTH_UM, ROUTE_WIDTH_UM, TRAP_WIDTH_UM, GOAL_HEIGHT_UM = 0.5, 0.8, 0.3, 0.2


@dataclasses.dataclass(frozen=True)
class Shape:
    """One marker's content: ``kind`` a name of visualization_msgs' Marker constants
    (``LINE_STRIP``, ``LINE_LIST``, ``SPHERE``, ``CYLINDER``), ``points_um`` (N, 2)
    for lines, ``centre_um`` and ``size_um`` (x, y, z) for a sphere or cylinder, or the
    lines' width in ``size_um[0]``."""

    namespace: str
    id: int
    kind: str
    colour: tuple[float, float, float, float]
    size_um: tuple[float, float, float]
    centre_um: tuple[float, float] = (0.0, 0.0)
    points_um: np.ndarray | None = None


@dataclasses.dataclass(frozen=True)
class Markers:
    stamp_sec: int
    stamp_nanosec: int
    shapes: list[Shape]


class MarkerTracker:
    """Turns bus messages into markers (see the module's docstring)."""

    def __init__(self):
        load_contour_tools()
        self.description: dict | None = None
        self.walls_um: list[np.ndarray] = []
        self.route_um = np.zeros((0, 2))
        self.traps_um: np.ndarray | None = None
        self._png: bytes | None = None

    def take(self, topic: str, message) -> Markers | None:
        """The markers to send after ``message`` on ``topic``: on each ``/otgym/bodies``
        of this session (as many bodies as the description has kinds), else None."""
        if topic == msg.SESSION:
            self.description = json.loads(message.data)
            self._walls()
        elif topic == msg.CHIP:
            self._png = bytes(message.data)
            self._walls()
        elif topic == msg.ROUTE:
            self.route_um = np.array([(p.pose.position.x, p.pose.position.y) for p in message.poses]).reshape(-1, 2)
        elif topic == msg.TRAPS:
            self.traps_um = msg.xy_um(message)
        elif topic == msg.BODIES and self.description is not None:
            bodies_um = msg.xy_um(message)
            if len(bodies_um) == len(self.description["sphere_kind"]):
                stamp = message.header.stamp
                return Markers(int(stamp.sec), int(stamp.nanosec), self._shapes(bodies_um))
        return None

    def _walls(self) -> None:
        if self._png is not None and self.description is not None:
            self.walls_um = wall_contours_um(self._png, float(self.description["chip"]["pixel_size_um"]))

    def _shapes(self, bodies_um: np.ndarray) -> list[Shape]:
        shapes = [
            Shape("walls", i, "LINE_STRIP", WALL_COLOUR, (WALL_WIDTH_UM, 0.0, 0.0), points_um=contour)
            for i, contour in enumerate(self.walls_um)
        ]
        if len(self.route_um):
            shapes.append(
                Shape("route", 0, "LINE_STRIP", ROUTE_COLOUR, (ROUTE_WIDTH_UM, 0, 0), points_um=self.route_um)
            )
            diameter = 2 * float(self.description.get("goal_tolerance_um", 1.0))
            goal = tuple(float(v) for v in self.route_um[-1])
            shapes.append(Shape("goal", 0, "CYLINDER", GOAL_COLOUR, (diameter, diameter, GOAL_HEIGHT_UM), goal))
        kinds = self.description["sphere_kind"]
        radii = self.description.get("sphere_radius_um") or [1.0] * len(kinds)
        counts: dict[str, int] = {}
        for (x, y), kind, radius in zip(bodies_um, kinds, radii):
            namespace = KIND_NAMESPACES.get(kind, kind)
            index = counts[namespace] = counts.get(namespace, -1) + 1
            diameter = 2 * float(radius)
            colour = KIND_COLOURS.get(kind, (1.0, 1.0, 1.0, 1.0))
            shapes.append(Shape(namespace, index, "SPHERE", colour, (diameter,) * 3, (float(x), float(y))))
        if self.traps_um is not None and len(self.traps_um):
            arms = []
            for x, y in self.traps_um:
                arms += [(x - TRAP_ARM_UM, y), (x + TRAP_ARM_UM, y), (x, y - TRAP_ARM_UM), (x, y + TRAP_ARM_UM)]
            shapes.append(Shape("traps", 0, "LINE_LIST", TRAP_COLOUR, (TRAP_WIDTH_UM, 0, 0), points_um=np.array(arms)))
        return shapes


def marker_array(markers: Markers):
    """The ``visualization_msgs/msg/MarkerArray`` of ``markers`` (needs the ROS 2 message
    wheels: ``pip install ros-visualization-msgs``)."""
    from builtin_interfaces.msg import Time
    from geometry_msgs.msg import Point
    from std_msgs.msg import ColorRGBA
    from visualization_msgs.msg import Marker, MarkerArray

    stamp = Time(sec=markers.stamp_sec, nanosec=markers.stamp_nanosec)
    clear = Marker(action=Marker.DELETEALL)
    clear.header.frame_id, clear.header.stamp = FRAME, stamp
    out = [clear]
    for shape in markers.shapes:
        marker = Marker(ns=shape.namespace, id=shape.id, type=getattr(Marker, shape.kind), action=Marker.ADD)
        marker.header.frame_id, marker.header.stamp = FRAME, stamp
        marker.pose.position.x, marker.pose.position.y = shape.centre_um
        marker.pose.orientation.w = 1.0
        marker.scale.x, marker.scale.y, marker.scale.z = (float(v) for v in shape.size_um)
        marker.color = ColorRGBA(r=shape.colour[0], g=shape.colour[1], b=shape.colour[2], a=shape.colour[3])
        if shape.points_um is not None:
            marker.points = [Point(x=float(x), y=float(y), z=0.0) for x, y in shape.points_um]
        out.append(marker)
    return MarkerArray(markers=out)
