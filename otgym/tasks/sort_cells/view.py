"""What ``sort-cells`` shows: its frame (the window, a Gymnasium ``render()``) and its
recorded scene (``Task.scene``: ``/otgym/bodies``, ``/otgym/traps``, Foxglove).

The cells, coloured and sized by kind (``KIND_RGB``: small green, large blue). The ports,
read from the chip's sidecar through the params: each outlet as a disc of the exit
distance (where a cell leaves by it) in the colour of the kind it takes, labelled with
the port's name and that kind; the inlet as a bar across its opening, labelled.

The manipulator. The task does not simulate the robots (``core``: taking hold is a
fixed ``grip_time``), so where they are drawn is this module's model, not the task's
state: in ``robots`` the two robots are parked against the inlet channel's walls,
``PARK_UPSTREAM_UM`` upstream of the junction (robot a on the side of kind 0's outlet,
robot b on the other), each with a trap on each handle; while the controller takes hold
of the target, they travel in a straight line from there to the grip about the target
(the transport scene's grip geometry, ``otgym.sim.scene.grip_robots_um``), the fraction
of the way the fraction of ``grip_time`` done, and hold it after. Robots are not bodies
of the simulation: cells pass through them. In ``direct`` one trap, drawn in the held
cell once it is held (a ring of ``DIRECT_RING_UM`` about it), is the manipulator; no
trap is drawn otherwise (the light is switched off)."""

from __future__ import annotations

import jax
import numpy as np

from otgym.physics.bodies import BodyKind
from otgym.sim import scene as sc
from otgym.sim.chip import load_chip
from otgym.sim.render import KIND_RGB as BODY_RGB
from otgym.sim.render import TRAP_RGB, Disc, Label, Line, SceneRenderer
from otgym.tasks.base import TaskScene

KIND_RGB = ((90.0, 185.0, 100.0), (70.0, 140.0, 225.0))
"""The colour of each kind's cells and outlet: kind 0 (small) green, kind 1 (large) blue."""
KIND_WORDS = ("small", "large")
INLET_RGB = (120.0, 160.0, 215.0)
INLET_TEXT = "inlet: cells arrive"
LABEL_RGB = (235, 238, 242)
OUTLET_OPACITY = 0.3
DIRECT_RING_UM = 1.5
"""The radius of the ring marking the direct trap's focus in the held cell."""
PARK_UPSTREAM_UM = 30.0
"""How far upstream of the junction the robots wait, against the inlet channel's walls."""


def frame(state, params, size_px=(600, 400)) -> np.ndarray:
    """RGB (H, W, 3) uint8 of one environment (see the module docstring)."""
    state = jax.device_get(state)
    config = params.config
    renderer = _renderer(config.chip, tuple(size_px))
    active = np.asarray(state.active, bool)
    kind = np.asarray(state.kind)[active]
    cells = np.asarray(state.xy_um, float)[active]
    robot_xy, robot_radii, robot_handles = robots(state, params)
    n_cells, n_robot = len(cells), len(robot_xy)
    kinds = np.array([int(BodyKind.CELL)] * n_cells + [int(BodyKind.ROBOT)] * n_robot, int)
    rgb = np.concatenate([np.asarray(KIND_RGB, np.float32)[kind].reshape(-1, 3), np.zeros((n_robot, 3), np.float32)])
    trap_xy = traps(state, params)
    focus = (
        [] if config.mode == "robots" else [Disc(tuple(xy), DIRECT_RING_UM, TRAP_RGB, ring_px=2.5) for xy in trap_xy]
    )
    return renderer.render(
        np.concatenate([cells.reshape(-1, 2), robot_xy]),
        np.concatenate([np.asarray(params.radius_um, float)[kind], robot_radii]),
        kinds,
        np.concatenate([np.zeros(n_cells, bool), robot_handles]),
        trap_xy,
        sphere_rgb=np.where((kinds == int(BodyKind.ROBOT))[:, None], BODY_RGB[BodyKind.ROBOT], rgb),
        under=_ports(params)[0],
        over=focus,
    )


def scene(state, params) -> TaskScene:
    """The cells (kind ``"cell"``; their radii tell the two kinds apart), then the robots'
    spheres in ``robots`` (kind ``"robot"``, where ``frame`` draws them), the traps
    (``traps``), the two outlets as targets of radius ``exit_distance_um`` (where a cell
    leaves by one), two lines: the target cell's route, from it through the junction
    to its kind's outlet, and the inlet's opening; and the ports' labels at the ports
    (``_ports``)."""
    from otgym.tasks.sort_cells import core

    state = jax.device_get(state)
    active = np.asarray(state.active, bool)
    kind = np.asarray(state.kind)
    xy = np.asarray(state.xy_um, float)
    robot_xy, robot_radii, _ = robots(state, params)
    first, present, _, _ = core._upstream_order(params, state)
    lines = [_ports(params)[2]]
    if bool(present):
        outlet = np.asarray(params.outlets_um, float)[kind[int(first)]]
        lines.insert(0, np.stack([xy[int(first)], np.asarray(params.junction_um, float), outlet]))
    return TaskScene(
        spheres_um=np.concatenate([xy[active], robot_xy]),
        radii_um=np.concatenate([np.asarray(params.radius_um, float)[kind[active]], robot_radii]),
        kinds=("cell",) * int(active.sum()) + ("robot",) * len(robot_xy),
        traps_um=traps(state, params),
        targets_um=np.asarray(params.outlets_um, float),
        target_radius_um=params.config.exit_distance_um,
        lines_um=tuple(lines),
        labels=_ports(params)[1],
    )


