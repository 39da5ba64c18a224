"""The MCAP recording of ``otgym play --task NAME`` (``DIR/session.mcap``, or
``session-<n>.mcap`` beside an earlier one): what the task did, episode by episode, in
the topics and encodings of the interactive task's recording (``otgym.ui.recording``),
so ``otgym replay`` summarises it and Foxglove shows it.

Topics (``otgym.bus.messages``):

- ``/otgym/trial/events`` (``std_msgs/String``, JSON): ``{"event": "task", "task",
  "preset", "seed", "control_period_s"}`` once at the start; ``{"event":
  "trial_start", "trial": n}`` at each episode's start; ``{"event": "trial_end",
  "trial", "ended_by", "success", "steps", "time_s", "return", "metrics"}`` at its
  end, where ``metrics`` holds every scalar of the task's last ``info`` (the task's own
  metrics: e.g. assemble's ``rms_error_um``, ``beads_lost``, ``collisions``) and
  ``time_s`` is the info's ``time_s`` where the task reports one, else steps times
  the control period;
- ``/otgym/bodies`` and ``/otgym/traps`` (``geometry_msgs/PoseArray``, um, frame
  ``chip``) after each reset and step, for tasks with a ``Task.scene``;
- ``/otgym/scene`` (``foxglove.SceneUpdate``, protobuf; needs foxglove-sdk) with each
  of those: entity ``bodies`` (the spheres, coloured by kind as the interactive
  task's scene), ``traps`` (a cross per trap) and ``targets`` (the targets as flat
  discs, the task's lines as line strips, its labels as text facing the viewer).

Stamps are the recording's clock (wall time by default): a played episode is recorded
as it was played.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from otgym.bus import messages as msg
from otgym.bus.foxglove_scene import GOAL_COLOUR, KIND_COLOURS, ROUTE_COLOUR, SCENE_TOPIC, TRAP_COLOUR, scene_schema
from otgym.bus.foxglove_scene import available as foxglove_available
from otgym.bus.schemas import SCHEMAS
from otgym.record.mcap_file import McapRecorder
from otgym.tasks.base import Task, TaskScene

TRAP_ARM_UM = 1.0
"""Half the size of a trap's cross in the scene."""
LABEL_FONT_PX = 14.0
"""A label's size on screen (scale-invariant text, facing the viewer)."""
LABEL_COLOUR = (1.0, 1.0, 1.0, 1.0)


def info_metrics(info: dict) -> dict:
    """The scalars of one environment's ``info`` as JSON numbers (bools stay bools;
    arrays of more than one value are left out)."""
    metrics = {}
    for name, value in info.items():
        array = np.asarray(value)
        if array.size != 1:
            continue
        item = array.reshape(()).item()
        metrics[name] = item if isinstance(item, bool) else float(item)
    return metrics


class TaskRecording:
    """Records one play session of ``task`` into ``path`` (see the module docstring)."""

    def __init__(
        self, path: Path, task: Task, params, preset: str | None, seed: int, period_s: float, clock_s=time.time
    ):
        self.recorder = McapRecorder(path)
        self.path = self.recorder.path
        self.task, self.params, self.period_s, self.clock_s = task, params, float(period_s), clock_s
        self.scene_enabled = foxglove_available()
        self._schema = scene_schema() if self.scene_enabled else None
        self.write_event("task", task=task.name, preset=preset, seed=int(seed), control_period_s=self.period_s)

    def write_event(self, name: str, **fields) -> None:
        self.recorder.write(
            msg.EVENTS,
            msg.topic_type(msg.EVENTS),
            SCHEMAS[msg.topic_type(msg.EVENTS)],
            msg.event(name, **fields),
            log_time_ns=int(self.clock_s() * 1e9),
        )

    def episode_start(self, episode: int, state) -> None:
        self.write_event("trial_start", trial=int(episode), task=self.task.name)
        self.state(state)

    def episode_end(self, episode: int, steps: int, episode_return: float, success: bool, ended_by: str, info) -> None:
        metrics = info_metrics(info) if info is not None else {}
        time_s = metrics.get("time_s", steps * self.period_s)
        self.write_event(
            "trial_end",
            trial=int(episode),
            ended_by=ended_by,
            success=bool(success),
            steps=int(steps),
            time_s=float(time_s),
            metrics=metrics,
            **{"return": float(episode_return)},
        )

    def state(self, state) -> None:
        """Record one environment's state: bodies, traps and the scene (when the task has one)."""
        scene = self.task.scene(state, self.params)
        if scene is None:
            return
        stamp_s = self.clock_s()
        stamp_ns = int(stamp_s * 1e9)
        for topic, xy in ((msg.TRAPS, scene.traps_um), (msg.BODIES, scene.spheres_um)):
            type_name = msg.topic_type(topic)
            self.recorder.write(
                topic, type_name, SCHEMAS[type_name], msg.pose_array(np.asarray(xy).reshape(-1, 2), stamp_s), stamp_ns
            )
        if self.scene_enabled:
            self.recorder.write_encoded(SCENE_TOPIC, self._schema, "protobuf", scene_update(scene, stamp_ns), stamp_ns)

    def close(self) -> None:
        self.recorder.close()


