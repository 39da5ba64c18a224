"""Microrobot designs as the tasks use them (``RobotSpec``): how to build a robot's body
(its spheres and handles, ``otgym.physics.bodies``) and the geometry of its grip. The
registry's ``robots`` name these specs (``otgym list robots``); a scene takes one by name
(``otgym.sim.scene.SceneConfig.robot``)."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

from otgym.physics.bodies import TWO_HANDLE_GRIPPER_SPHERES, BodySpec, four_arm_robot, two_handle_robot


@dataclasses.dataclass(frozen=True)
class RobotSpec:
    """A robot design. ``build(name)`` returns its ``BodySpec``; ``grip_spheres``: the
    indices of the two spheres of a notch that holds a cell between two robots facing
    each other (the transport scene's grip), None if the design cannot grip."""

    build: Callable[[str], BodySpec]
    grip_spheres: tuple[int, int] | None = None

    def body(self, name: str) -> BodySpec:
        return self.build(name)

    @property
    def n_handles(self) -> int:
        return len(self.build("probe").handle_indices)

    @property
    def can_grip(self) -> bool:
        return self.grip_spheres is not None


TWO_HANDLE = RobotSpec(two_handle_robot, TWO_HANDLE_GRIPPER_SPHERES)
"""The paper's robot: a bar with a handle at each end and a two-sphere gripper notch."""

FOUR_ARM = RobotSpec(four_arm_robot)
"""A hub with four arms, a handle at each arm's end; no grip (it pushes)."""