def _held(state, params) -> tuple[int, float]:
    """The cell being taken hold of or held (-1: none) and the fraction of the grip time
    done (1 once held)."""
    held = int(state.held)
    if held < 0 or not bool(np.asarray(state.active)[held]):
        return -1, 0.0
    grip = params.config.grip_time
    return held, 1.0 if grip <= 0 else float(np.clip(float(state.grip_s) / grip, 0.0, 1.0))


def robots(state, params) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The drawn robots' spheres in ``robots`` (none in ``direct``): centres (S, 2) um,
    radii (S,), handle mask (S,); where, the module docstring says."""
    config = params.config
    if config.mode != "robots":
        return np.zeros((0, 2)), np.zeros(0), np.zeros(0, bool)
    held, fraction = _held(state, params)
    kind = int(np.asarray(state.kind)[held]) if held >= 0 else 0
    grip_xy, radii, robot, handle = _grip(config, kind)
    parked = np.empty_like(grip_xy)
    junction = np.asarray(params.junction_um, float)
    for r, side in enumerate(np.asarray(params.side_sign, float)):
        own = robot == r
        centre = grip_xy[own].mean(axis=0)
        reach = float(np.max(np.abs(grip_xy[own, 1] - centre[1]) + radii[own]))
        place = junction + np.array([-PARK_UPSTREAM_UM, side * (params.half_width_um - reach)])
        parked[own] = grip_xy[own] - centre + place
    if held < 0:
        return parked, radii, handle
    gripping = np.asarray(state.xy_um, float)[held] + grip_xy
    return parked + fraction * (gripping - parked), radii, handle


def traps(state, params) -> np.ndarray:
    """The traps (um, (T, 2)): in ``robots`` one on each drawn robot handle, wherever the
    robots are; in ``direct`` one in the held cell once it is held (after the grip
    time), none otherwise."""
    if params.config.mode == "robots":
        xy, _, handle = robots(state, params)
        return xy[handle]
    held, _ = _held(state, params)
    if held < 0 or float(state.grip_s) < params.config.grip_time:
        return np.zeros((0, 2))
    return np.asarray(state.xy_um, float)[held][None]


def _ports(params) -> tuple[list, tuple, np.ndarray]:
    """The ports as the frame marks them (``_port_marks``), their labels (each outlet's
    name and the kind it takes, at the outlet; the inlet's at the middle of its opening)
    and the inlet's opening (a line (2, 2) across the inlet channel), read once per
    config from the chip's sidecar through ``params``."""
    config = params.config
    if config not in _PORTS:
        chip = load_chip(config.chip)
        inlet = np.asarray({p.name: p for p in chip.ports}[config.inlet].xy_um, float)
        along = np.asarray(params.junction_um, float) - inlet
        along /= np.linalg.norm(along)
        across = np.array([-along[1], along[0]]) * (params.half_width_um + 0.5)
        start = inlet + 2.0 * along
        bar = np.stack([start - across, start + across])
        outlets = np.asarray(params.outlets_um, float)
        labels = tuple(
            ((float(x), float(y)), f"{name}: {KIND_WORDS[kind]} cells ({config.cell_radii_um[kind]:g} um)")
            for kind, (name, (x, y)) in enumerate(zip(config.outlets, outlets))
        ) + ((tuple(float(v) for v in bar.mean(axis=0)), INLET_TEXT),)
        _PORTS[config] = (_port_marks(config, np.asarray(params.junction_um, float), outlets, labels, bar), labels, bar)
    return _PORTS[config]


def _port_marks(config, junction, outlets, labels, bar) -> list:
    """The outlets (discs of the exit distance in their kind's colour, and labels) and
    the inlet (a bar across its opening, and a label), beneath the cells."""
    marks = []
    for kind, outlet in enumerate(outlets):
        rgb = KIND_RGB[kind]
        toward = np.sign(junction[1] - outlet[1])  # the label on the junction's side of the outlet
        spot = outlet + np.array([-2.0, toward * (config.exit_distance_um + 2.0)])
        marks += [
            Disc(tuple(outlet), config.exit_distance_um, rgb, opacity=OUTLET_OPACITY),
            Disc(tuple(outlet), config.exit_distance_um, rgb, ring_px=2.0),
            Label(tuple(spot), labels[kind][1], tuple(int(v) for v in rgb), anchor="rt" if toward > 0 else "rb"),
        ]
    top = bar[np.argmin(bar[:, 1])]
    return [
        *marks,
        Line(bar, INLET_RGB, width_px=6.0),
        Label(tuple(top + [0.0, -2.0]), INLET_TEXT, LABEL_RGB, anchor="lb"),
    ]


_PORTS: dict = {}
_RENDERERS: dict = {}
_GRIPS: dict = {}


def _renderer(chip: str, size_px) -> SceneRenderer:
    """One renderer per (chip, size): drawing the chip's background is the costly part."""
    if (chip, size_px) not in _RENDERERS:
        _RENDERERS[chip, size_px] = SceneRenderer(load_chip(chip), size_px=size_px)
    return _RENDERERS[chip, size_px]


def _grip(config, kind: int):
    """The robots about a cell of ``kind`` at the origin (``sc.grip_robots_um``)."""
    key = (config.robot, config.cell_radii_um[kind])
    if key not in _GRIPS:
        _GRIPS[key] = sc.grip_robots_um(sc.SceneConfig(robot=config.robot, cell_radius_um=config.cell_radii_um[kind]))
    return _GRIPS[key]