def scene_update(scene: TaskScene, stamp_ns: int) -> bytes:
    """``foxglove.SceneUpdate`` protobuf bytes of ``scene`` (frame ``chip``, um)."""
    from foxglove import messages as fm

    stamp = fm.Timestamp(sec=stamp_ns // 1_000_000_000, nsec=stamp_ns % 1_000_000_000)

    def pose(x, y):
        return fm.Pose(
            position=fm.Vector3(x=float(x), y=float(y), z=0.0), orientation=fm.Quaternion(x=0.0, y=0.0, z=0.0, w=1.0)
        )

    def colour(rgba):
        return fm.Color(r=rgba[0], g=rgba[1], b=rgba[2], a=rgba[3])

    def point(x, y):
        return fm.Point3(x=float(x), y=float(y), z=0.0)

    spheres = [
        fm.SpherePrimitive(
            pose=pose(x, y),
            size=fm.Vector3(x=2 * r, y=2 * r, z=2 * r),
            color=colour(KIND_COLOURS.get(kind, (1, 1, 1, 1))),
        )
        for (x, y), r, kind in zip(np.asarray(scene.spheres_um), np.asarray(scene.radii_um), scene.kinds)
    ]
    cross = []
    for x, y in np.asarray(scene.traps_um).reshape(-1, 2):
        cross += [
            point(x - TRAP_ARM_UM, y),
            point(x + TRAP_ARM_UM, y),
            point(x, y - TRAP_ARM_UM),
            point(x, y + TRAP_ARM_UM),
        ]
    size = 2 * float(scene.target_radius_um)
    targets = [
        fm.CylinderPrimitive(
            pose=pose(x, y),
            size=fm.Vector3(x=size, y=size, z=0.2),
            bottom_scale=1.0,
            top_scale=1.0,
            color=colour(GOAL_COLOUR),
        )
        for x, y in np.asarray(scene.targets_um).reshape(-1, 2)
    ]
    lines = [
        fm.LinePrimitive(
            type=fm.LinePrimitiveLineType.LineStrip,
            thickness=0.5,
            points=[point(x, y) for x, y in np.asarray(line).reshape(-1, 2)],
            color=colour(ROUTE_COLOUR),
        )
        for line in scene.lines_um
    ]
    texts = [
        fm.TextPrimitive(
            pose=pose(x, y),
            billboard=True,
            font_size=LABEL_FONT_PX,
            scale_invariant=True,
            color=colour(LABEL_COLOUR),
            text=text,
        )
        for (x, y), text in scene.labels
    ]
    trap_lines = [
        fm.LinePrimitive(type=fm.LinePrimitiveLineType.LineList, thickness=0.3, points=cross, color=colour(TRAP_COLOUR))
    ]
    entities = [
        fm.SceneEntity(
            timestamp=stamp,
            frame_id="chip",
            id="bodies",
            spheres=spheres,
            metadata=[fm.KeyValuePair(key="kinds", value=",".join(scene.kinds))],
        ),
        fm.SceneEntity(timestamp=stamp, frame_id="chip", id="traps", lines=trap_lines if cross else []),
        fm.SceneEntity(timestamp=stamp, frame_id="chip", id="targets", cylinders=targets, lines=lines, texts=texts),
    ]
    return fm.SceneUpdate(entities=entities).encode()
