"""Simulated participants: a closed-loop model of a person driving the interactive task
with two haptic styluses (bimanual: hand 0 moves robot A's traps, hand 1 robot B's),
vectorised over E environments. The hand itself is ``otgym.human.motor``'s motor
model (reaction delay, intermittent sub-movements with Fitts timing, neuromuscular lag,
speed-dependent noise, tremor, yielding to the stylus force); this module is the task
level: where the person wants each robot to be when a sub-movement ends.

The person sees the scene one reaction time late and knows what they have commanded
since (an efference copy: the motor system predicts the current state from the delayed
one and its own commands, a Smith predictor; Miall, Weir, Wolpert & Stein, J. Motor
Behav. 25, 203, 1993). The copy is of the planned hand motion: the traps' commanded motion
since what is seen, plus the planned motion still on its way through the arm's lag and
the input filter (forgotten over ``pending_memory_s``: motion the retargeting's dead
band swallowed never arrives). Each sub-movement is a reach to a place (Fitts timing, errors
from the motor model), re-planned at the next correction from what is then seen:

* Grip places: each robot's traps as in the formation, at the robots' present
  orientation (each robot's turn is the line between its own two traps: a hand
  translates its traps and cannot turn its robot). Around the cell while gripping;
  once the cell is held, around the centre the two robots' traps imply, so each hand
  keeps its robot's place relative to the other robot and leaves the cell to the
  notches (placing robots about a cell that sits off-centre in its notches would
  squeeze it). The formation is not turned to the line between the two robots: that
  line tilts with any shear between them (one robot ahead of the other along the
  route), and places at that tilt keep the shear, so the cell was pinched between
  one robot's front sphere and the other's back sphere at 10-16 pN until a trap lost
  its handle (the trap's hold is k w exp(-1/2) / 2 = 9.1 pN per handle). On 64 fresh
  manual trials (participants of population seed 4242, scenarios 910000-910007,
  120 s each) trap losses fell from 33 to 11 with this change.
* APPROACH: align, then close. The robots are held ``open_gap_um`` out from their
  places around the free cell (where it will be: its drift seen over a glimpse,
  extrapolated over the delay and the movement) until the cell sits within
  ``align_tolerance_um`` of the formation's centre along the robots' notches; then
  they close on it (and open again if it slips twice that far before the grip). Closing
  on a misaligned cell pinches it between the robots' front spheres, a grip that
  cannot be carried.
* Walls: the person sees the channel's walls and keeps each robot's handles
  ``wall_clearance_um`` from them (a handle's radius, 1.25 um, plus a visible 0.75 um
  of water; a modelling choice): a robot's place that lies closer is moved out along
  the wall's normal. While approaching, only that robot's place moves (it nudges a
  free cell off the wall); while carrying, the whole formation moves (moving one robot
  would squeeze the cell). Without this the wall-side robot was pressed into the wall
  by a hand chasing a cell that drifted toward it, and its trap lost it (the first
  cause of trap losses in manual trials).
* Careful closing: while approaching, a hand moves its robot toward the cell (beyond
  the cell's own drift) fast until it is ``close_guard_um`` (1.5 um) from its grip
  place, then at most ``close_speed_um_s`` (a fast reach to a point short of the
  target, then slow homing in: the two phases of aimed movements, Woodworth 1899;
  Meyer et al., Psychol. Rev. 95, 340, 1988; the guard is about what the fast reach's
  momentum through the arm's lag and the tremor filter carries on). A hand keeps moving for a
  reaction time plus up to a correction interval (about 0.6 s) after the robot
  touches the cell; at 0.75 um/s it then presses about 0.45 um into the cell, below
  the 0.6 um at which a 50 pN/um trap loses its handle. The value follows from those
  numbers, not from a measurement of operators (a modelling choice: operators slow
  down before contact). Closing at the 5-10 um/s of a free reach overshot by 1-2 um
  and the trap lost the squeezed robot (the second cause of manual trap losses).
* A gripped cell seen more than ``seat_tolerance_um`` off-centre along the notches is
  let go and gripped again.
* CARRY: the places moved along the route at the intended assembly speed:
  ``carry_speed_um_s`` in manual mode (a careful pace, see ``ParticipantTask``).
* Obstacles: each obstacle's motion is extrapolated from two glimpses ``glimpse_s``
  apart. The person weighs these assembly velocities, each safe if no obstacle comes
  within ``clearance_um`` of the cell in the next ``horizon_s``: the intended one, a
  hurried one (``hurry_factor`` times faster, passing ahead), a slowed one (half),
  holding still, backing along the route, stepping away from the obstacle, and
  side-steps to either side of the route (forward and aside at 45 and 70 degrees,
  and straight aside). A side-step is foreseen to end where the walls stop it: the
  person sees how far the formation can move to each side before a handle comes
  ``wall_clearance_um`` from a wall, and expects to go on along the route from there.
  Of the safe options the person takes the first in a preference that depends on how
  the threat moves; if none is safe, the one with the widest miss (but see standing
  obstacles below).
  - A threat crossing the route (its track more than ``along_angle_deg``, 45 degrees,
    off the route): keep the path, change the speed (intended, hurried, slowed, still,
    back, away), side-step only if none of these is safe.
  - A threat moving along the route, toward the assembly or ahead of it, or standing
    in it: change the path first (intended, the side-steps, then the speeds), the
    side with the wider miss among equals, which is the side the obstacle comes from
    when it crosses at a shallow angle (passing behind it). Walkers do this: avoiding
    a pedestrian who crosses their path, they adjust their speed and their path when
    the crossing angle is 45 or 90 degrees, and only their path at obtuse angles,
    where the other comes toward them (Huber, Su, Krueger, Faschian, Glasauer &
    Hermsdoerfer, PLoS ONE 9, e89589, 2014); 45 degrees as the boundary is a modelling
    choice. Waiting for an obstacle that moves along the route does not clear the way
    (it stays in the corridor for as long as it moves along it), and backing cannot
    outrun one that comes faster than the pace. (Without this, collisions in shared
    mode clustered on obstacles crossing at 30-42 degrees to the route, which the
    person met head on, and on side-steps into a wall the person did not foresee.)
  An obstacle seen standing still (slower than ``still_speed_um_s``, 1 um/s: half the
  obstacles' 2 um/s track speed and above the ~0.5 um/s that Brownian jitter of a
  3 um sphere in water, D = kT / (6 pi eta r) = 0.07 um^2/s, shows between glimpses
  0.5 s apart; a modelling choice) will not clear the way either, and the person
  passes it closer, ``still_clearance_um`` (0.5 um to spare: its path need not be
  guessed). (Without this a person waited forever beside an obstacle held against a
  wall 9.6 um from the route, inside the assembly's corridor.) Nor can it be waited
  out: when no forward option keeps that clearance, the person squeezes past with the
  widest miss a forward option gives, down to ``squeeze_um`` inside it, before
  holding still, and stops only if even that would touch. (Once the side-steps
  foresaw the walls, persons otherwise stopped beside an obstacle parked 12 um from
  the route, a wall on the other side, with 1 um of water between them, until the
  time ran out.)
* Shared mode: the person rests and lets the autonomy drive while the interface's cue
  shows alpha below ``fine_tune_alpha``; from there on (the cue asks them to take
  part) they command what brings the blend to their intention, dP_h = (dP_want -
  (1 - alpha) dP_r) / alpha, as far as the trap-speed clamp allows: a dodge when a
  threat is seen, otherwise the route at the autonomy's pace. (A hand resting while its
  share is half halves the blend's speed: resting at the cue when no threat was seen
  cost 6 s a trial on 32 development trials, scenarios 900000-900003, with no change
  in obstacles avoided.) Their intended pace is the
  autonomy's, at most its cruise speed: the autonomy's corrections back to the route
  (up to the 20 um/s clamp when the assembly has been held back or stepped aside) are
  not a pace a person would dodge at. (Side-steps at those speeds carried handles into
  the walls and lost them.)
Stylus units: chip um -> stylus mm through the retargeting scale (tau) and plane; the
hands feel the feedback force (``otgym.teleop.feedback.chip_force_n`` on the trap
forces of their robot's handles) and yield to it.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from otgym.human.motor import HumanMotor, HumanParams
from otgym.task.geometry import rotate
from otgym.task.task import APPROACH, CARRY
from otgym.teleop.feedback import FeedbackConfig, chip_force_n
from otgym.teleop.retarget import BatchRetargeter, RetargetConfig

N_HANDS = 2


@dataclasses.dataclass(frozen=True)
class ParticipantTask:
    """Task-level parameters of the simulated participants (not motor constants).

    ``carry_speed_um_s``: manual transport pace, 2 um/s. Not a literature constant: manual
    optical-tweezers transport of cells is reported at a few um/s, and here each hand
    must also keep its robot in the grip (a gripper that strays 1 um from the cell
    loses it), which sets a careful pace. ``clearance_um``: the assembly's radius
    (8.7 um) plus the obstacle's (3 um) plus 1.5 um to spare (the scenarios park an obstacle 14 um from the route, which must count as passable). ``grip_tolerance_um``: the
    Fitts tolerance of a reach to a grip place. ``along_angle_deg``: a threat whose
    track lies within this angle of the route moves along it (module docstring).
    ``side_step_resolution_um``: the step in which the person judges the room beside
    the assembly. ``squeeze_um``: how much of ``still_clearance_um`` the person gives
    up to pass a standing obstacle when no option keeps all of it: beside the assembly
    its handles reach 7.75 um from the cell's centre (6.5 um offset plus their
    1.25 um radius), 0.95 um less than the 8.7 um radius that the clearances count, so
    such a pass still leaves about 0.45 um of water."""

    carry_speed_um_s: float = 2.0
    lookahead_um: float = 5.0
    grip_tolerance_um: float = 0.2
    open_gap_um: float = 1.5
    align_tolerance_um: float = 0.4
    seat_tolerance_um: float = 1.5
    clearance_um: float = 13.2
    horizon_s: float = 6.0
    glimpse_s: float = 0.5
    hurry_factor: float = 1.6
    still_speed_um_s: float = 1.0
    still_clearance_um: float = 12.2
    fine_tune_alpha: float = 0.3
    pending_memory_s: float = 0.5
    wall_clearance_um: float = 2.0
    close_speed_um_s: float = 0.75
    close_guard_um: float = 1.5
    along_angle_deg: float = 45.0
    side_step_resolution_um: float = 0.5
    squeeze_um: float = 1.0
    bimanual: bool = True
    """True: one stylus per robot (the paper's set-up). False: one stylus moves all four
    traps as a rigid formation (the grip cannot be squeezed by the hands)."""

    def __post_init__(self):
        for field in dataclasses.fields(self):
            if field.name == "bimanual":
                continue
            value = getattr(self, field.name)
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"{field.name} must be positive, got {value!r}")


def robots_heading(traps_um, offsets_um, trap_robot):
    """(E,) the formation heading the robots' present orientations show: each robot's
    turn is that of the line between its own two traps (E, T, 2) against the same line in
    the formation's ``offsets_um`` (T, 2); their circular mean. (The line between the two
    robots would tilt with any shear between them, and a grip placed at that tilt keeps
    the shear, pinching the cell between the robots' front spheres.)"""
    turns = []
    for robot in range(N_HANDS):
        first, second = np.flatnonzero(np.asarray(trap_robot) == robot)[:2]
        now = traps_um[:, second] - traps_um[:, first]
        reference = offsets_um[second] - offsets_um[first]
        turns.append(np.arctan2(now[:, 1], now[:, 0]) - np.arctan2(reference[1], reference[0]))
    turns = np.stack(turns, axis=1)
    return np.arctan2(np.sin(turns).sum(axis=1), np.cos(turns).sum(axis=1))


def _unit(vectors):
    return vectors / np.maximum(np.linalg.norm(vectors, axis=-1, keepdims=True), 1e-9)


def _closest_um(
    cell_um, obstacle_um, obstacle_velocity_um_s, assembly_velocity_um_s, horizon_s: float, until_s=None, then_um_s=None
):
    """(E, K) the closest each obstacle comes to the cell within ``horizon_s`` if the
    assembly moves at ``assembly_velocity_um_s`` (E, 2), or at it until ``until_s`` (E,)
    and at ``then_um_s`` (E, 2) after (a step aside that a wall ends)."""

    def closest(relative, closing, duration_s):
        speed2 = np.maximum(np.sum(closing**2, axis=-1), 1e-9)
        t_star = np.clip(-np.sum(relative * closing, axis=-1) / speed2, 0.0, duration_s)
        return np.linalg.norm(relative + closing * t_star[..., None], axis=-1)

    relative = obstacle_um - cell_um[:, None]
    closing = obstacle_velocity_um_s - assembly_velocity_um_s[:, None]
    if until_s is None:
        return closest(relative, closing, horizon_s)
    until = np.clip(until_s, 0.0, horizon_s)[:, None]
    later = relative + closing * until[..., None]
    return np.minimum(
        closest(relative, closing, until),
        closest(later, obstacle_velocity_um_s - then_um_s[:, None], horizon_s - until),
    )


def miss_um(cell_um, obstacle_um, obstacle_velocity_um_s, assembly_velocity_um_s, horizon_s: float):
    """(E,) the closest any obstacle (E, K, 2) moving at its velocity comes to the cell
    (E, 2) within ``horizon_s`` if the assembly moves at ``assembly_velocity_um_s`` (E, 2),
    and (E, 2) the unit vector from that obstacle to the cell now."""
    miss = _closest_um(cell_um, obstacle_um, obstacle_velocity_um_s, assembly_velocity_um_s, horizon_s)
    worst = np.argmin(miss, axis=1)
    return miss.min(axis=1), _unit(cell_um - obstacle_um[np.arange(len(cell_um)), worst])


SPEED_OPTIONS = ("intended", "hurried", "slowed", "still", "back", "away")
"""The options that change the speed (``away``: straight away from the threat), in the
order ``choose_velocity`` lists them; the side-steps follow."""

SIDE_STEP_DEG = (45.0, 70.0, 90.0)
"""Side-steps, to either side of the route: forward and aside at 45 and 70 degrees, and
straight aside."""


def _option_ranks():
    """Preference (lower first) of each option among the safe ones, (2, options): for a
    threat crossing the route (intended, hurried, slowed, still, back, away, then the
    side-steps: keep the path, change the speed) and for one moving along the route or
    standing in it (intended, the side-steps, then the changes of speed: waiting does
    not clear the way). Both sides of a side-step rank alike."""
    speeds, side = len(SPEED_OPTIONS), np.repeat(np.arange(len(SIDE_STEP_DEG)), 2)
    crossing = np.concatenate([np.arange(speeds), speeds + side])
    along = np.concatenate([[0], len(SIDE_STEP_DEG) + np.arange(1, speeds), 1 + side])
    return np.stack([crossing, along])


def choose_velocity(
    cell_um, obstacle_um, obstacle_velocity_um_s, want_um_s, route_direction, task: ParticipantTask, room_um=None
):
    """The person's choice of assembly velocity (E, 2) and whether it differs from
    ``want_um_s``. Options: intended, hurried, slowed, still, backing along the route,
    stepping away, and side-steps to either side of the route (``SIDE_STEP_DEG``). Safe:
    no obstacle comes within ``task.clearance_um`` of the cell in ``task.horizon_s``, or
    within ``task.still_clearance_um`` for an obstacle seen moving slower than
    ``task.still_speed_um_s``. ``room_um`` (E, 2): how far the assembly can move to the
    left and to the right of ``route_direction`` before a wall stops it (None: no
    walls); an option's sideways motion is predicted to end there. The safe option
    ranked first (``_option_ranks``: the threat crossing the route, or moving within
    ``task.along_angle_deg`` of it or standing still), the one
    with the most room among equals; if none is safe, the one with the most room. Past
    a standing threat, a forward option (intended, hurried, slowed, the side-steps short
    of 90 degrees) with room down to ``-task.squeeze_um`` ranks just before holding
    still: waiting does not clear the way."""
    rows = np.arange(len(cell_um))
    _, away = miss_um(cell_um, obstacle_um, obstacle_velocity_um_s, np.zeros_like(want_um_s), task.horizon_s)
    speed_k = np.linalg.norm(obstacle_velocity_um_s, axis=-1)  # (E, K)
    still_k = speed_k < task.still_speed_um_s
    clearance = np.where(still_k, task.still_clearance_um, task.clearance_um)
    worst = np.argmin(
        _closest_um(cell_um, obstacle_um, obstacle_velocity_um_s, want_um_s, task.horizon_s) - clearance, axis=1
    )
    pace = np.linalg.norm(want_um_s, axis=-1, keepdims=True)
    left = np.stack([-route_direction[:, 1], route_direction[:, 0]], axis=-1)
    side = [
        (np.cos(a) * route_direction + sign * np.sin(a) * left) * pace
        for a in np.radians(SIDE_STEP_DEG)
        for sign in (1.0, -1.0)
    ]
    options = [
        want_um_s,
        task.hurry_factor * want_um_s,
        0.5 * want_um_s,
        np.zeros_like(want_um_s),
        -route_direction * pace,
        away * pace,
        *side,
    ]
    heading_cos = np.abs(np.sum(obstacle_velocity_um_s[rows, worst] * route_direction, axis=-1)) / np.maximum(
        speed_k[rows, worst], 1e-9
    )
    along = still_k[rows, worst] | (heading_cos >= np.cos(np.radians(task.along_angle_deg)))
    rank = _option_ranks()[along.astype(int)]  # (E, options)
    room = []
    for index, velocity in enumerate(options):
        if room_um is None:
            miss = _closest_um(cell_um, obstacle_um, obstacle_velocity_um_s, velocity, task.horizon_s)
        else:  # sideways only until a wall, then along the route; a side-step into a wall is no option
            sideways_um_s = np.sum(velocity * left, axis=-1)
            free_um = np.where(sideways_um_s > 0, room_um[:, 0], room_um[:, 1])
            until_s = free_um / np.maximum(np.abs(sideways_um_s), 1e-9)
            miss = _closest_um(
                cell_um,
                obstacle_um,
                obstacle_velocity_um_s,
                velocity,
                task.horizon_s,
                until_s,
                velocity - sideways_um_s[:, None] * left,
            )
            if index >= len(SPEED_OPTIONS):
                miss = np.where((free_um < task.side_step_resolution_um)[:, None], -np.inf, miss)
        room.append((miss - clearance).min(axis=1))
    room = np.stack(room, axis=1)  # (E, options)
    safe = room >= 0.0
    onward = np.array(
        [name in ("intended", "hurried", "slowed") for name in SPEED_OPTIONS]
        + [a < 90.0 for a in SIDE_STEP_DEG for _ in range(2)]
    )
    squeeze = still_k[rows, worst][:, None] & onward & ~safe & (room >= -task.squeeze_um)
    rank = np.where(squeeze, _option_ranks()[1, SPEED_OPTIONS.index("still")] - 0.5, rank)  # just before waiting
    chosen = safe | squeeze
    first = np.min(np.where(chosen, rank, np.inf), axis=1, keepdims=True)
    best = np.argmax(np.where(chosen & (rank == first), room, -np.inf), axis=1)
    choice = np.where(chosen.any(axis=1), best, np.argmax(room, axis=1))
    return np.stack(options, axis=1)[rows, choice], choice > 0


class SimulatedParticipants:
    """E simulated participants (one per environment), each with two hands.

    Per tick: ``intend(obs, ...)`` gives the hands' trap increments dP_h, then
    ``moved(dP_s, human_weight)`` tells the participants what the traps were commanded
    to do (for their efference copy; ``human_weight`` (E,) is tau * alpha, the share of
    dP_h in dP_s) and ``feel(obs, ...)`` what their hands feel next."""

    def __init__(
        self,
        params: list[HumanParams],
        tick_s: float,
        seed: int,
        navigator,
        retarget: RetargetConfig,
        feedback: FeedbackConfig,
        bend_distance_um: float,
        task: ParticipantTask = ParticipantTask(),
        wall_distance_um=None,
    ):
        self.n_env = len(params)
        self.wall_distance_um = wall_distance_um
        """``(n, 2) um -> (n,)`` distance to the chip's walls, or None (no walls)."""
        self.tick_s = tick_s
        self.navigator = navigator
        self.task = task
        self.retarget_config = retarget
        self.feedback_config = feedback
        self.bend_distance_um = bend_distance_um
        hands = [p for p in params for _ in range(N_HANDS)]
        self.motor = HumanMotor(
            hands, 1.0 / tick_s, np.random.default_rng(seed), hands_per_person=N_HANDS if task.bimanual else 1
        )
        self.retargeter = BatchRetargeter(retarget, 1.0 / tick_s, self.n_env * N_HANDS)
        self.delay_s = self.motor.delay_ticks[::N_HANDS] * tick_s
        self._glimpses = max(1, int(round(task.glimpse_s / tick_s)))
        self._history: list[np.ndarray] = []
        self._moved_um: np.ndarray | None = None
        self._unexecuted_um = np.zeros((self.n_env, N_HANDS, 2))
        self._pending_um = np.zeros((self.n_env, N_HANDS, 2))
        self._pending_keep = float(np.exp(-tick_s / task.pending_memory_s))
        self.feedback_n = np.zeros((self.n_env, N_HANDS, 2))
        self.closing = np.zeros(self.n_env, bool)

    def _grip_places(self, cell_now, traps_now, phase, trap_robot):
        """Each trap's place (E, T, 2): around the cell at the robots' present orientation,
        closed or held open (module docstring); updates ``closing``."""
        task = self.task
        offsets = np.asarray(self.navigator.offsets_um, float)
        heading = robots_heading(traps_now, offsets, trap_robot)
        centre = (traps_now - rotate(offsets[None], heading)).mean(axis=1)  # the formation centre the traps imply
        along = np.abs(np.sum((cell_now - centre) * np.stack([np.cos(heading), np.sin(heading)], axis=-1), axis=-1))
        approach = phase == APPROACH
        closing = np.where(
            approach, along < np.where(self.closing, 2.0, 1.0) * task.align_tolerance_um, along < task.seat_tolerance_um
        )
        self.closing = closing
        side = np.sign(np.array([offsets[trap_robot == r, 1].mean() for r in range(N_HANDS)]))[trap_robot]  # (T,)
        opened = offsets + np.where(closing[:, None, None], 0.0, task.open_gap_um * side[None, :, None] * [0.0, 1.0])
        about = np.where(((phase == CARRY) & closing)[:, None], centre, cell_now)
        return about[:, None] + rotate(opened, heading)

    def _guard_closing(self, reach_um, want, duration, traps_now, places, phase, trap_robot):
        """While approaching, each hand closes its robot on the cell (moves it toward the
        other robot, beyond the cell's own drift ``want`` (E, 2)) fast only while it is
        more than ``close_guard_um`` from its grip place (``places`` (E, T, 2)); the last
        ``close_guard_um`` at most ``close_speed_um_s``: the careful end of a grip."""
        robots = np.stack([traps_now[:, trap_robot == r].mean(axis=1) for r in range(N_HANDS)], axis=1)
        goals = np.stack([places[:, trap_robot == r].mean(axis=1) for r in range(N_HANDS)], axis=1)
        across = _unit(robots[:, 1] - robots[:, 0])  # closing is along the line between the robots
        inward = np.stack([across, -across], axis=1)  # (E, hands, 2)
        needed = np.sum((goals - robots) * inward, axis=-1)
        allowed = np.maximum(self.task.close_speed_um_s * duration, needed - self.task.close_guard_um)
        closing = np.sum((reach_um - want[:, None] * duration[..., None]) * inward, axis=-1)
        excess = np.where((phase == APPROACH)[:, None], np.maximum(closing - allowed, 0.0), 0.0)
        return reach_um - excess[..., None] * inward

    def _off_walls(self, places, carried, trap_robot, step_um: float = 0.1):
        """``places`` (E, T, 2) with each robot's moved out along the wall normal until
        its handles are ``wall_clearance_um`` from the walls; for ``carried`` (E,)
        environments every robot moves by the robots' summed shift."""
        if self.wall_distance_um is None:
            return places
        flat = places.reshape(-1, 2)
        probes = np.concatenate([flat, flat + [step_um, 0.0], flat + [0.0, step_um]])
        distance = np.asarray(self.wall_distance_um(probes), float).reshape(3, *places.shape[:2])
        normal = _unit(np.stack([distance[1] - distance[0], distance[2] - distance[0]], axis=-1))
        short = np.maximum(self.task.wall_clearance_um - distance[0], 0.0)  # (E, T)
        shift = np.zeros_like(places)
        for r in range(N_HANDS):
            mine = trap_robot == r
            worst = np.argmax(short[:, mine], axis=1)
            rows = np.arange(len(places))
            shift[:, mine] = (short[:, mine][rows, worst, None] * normal[:, mine][rows, worst])[:, None]
        common = np.stack([shift[:, trap_robot == r][:, 0] for r in range(N_HANDS)], axis=1).sum(axis=1)
        return places + np.where(carried[:, None, None], common[:, None], shift)

    def _side_room_um(self, traps_um, route_direction, max_um: float):
        """(E, 2) how far the formation of traps (E, T, 2) can move to the left and to the
        right of ``route_direction`` (E, 2), in steps of ``side_step_resolution_um``, up to
        ``max_um``, before a handle comes ``wall_clearance_um`` from a wall (or closer than
        it is now); None without walls."""
        if self.wall_distance_um is None:
            return None
        task = self.task
        steps_um = np.arange(0.0, max_um + task.side_step_resolution_um, task.side_step_resolution_um)  # (S,)
        left = np.stack([-route_direction[:, 1], route_direction[:, 0]], axis=-1)
        sides = np.stack([left, -left], axis=1)  # (E, 2, 2)
        probes = traps_um[:, None, None] + steps_um[None, None, :, None, None] * sides[:, :, None, None]
        distance = np.asarray(self.wall_distance_um(probes.reshape(-1, 2)), float).reshape(probes.shape[:-1])
        limit = np.minimum(task.wall_clearance_um, distance[:, :, :1])  # (E, 2, 1, T): now or the clearance
        blocked = np.any(distance < limit - 1e-6, axis=-1)  # (E, 2, S)
        free_steps = np.where(blocked.any(axis=-1), np.argmax(blocked, axis=-1) - 1, len(steps_um) - 1)
        return steps_um[np.maximum(free_steps, 0)]

    def moved(self, trap_increment_um: np.ndarray, human_weight: np.ndarray, trap_robot) -> None:
        """The traps' commanded increments (E, T, 2) um this tick, plus the planned hand
        motion not yet executed (weighted by ``human_weight`` (E,)): the efference copy."""
        weight = np.asarray(human_weight, float)[:, None, None]
        self._pending_um = self._pending_um * self._pending_keep + weight * self._unexecuted_um
        self._moved_um = self._moved_um + np.asarray(trap_increment_um, float)

    def _perceive(self, obs, trap_robot):
        """What each participant sees now (one reaction time late): cell, traps,
        obstacles, the cell's arc and phase, their drift over a glimpse, and the trap
        motion commanded since what is seen."""
        if self._moved_um is None:
            self._moved_um = np.zeros_like(obs.trap_xy_um)
        n_traps, n_obs = obs.trap_xy_um.shape[1], obs.obstacle_xy_um.shape[1]
        now = np.concatenate(
            [
                obs.cell_xy_um,
                obs.trap_xy_um.reshape(self.n_env, -1),
                obs.obstacle_xy_um.reshape(self.n_env, -1),
                obs.cell_arc_um[:, None],
                obs.phase[:, None].astype(float),
                self._moved_um.reshape(self.n_env, -1),
            ],
            axis=1,
        )
        seen = self.motor.perceive(np.repeat(now, N_HANDS, axis=0))[::N_HANDS]
        self._history.append(seen)
        if len(self._history) > self._glimpses + 1:
            self._history.pop(0)
        split = np.cumsum([2, 2 * n_traps, 2 * n_obs, 1, 1])
        cell, traps, obstacles, arc, phase, moved = np.split(seen, split, axis=1)
        earlier = np.split(self._history[0], split, axis=1)
        elapsed = max(len(self._history) - 1, 1) * self.tick_s
        obstacles = obstacles.reshape(self.n_env, n_obs, 2)
        velocity = (obstacles - earlier[2].reshape(self.n_env, n_obs, 2)) / elapsed
        cell_velocity = (cell - earlier[0]) / elapsed
        since_um = self._moved_um - moved.reshape(self.n_env, n_traps, 2) + self._pending_um[:, trap_robot]
        return (
            cell,
            cell_velocity,
            traps.reshape(self.n_env, n_traps, 2),
            obstacles,
            velocity,
            arc[:, 0],
            phase[:, 0].round().astype(int),
            since_um,
        )

    def intend(self, obs, mode: np.ndarray, alpha: np.ndarray, robot_increment_um: np.ndarray, trap_robot):
        """Plan the hands' sub-movements (those due) and return dP_h (E, 2 hands, 2) um for this tick."""
        task = self.task
        cell, cell_velocity, traps, obstacles, velocity, arc, phase, since_um = self._perceive(obs, trap_robot)
        delay = self.delay_s[:, None]
        carrying = (phase == CARRY)[:, None]
        traps_now = traps + since_um
        cell_now = np.where(carrying, cell + since_um.mean(axis=1), cell + cell_velocity * delay)
        obstacles_now = obstacles + velocity * delay[:, :, None]
        route_direction = _unit(self.navigator.route_point_at(arc + task.lookahead_um) - cell_now)
        autonomy_um_s = robot_increment_um / self.tick_s  # (E, T, 2)
        shared = mode == "shared"
        pace = np.where(
            shared,
            np.minimum(np.linalg.norm(autonomy_um_s.mean(axis=1), axis=-1), self.navigator.cruise_speed_um_s),
            task.carry_speed_um_s,
        )
        want = np.where(
            carrying, route_direction * pace[:, None], np.where(phase[:, None] == APPROACH, cell_velocity, 0.0)
        )
        room = self._side_room_um(traps_now, route_direction, float(pace.max()) * task.horizon_s)
        chosen, _ = choose_velocity(cell_now, obstacles_now, velocity, want, route_direction, task, room)
        want = np.where(carrying, chosen, want)
        places = self._grip_places(cell_now, traps_now, phase, trap_robot)
        error = np.stack([(places - traps_now)[:, trap_robot == r].mean(axis=1) for r in range(N_HANDS)], axis=1)
        if not task.bimanual:  # one hand moves the formation: only the common part of the correction
            error = np.repeat(error.mean(axis=1, keepdims=True), N_HANDS, axis=1)
        scale = self.retarget_config.motion_scale_um_per_mm
        limit_mm_s = self.retarget_config.max_trap_speed_um_s / scale
        tolerance_mm = task.grip_tolerance_um / scale
        duration = self.motor.submovement_duration_s(
            np.linalg.norm(error, axis=-1).ravel() / scale, tolerance_mm, limit_mm_s
        ).reshape(self.n_env, N_HANDS)
        # where the hands go in this sub-movement: the places where they will be when it
        # ends, kept off the walls
        ahead = places + want[:, None] * duration[:, trap_robot, None]  # (E, T, 2)
        off_wall = self._off_walls(ahead, (phase == CARRY) & self.closing, trap_robot) - ahead

        def per_hand(traps):
            return np.stack([traps[:, trap_robot == r].mean(axis=1) for r in range(N_HANDS)], axis=1)

        reach_um = per_hand(ahead - traps_now)
        duration = self.motor.submovement_duration_s(
            np.linalg.norm(reach_um + per_hand(off_wall), axis=-1).ravel() / scale, tolerance_mm, limit_mm_s
        ).reshape(self.n_env, N_HANDS)
        reach_um = self._guard_closing(reach_um, want, duration, traps_now, places, phase, trap_robot)
        reach_um = reach_um + per_hand(off_wall)  # a wall is escaped at once, not closed on carefully
        if not task.bimanual:
            reach_um = np.repeat(reach_um.mean(axis=1, keepdims=True), N_HANDS, axis=1)
        hand_um_s = reach_um / duration[..., None]
        robot_hand = np.stack([autonomy_um_s[:, trap_robot == r].mean(axis=1) for r in range(N_HANDS)], axis=1)
        safe_alpha = np.maximum(alpha, 1e-3)[:, None, None]
        override = (hand_um_s - (1 - safe_alpha) * robot_hand) / safe_alpha
        cue = carrying[:, 0] & (alpha >= task.fine_tune_alpha)
        hand_um_s = np.where(shared[:, None, None], np.where(cue[:, None, None], override, 0.0), hand_um_s)
        planar_mm_s = (hand_um_s * np.array([1.0, -1.0]) / scale).reshape(-1, 2)  # chip -> stylus x, y
        speed_mm_s = np.maximum(np.linalg.norm(planar_mm_s, axis=-1), 1e-6)
        self.motor.plan(
            planar_mm_s * duration.reshape(-1, 1), tolerance_mm, np.minimum(speed_mm_s * 1.0001, limit_mm_s)
        )
        planned_um = (self.motor.command_mm_s * np.array([1.0, -1.0]) * scale * self.tick_s).reshape(
            self.n_env, N_HANDS, 2
        )
        stylus = self.motor.step(self.feedback_n.reshape(-1, 2) * np.array([1.0, -1.0]))
        increments = self.retargeter(stylus).reshape(self.n_env, N_HANDS, 2)
        if not task.bimanual:
            increments, planned_um = (np.repeat(a[:, :1], N_HANDS, axis=1) for a in (increments, planned_um))
        self._unexecuted_um = planned_um - increments
        return increments

    def feel(self, obs, trap_force_pn: np.ndarray, trap_robot):
        """The stylus force each hand feels next tick, from its robot's handle forces (E, T, 2)."""
        offsets = obs.trap_xy_um - obs.handle_xy_um
        valid = np.ones(offsets.shape[:2], bool)
        forces = [
            chip_force_n(
                trap_force_pn[:, trap_robot == r],
                offsets[:, trap_robot == r],
                obs.contact_force_pn[:, r],
                valid[:, trap_robot == r],
                self.feedback_config,
                self.bend_distance_um,
            )
            for r in range(N_HANDS)
        ]
        force = np.stack(forces, axis=1)
        norm = np.linalg.norm(force, axis=-1, keepdims=True)
        limit = self.feedback_config.force_limit_n
        self.feedback_n = force * np.minimum(1.0, limit / np.maximum(norm, 1e-300))
