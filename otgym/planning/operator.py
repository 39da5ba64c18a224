"""A simulated human operator who steers the robot through the chip by hand.

It stands in for the paper's recorded manual trajectories (section III-A) so that
Table I can be made without a person. The operator looks at the chip, steers the
trap towards the goal along the middle of the channels, and behaves like a person
at a haptic stylus:

* **Route.** People keep away from walls: the intended route is the least-cost path
  (scikit-image ``MCP_Geometric``) through the dilated free map with cost
  1 / (distance to the nearest wall), which follows the channels' centre lines.
* **Reaction delay** ``reaction_delay_s`` (0.2 s): the operator sees the robot's
  position that long ago and only starts moving after it. Simple visual reaction
  times are about 0.2 s, and the Model Human Processor's perceive-decide-act cycle
  is about 0.24 s (Card, Moran & Newell, *The Psychology of Human-Computer
  Interaction*, 1983).
* **Intermittent corrections** every ``correction_interval_s`` (0.4 s): manual
  tracking proceeds by discrete corrective sub-movements at about 2-3 per second
  (Craik, Br. J. Psychol. 38, 56, 1947; Miall, Weir & Stein, J. Motor Behav. 25, 53,
  1993). Each aims at the route point ``lookahead`` ahead of the (delayed) perceived
  position.
* **Over- and under-shoot**: each sub-movement's extent is scaled by
  1 + N(0, ``extent_error_fraction`` = 0.1) and its direction rotated by
  N(0, ``direction_error_deg`` = 4 deg); planar reaching errors grow with distance,
  with extent errors of about a tenth of the distance and directional errors of a
  few degrees (Gordon, Ghilardi & Ghez, Exp. Brain Res. 99, 97, 1994). Acting on a
  position seen ``reaction_delay_s`` ago adds the overshoot of delayed feedback.
* **Neuromuscular lag** ``neuromuscular_lag_s`` (0.1 s): the hand's velocity follows
  the intended one through a first-order lag, the neuromuscular term of the
  crossover model of the human controller (McRuer & Jex, IEEE Trans. HFE 8, 231,
  1967).
* **Physiological tremor** in ``tremor_band_hz`` (8-12 Hz; McAuley & Marsden,
  Brain 123, 1545, 2000) with ``tremor_rms_um`` (0.2 um) per axis at the trap:
  band-pass-filtered Gaussian noise (4th-order Butterworth, zero phase). A hand-held
  instrument tip trembles by about 50 um RMS per axis (Riviere, Rader & Thakor, IEEE
  Trans. BME 45, 839, 1998); scaled by an assumed stylus-to-trap motion scale of
  1:250 (so that a Geomagic Touch's ~160 mm workspace spans a ~640 um field, the
  whole chip without clutching) that is 0.2 um.
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
* **Speed** ``speed_um_per_s`` (3 um/s): the task's pace, not a human constant. It is
  below the ~7 um/s at which the paper's trap law (about 0.3 pN per handle, two
  handles) can drag a 10 um robot through water (Stokes drag 6 pi eta a).

The recorded trajectory is the robot's. Walls stop it: a step that would cross the dilated obstacles slides along the
wall (x or y alone) or is not taken. Positions are sampled at ``sample_rate_hz``
(100 Hz, the haptic state rate of the paper's release). Coordinates are um, origin at
the image's top-left corner, x right, y down.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from scipy import ndimage, signal
from skimage.graph import MCP_Geometric

from otgym.planning.collision import _segment_free


@dataclasses.dataclass(frozen=True)
class OperatorParams:
    """Parameters of the simulated operator; sources in the module docstring."""

    speed_um_per_s: float = 3.0
    reaction_delay_s: float = 0.2
    correction_interval_s: float = 0.4
    neuromuscular_lag_s: float = 0.1
    extent_error_fraction: float = 0.1
    direction_error_deg: float = 4.0
    tremor_rms_um: float = 0.05
    tremor_band_hz: tuple[float, float] = (8.0, 12.0)
    trap_stiffness_pn_per_um: float = 0.91
    robot_drag_pn_s_per_um: float = 0.084
    thermal_energy_pn_um: float = 4.11e-3
    detour_probability: float = 0.15
    detour_fraction: float = 0.6
    sample_rate_hz: float = 100.0
    goal_tolerance_um: float = 1.0
    timeout_factor: float = 10.0

    def __post_init__(self):
        for name in ("speed_um_per_s", "correction_interval_s", "neuromuscular_lag_s", "sample_rate_hz",
                     "trap_stiffness_pn_per_um", "robot_drag_pn_s_per_um", "goal_tolerance_um",
                     "timeout_factor"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"operator {name} must be positive, got {value!r}")
        for name in ("reaction_delay_s", "extent_error_fraction", "direction_error_deg", "tremor_rms_um",
                     "detour_fraction", "thermal_energy_pn_um"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"operator {name} must be non-negative, got {value!r}")
        if not 0 <= self.detour_probability <= 1:
            raise ValueError(f"operator detour_probability must lie in [0, 1], got {self.detour_probability!r}")
        low, high = self.tremor_band_hz
        if not 0 < low < high < self.sample_rate_hz / 2:
            raise ValueError(
                f"operator tremor band {self.tremor_band_hz} Hz must satisfy 0 < low < high < "
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
    tremor = _tremor(rng, max_steps + 1, params)
    delay_steps = int(round(params.reaction_delay_s / dt))
    correction_steps = max(int(round(params.correction_interval_s / dt)), 1)
    lookahead_um = params.speed_um_per_s * (params.correction_interval_s + params.reaction_delay_s) * 1.5
    hand_lag = min(dt / params.neuromuscular_lag_s, 1.0)
    relaxation = params.trap_stiffness_pn_per_um / params.robot_drag_pn_s_per_um * dt
    if relaxation >= 1.0:
        raise ValueError(
            f"operator sample rate {params.sample_rate_hz:g} Hz is too low for the trap's relaxation rate "
            f"k / gamma = {relaxation / dt:g} 1/s (Euler-Maruyama needs k dt / gamma < 1)"
        )
    thermal_step_um = math.sqrt(2.0 * params.thermal_energy_pn_um / params.robot_drag_pn_s_per_um * dt)
    free = np.ascontiguousarray(free, dtype=np.bool_)

    robot = np.empty((max_steps + 1, 2))
    robot[0] = start
    hand = start.copy()  # the trap, moved by the hand (without tremor)
    hand_velocity = np.zeros(2)
    intended_velocity = np.zeros(2)
    progress = 0.0  # route arc length the operator believes has been covered
    for k in range(max_steps):
        if k >= delay_steps and (k - delay_steps) % correction_steps == 0:
            seen = robot[k - delay_steps]
            progress = _progress(route, arc, seen, progress, lookahead_um)
            target_s = min(progress + lookahead_um, arc[-1])
            aim = _aim(rng, params, seen, route, arc, room, target_s, goal)
            displacement = aim - seen
            duration = max(np.linalg.norm(displacement) / params.speed_um_per_s, params.correction_interval_s)
            intended_velocity = displacement / duration
        hand_velocity += (intended_velocity - hand_velocity) * hand_lag
        hand += hand_velocity * dt
        trap = hand + tremor[k + 1]
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
    """Where one corrective sub-movement aims, with extent/direction errors and detours."""
    index = min(int(np.searchsorted(arc, target_s)), len(route) - 1)
    nominal = goal if target_s >= arc[-1] else route[index]
    vector = nominal - seen
    distance = np.linalg.norm(vector)
    if distance == 0.0:
        return nominal
    if rng.random() < params.detour_probability and target_s < arc[-1]:
        normal = np.array([-vector[1], vector[0]]) / distance
        vector = vector + normal * rng.choice((-1.0, 1.0)) * rng.uniform(0, params.detour_fraction) * room[index]
    angle = math.radians(rng.normal(0.0, params.direction_error_deg))
    rotation = np.array([[math.cos(angle), -math.sin(angle)], [math.sin(angle), math.cos(angle)]])
    return seen + (1.0 + rng.normal(0.0, params.extent_error_fraction)) * (rotation @ vector)


def _tremor(rng, count, params):
    """Band-limited (tremor band) Gaussian displacement noise, ``tremor_rms_um`` per axis."""
    if params.tremor_rms_um == 0.0:
        return np.zeros((count, 2))
    sos = signal.butter(4, params.tremor_band_hz, btype="bandpass", fs=params.sample_rate_hz, output="sos")
    noise = signal.sosfiltfilt(sos, rng.standard_normal((count + 200, 2)), axis=0)[100:-100]
    return noise / noise.std(axis=0) * params.tremor_rms_um


def _move(free, pixel_size_um, position, step):
    """Take a step unless it crosses a wall; against a wall, slide along it."""
    for candidate in (step, np.array([step[0], 0.0]), np.array([0.0, step[1]])):
        target = position + candidate
        if _segment_free(free, position[0] / pixel_size_um, position[1] / pixel_size_um,
                         target[0] / pixel_size_um, target[1] / pixel_size_um):
            return target
    return position.copy()
