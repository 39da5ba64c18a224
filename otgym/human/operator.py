"""A simulated human operator who steers the robot through the chip by hand.

It stands in for the paper's recorded manual trajectories (section III-A) so that
Table I can be made without a person. The operator looks at the chip, steers the
trap towards the goal along the middle of the channels with a haptic stylus, and the
trapped robot follows the trap:

* **Route.** People keep away from walls: the intended route is the least-cost path
  (scikit-image ``MCP_Geometric``) through the dilated free map with cost
  1 / (distance to the nearest wall), which follows the channels' centre lines.
* **The person** is otgym's one human motor model, ``otgym.human.motor``
  (``HumanMotor`` with one participant, ``params.human``; sources there): the operator
  sees the robot's position a reaction time ago, and at each corrective sub-movement
  (every ~0.4 s, none during a lapse of responsiveness) aims at the route point
  ``lookahead`` ahead of that position, to within the room to the walls there (the goal
  tolerance at the goal); the hand executes the sub-movement with extent and direction
  errors, Fitts' speed-accuracy trade-off, neuromuscular lag, signal-dependent noise,
  8-12 Hz tremor and slow drift.
* **Motion scale** ``motion_scale_um_per_mm`` (4 um per mm): the trap moves by the
  stylus displacement times this. Assumed 1:250 so that a Geomagic Touch's ~160 mm
  workspace spans a ~640 um field, the whole chip without clutching; the default
  0.027 mm RMS stylus tremor is then 0.11 um at the trap.
* **The trapped robot** is not the hand: the operator moves the trap, and the
  overdamped robot follows it with the trap's restoring force plus thermal motion,
  dx = (k / gamma)(trap - x) dt + sqrt(2 kT / gamma) dW (Euler-Maruyama; the
  trapped-particle model of Berg-Sorensen & Flyvbjerg, Rev. Sci. Instrum. 75, 594,
  2004). k = 0.91 pN/um: the paper's trap stiffness 0.455 pN/um on each of two
  handles; gamma = 0.084 pN s/um: the Stokes drag 6 pi eta a of a 5 um-radius robot
  in water (eta = 8.9e-4 pN s/um^2); kT = 4.11e-3 pN um at 298 K. The corner
  frequency k / (2 pi gamma) = 1.7 Hz filters most of the tremor out of the robot's
  path; the thermal jitter, sqrt(kT / k) = 0.07 um RMS, stays in it, as it does in a
  recorded trajectory.
* **Detours**: with probability ``detour_probability`` (0.15) a sub-movement aims to
  the side of the route, by a uniform fraction up to ``detour_fraction`` (0.6) of the
  room left there. This has no literature value; it is set to reproduce the visible
  detours of the manual path in the paper's Fig. 5(a).
* **Speed** ``speed_um_per_s`` (3 um/s at the trap): the task's pace, not a human
  constant; the operator's speed limit for every sub-movement. It is below the ~7 um/s
  at which the paper's trap law (about 0.3 pN per handle, two handles) can drag a 10 um
  robot through water (Stokes drag 6 pi eta a).

The recorded trajectory is the robot's. Walls stop it: a step that would cross the
dilated obstacles slides along the wall (x or y alone) or is not taken. Positions are
sampled at ``sample_rate_hz`` (100 Hz, the haptic state rate of the paper's release),
which is also the human model's tick. Coordinates are um, origin at the image's
top-left corner, x right, y down.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from scipy import ndimage
from skimage.graph import MCP_Geometric

from otgym.human.motor import HumanMotor
from otgym.human.params import HumanParams
from otgym.planning.collision import _segment_free


@dataclasses.dataclass(frozen=True)
class OperatorParams:
    """Parameters of the simulated operator; sources in the module docstring and, for
    ``human``, in ``otgym.human.params``."""

    speed_um_per_s: float = 3.0
    human: HumanParams = HumanParams()
    motion_scale_um_per_mm: float = 4.0
    trap_stiffness_pn_per_um: float = 0.91
    robot_drag_pn_s_per_um: float = 0.084
    thermal_energy_pn_um: float = 4.11e-3
    detour_probability: float = 0.15
    detour_fraction: float = 0.6
    sample_rate_hz: float = 100.0
    goal_tolerance_um: float = 1.0
    timeout_factor: float = 10.0

    def __post_init__(self):
        if not isinstance(self.human, HumanParams):
            raise ValueError(f"operator human must be a HumanParams, got {type(self.human).__name__}")
        for name in (
            "speed_um_per_s",
            "motion_scale_um_per_mm",
            "sample_rate_hz",
            "trap_stiffness_pn_per_um",
            "robot_drag_pn_s_per_um",
            "goal_tolerance_um",
            "timeout_factor",
        ):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"operator {name} must be positive, got {value!r}")
        if not (math.isfinite(self.thermal_energy_pn_um) and self.thermal_energy_pn_um >= 0):
            raise ValueError(f"operator thermal_energy_pn_um must be non-negative, got {self.thermal_energy_pn_um!r}")
        for name in ("detour_probability", "detour_fraction"):
            value = getattr(self, name)
            if not 0 <= value <= 1:
                raise ValueError(f"operator {name} must lie in [0, 1], got {value!r}")
        if not self.human.tremor_band_hz[1] < self.sample_rate_hz / 2:
            raise ValueError(
                f"operator tremor band {self.human.tremor_band_hz} Hz must lie below "
                f"sample_rate_hz / 2 = {self.sample_rate_hz / 2:g} Hz"
            )


def simulate_operator(
    free: np.ndarray,
    pixel_size_um: float,
    start_um,
    goal_um,
    params: OperatorParams = OperatorParams(),
    seed: int = 0,
) -> np.ndarray:
    """Trajectory (``(n, 2)`` x_um, y_um at ``params.sample_rate_hz``) of a simulated
    operator steering from ``start_um`` to within ``goal_tolerance_um`` of ``goal_um``.

    ``free`` is the dilated free map (True = the robot's centre may be there). Raises
    ``ValueError`` if the goal is not reached within ``timeout_factor`` times the
    route's nominal duration.
    """
    rng = np.random.default_rng(seed)
    start = np.asarray(start_um, dtype=np.float64)
    goal = np.asarray(goal_um, dtype=np.float64)
    route, room = _centre_route(free, pixel_size_um, start, goal)
    arc = np.concatenate(([0.0], np.cumsum(np.linalg.norm(np.diff(route, axis=0), axis=1))))
    dt = 1.0 / params.sample_rate_hz
    max_steps = int(math.ceil(params.timeout_factor * (arc[-1] / params.speed_um_per_s + 5.0) / dt))
    human = params.human
    lookahead_um = params.speed_um_per_s * (human.correction_interval_s + human.reaction_time_s) * 1.5
    scale = params.motion_scale_um_per_mm
    speed_limit_mm_s = params.speed_um_per_s / scale
    relaxation = params.trap_stiffness_pn_per_um / params.robot_drag_pn_s_per_um * dt
    if relaxation >= 1.0:
        raise ValueError(
            f"operator sample rate {params.sample_rate_hz:g} Hz is too low for the trap's relaxation rate "
            f"k / gamma = {relaxation / dt:g} 1/s (Euler-Maruyama needs k dt / gamma < 1)"
        )
    thermal_step_um = math.sqrt(2.0 * params.thermal_energy_pn_um / params.robot_drag_pn_s_per_um * dt)
    free = np.ascontiguousarray(free, dtype=np.bool_)
    hand = HumanMotor(human, params.sample_rate_hz, rng)

    robot = np.empty((max_steps + 1, 2))
    robot[0] = start
    trap = start.copy()
    progress = 0.0  # route arc length the operator believes has been covered
    for k in range(max_steps):
        seen = hand.perceive(robot[k][None])[0]
        if hand.decide_due()[0]:
            progress = _progress(route, arc, seen, progress, lookahead_um)
            target_s = min(progress + lookahead_um, arc[-1])
            aim, tolerance_um = _aim(rng, params, seen, route, arc, room, target_s, goal)
            hand.plan(((aim - seen) / scale)[None], tolerance_um / scale, speed_limit_mm_s)
        trap += hand.step()[0] * scale * dt
        step = (trap - robot[k]) * relaxation + thermal_step_um * rng.standard_normal(2)
        robot[k + 1] = _move(free, pixel_size_um, robot[k], step)
        if np.linalg.norm(robot[k + 1] - goal) <= params.goal_tolerance_um:
            return robot[: k + 2]
    raise ValueError(
        f"the simulated operator did not reach the goal within {max_steps * dt:g} s "
        f"(route {arc[-1]:g} um at {params.speed_um_per_s:g} um/s)"
    )


def _centre_route(free, pixel_size_um, start, goal):
    """Route along the channels' middle, and the room (um) to the nearest wall along it."""
    clearance = ndimage.distance_transform_edt(free)
    costs = np.where(free, 1.0 / np.maximum(clearance, 1.0), -1.0)  # negative = impassable
    start_px = tuple(int(v) for v in np.floor(start[::-1] / pixel_size_um))
    goal_px = tuple(int(v) for v in np.floor(goal[::-1] / pixel_size_um))
    for name, (row, col) in (("start", start_px), ("goal", goal_px)):
        if not (0 <= row < free.shape[0] and 0 <= col < free.shape[1] and free[row, col]):
            raise ValueError(f"operator {name} {tuple(start if name == 'start' else goal)} um is not in free space")
    mcp = MCP_Geometric(costs)
    cumulative, _ = mcp.find_costs([start_px], [goal_px])
    if not np.isfinite(cumulative[goal_px]):
        raise ValueError("the simulated operator cannot reach the goal: no free route")
    pixels = np.asarray(mcp.traceback(goal_px))
    route = np.vstack((start, (pixels[:, ::-1] + 0.5) * pixel_size_um, goal))
    room = np.concatenate(([0.0], clearance[pixels[:, 0], pixels[:, 1]], [0.0])) * pixel_size_um
    return route, room


def _progress(route, arc, seen, progress, window_um):
    """Arc length of the route point nearest to what the operator sees, searched
    within ``window_um`` of the previous estimate so loops of the route cannot confuse it."""
    candidates = np.flatnonzero(np.abs(arc - progress) <= window_um + 1e-9)
    nearest = candidates[np.argmin(np.linalg.norm(route[candidates] - seen, axis=1))]
    return max(float(arc[nearest]), progress)


def _aim(rng, params, seen, route, arc, room, target_s, goal):
    """Where one corrective sub-movement aims (with a detour now and then) and its
    tolerance: the room left to the walls there, or the goal tolerance at the goal."""
    index = min(int(np.searchsorted(arc, target_s)), len(route) - 1)
    if target_s >= arc[-1] or index == len(route) - 1:
        return goal, params.goal_tolerance_um
    nominal, tolerance = route[index], room[index]
    vector = nominal - seen
    distance = np.linalg.norm(vector)
    if distance == 0.0 or rng.random() >= params.detour_probability:
        return nominal, tolerance
    normal = np.array([-vector[1], vector[0]]) / distance
    offset = rng.choice((-1.0, 1.0)) * rng.uniform(0, params.detour_fraction) * tolerance
    return nominal + normal * offset, tolerance - abs(offset)


def _move(free, pixel_size_um, position, step):
    """Take a step unless it crosses a wall; against a wall, slide along it."""
    for candidate in (step, np.array([step[0], 0.0]), np.array([0.0, step[1]])):
        target = position + candidate
        if _segment_free(
            free,
            position[0] / pixel_size_um,
            position[1] / pixel_size_um,
            target[0] / pixel_size_um,
            target[1] / pixel_size_um,
        ):
            return target
    return position.copy()
