"""Rigid multi-sphere bodies: the geometry every other physics module works on.

A body is a rigid cluster of spheres given by local offsets (um) and radii (um) in
its own frame, with a planar pose (x, y, theta) in the focal plane. Some spheres of a
microrobot are *handles*: the spheres optical traps hold. This is the "multi-sphere"
model of optical microrobots used by the paper's group (Zhang et al., two-photon
polymerised robots about 10 um across with 2-3 um spherical handles).

Kinds: robot, cell (a soft sphere), obstacle, bead.
Obstacles are kinematic by default: they move with a prescribed velocity and are
not pushed by forces (the chip issue drives them).

Each body has a material (``otgym.physics.adhesion``) that sets its van der Waals
attraction: robots and beads ``polymer``, cells and obstacles (other cells of the
sample) ``cell`` unless given.
"""

from __future__ import annotations

import dataclasses
from enum import IntEnum

import numpy as np

from otgym.physics.adhesion import MATERIALS
from otgym.physics.validation import require_finite, require_positive, require_shape


class BodyKind(IntEnum):
    ROBOT = 0
    CELL = 1
    OBSTACLE = 2
    BEAD = 3


DEFAULT_MATERIAL = {
    BodyKind.ROBOT: "polymer",
    BodyKind.CELL: "cell",
    BodyKind.OBSTACLE: "cell",
    BodyKind.BEAD: "polymer",
}


@dataclasses.dataclass(frozen=True)
class BodySpec:
    """Geometry of one rigid body.

    offsets_um: (S, 2) sphere centres in the body frame.
    radii_um: (S,) sphere radii.
    handle_indices: indices of the spheres that optical traps may hold.
    kinematic: True for bodies that follow a prescribed velocity (obstacles).
    material: one of ``otgym.physics.adhesion.MATERIALS``; None: the kind's default.
    """

    name: str
    kind: BodyKind
    offsets_um: np.ndarray
    radii_um: np.ndarray
    handle_indices: tuple[int, ...] = ()
    kinematic: bool = False
    material: str | None = None

    def __post_init__(self):
        offsets = require_finite(f"{self.name}.offsets_um", self.offsets_um)
        radii = require_positive(f"{self.name}.radii_um", self.radii_um)
        if radii.ndim != 1 or radii.size == 0:
            raise ValueError(f"{self.name}.radii_um must be a non-empty 1-D array, got shape {radii.shape}")
        require_shape(f"{self.name}.offsets_um", offsets, (radii.size, 2))
        for index in self.handle_indices:
            if not 0 <= index < radii.size:
                raise ValueError(f"{self.name}.handle_indices contains {index}, outside 0..{radii.size - 1}")
        object.__setattr__(self, "offsets_um", offsets)
        object.__setattr__(self, "radii_um", radii)
        object.__setattr__(self, "kind", BodyKind(self.kind))
        if self.material is None:
            object.__setattr__(self, "material", DEFAULT_MATERIAL[self.kind])
        elif self.material not in MATERIALS:
            raise ValueError(f"{self.name}.material must be one of {MATERIALS}, got {self.material!r}")
        object.__setattr__(self, "handle_indices", tuple(int(i) for i in self.handle_indices))

    @property
    def n_spheres(self) -> int:
        return int(self.radii_um.size)

    @property
    def bounding_radius_um(self) -> float:
        return float(np.max(np.linalg.norm(self.offsets_um, axis=1) + self.radii_um))


def custom_body(
    name: str,
    offsets_um,
    radii_um,
    *,
    kind: BodyKind = BodyKind.ROBOT,
    handle_indices=(),
    kinematic: bool = False,
    material: str | None = None,
) -> BodySpec:
    """Define your own design: any cluster of spheres, any subset of them handles."""
    return BodySpec(
        name,
        kind,
        np.asarray(offsets_um, float),
        np.asarray(radii_um, float),
        tuple(handle_indices),
        kinematic,
        material,
    )


TWO_HANDLE_GRIPPER_SPHERES = (5, 6)
"""Indices of the two gripper spheres of ``two_handle_robot`` (the notch that holds a cell)."""


def two_handle_robot(
    name: str = "robot",
    *,
    handle_radius_um: float = 1.25,
    handle_separation_um: float = 7.0,
    body_sphere_radius_um: float = 1.0,
    gripper_spacing_um: float = 4.0,
) -> BodySpec:
    """The paper's microrobot: a bar with a trapping handle at each end (spheres 0, 1)
    and, on its +y side, two gripper spheres ``gripper_spacing_um`` apart (spheres 5, 6)
    forming a notch in which a cell sits, so that two robots facing each other hold a
    cell at four points. About 9.5 um across, handles 2.5 um wide."""
    half = handle_separation_um / 2
    grip = gripper_spacing_um / 2
    offsets = [
        (-half, 0.0),
        (half, 0.0),
        (-half / 2, 0.0),
        (0.0, 0.0),
        (half / 2, 0.0),
        (-grip, 2 * body_sphere_radius_um),
        (grip, 2 * body_sphere_radius_um),
    ]
    radii = [handle_radius_um, handle_radius_um] + [body_sphere_radius_um] * 5
    return custom_body(name, offsets, radii, handle_indices=(0, 1))


def four_arm_robot(
    name: str = "robot4",
    *,
    handle_radius_um: float = 1.25,
    arm_length_um: float = 5.0,
    hub_radius_um: float = 1.5,
    arm_sphere_radius_um: float = 0.75,
) -> BodySpec:
    """A four-arm microrobot: a hub, four arms at 90 degrees, a handle at each arm end."""
    directions = np.array([(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0)])
    offsets = [(0.0, 0.0)]
    radii = [hub_radius_um]
    offsets += list(directions * arm_length_um)
    radii += [handle_radius_um] * 4
    offsets += list(directions * arm_length_um / 2)
    radii += [arm_sphere_radius_um] * 4
    return custom_body(name, offsets, radii, handle_indices=(1, 2, 3, 4))


def cell(name: str = "cell", *, radius_um: float = 4.0) -> BodySpec:
    """A cell as one soft sphere (default 8 um across, the size of a red blood cell)."""
    return custom_body(name, [(0.0, 0.0)], [radius_um], kind=BodyKind.CELL)


def bead(name: str = "bead", *, radius_um: float = 0.5) -> BodySpec:
    """A trappable microsphere: the sphere is its own handle."""
    return custom_body(name, [(0.0, 0.0)], [radius_um], kind=BodyKind.BEAD, handle_indices=(0,))


def obstacle(name: str = "obstacle", *, radius_um: float = 3.0, kinematic: bool = True) -> BodySpec:
    """A moving obstacle (debris, another cell): a kinematic sphere by default."""
    return custom_body(name, [(0.0, 0.0)], [radius_um], kind=BodyKind.OBSTACLE, kinematic=kinematic)
