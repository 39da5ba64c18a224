"""Simulated participants: a closed-loop model of a person driving the interactive task
with two haptic styluses (bimanual: hand 0 moves robot A's traps, hand 1 robot B's),
vectorised over E environments. The hand itself is ``otgym.human.motor``'s motor model
(reaction delay, intermittent sub-movements with Fitts timing, neuromuscular lag,
speed-dependent noise, tremor, yielding to the stylus force); this module is the task
level: where the person wants each robot to be when a sub-movement ends. Parameters:
``otgym.human.participant_task.ParticipantTask``; obstacle avoidance:
``otgym.human.avoidance``.

Perception. The person perceives only the window (``otgym.human.percept.Percept``: the
scene as drawn, with the window's latency, and the cue panel; never the autonomy's
command), the stylus force, and their own hand. They see the window one reaction time
late and know what their own hand has done since (an efference copy: the motor system
predicts the current state from the delayed one and its own commands, a Smith
predictor; Miall, Weir, Wolpert & Stein, J. Motor Behav. 25, 203, 1993): their hand's
trap motion since what is seen, weighted by the share alpha the panel shows (1 in
manual mode), plus the planned motion still on its way through the arm's lag and the
input filter (forgotten over ``pending_memory_s``: motion the retargeting's dead band
swallowed never arrives). The person has adapted to the window's latency (their own
motion is compared with the picture of the same moment: **assumed**, as after a
practice block). Motion of the robots that their hand does not explain (in shared mode,
the autonomy's part, as seen over a glimpse) is extrapolated like the obstacles' and
the cell's. Each sub-movement is a reach to a place, re-planned at the next correction.

Places, per phase:

* Grip places: each robot's traps as in the formation, at the robots' present
  orientation (a hand translates its traps and cannot turn its robot), around the cell
  while gripping and around the centre the robots' traps imply once it is held
  (docs/decisions/0041-participant-grip-orientation.md).
* APPROACH: align, then close: the robots are held ``open_gap_um`` out from their places
  around the free cell (where it will be: its drift over a glimpse, extrapolated over the
  delay and the movement) until the cell sits within ``align_tolerance_um`` of the
  formation's centre along the notches (twice that to open again); closing on a
  misaligned cell pinches it. The last ``close_guard_um`` of a close at most
  ``close_speed_um_s`` (docs/decisions/0043-participant-careful-closing.md).
* A gripped cell seen more than ``seat_tolerance_um`` off-centre along the notches is let
  go and gripped again.
* Walls: each robot's handles kept ``wall_clearance_um`` from the walls, a place closer
  moved out along the wall's normal: one robot while approaching, the whole formation
  while carrying (docs/decisions/0042-participant-wall-clearance.md).
* CARRY: the places move along the route at the intended assembly speed,
  ``carry_speed_um_s`` in manual mode, or the velocity ``choose_velocity`` picks when an
  obstacle threatens.
* Shared mode: the hand rests until the fine-tune prompt is seen (the window shows it
  from alpha ``otgym.task.task.FINE_TUNE_ALPHA``, 0.4), watching the pace at which the
  robots carry the cell (the pace intended once acting), judged over a glimpse that
  lies wholly in the rest (the first glimpse after the hand stops still shows its own
  motion; until a whole one has passed the pace watched before stands). Then the hand corrects by
  feedback: each sub-movement reaches, at the manual mapping, for the difference
  between where the person wants the robots when it ends (a place moving on at the
  intended velocity, at most ``shared_lead_um`` from the robots as perceived) and where
  they expect them (seen, plus their own motion since, plus the unexplained motion
  extrapolated). Its
  effect on the traps is alpha times that; what is left is corrected at the next
  sub-movement. The blend is never inverted: no division by alpha, no use of the
  autonomy's command (docs/decisions/0027-participant-perceives-the-window.md).

Stylus units: chip um -> stylus mm through the retargeting scale (tau) and plane; the
hands feel the feedback force (``otgym.teleop.feedback.chip_force_n`` on the trap forces
of their robot's handles) and yield to it.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from otgym.human.avoidance import choose_velocity, unit
from otgym.human.motor import HumanMotor
from otgym.human.params import HumanParams
from otgym.human.participant_task import ParticipantTask, ParticipantTasks
from otgym.human.percept import DISPLAY_LATENCY_S, Percept, ShownRoute, latency_ticks, rows_at_latency
from otgym.task.task import APPROACH, CARRY
from otgym.tasks.transport.route_follow import rotate
from otgym.teleop.feedback import FeedbackConfig, chip_force_n
from otgym.teleop.retarget import BatchRetargeter, RetargetConfig

N_HANDS = 2


def robots_heading(traps_um, offsets_um, trap_robot):
    """(E,) the formation heading the robots' present orientations show: each robot's
    turn is that of the line between its own two traps (E, T, 2) against the same line in
    the formation's ``offsets_um`` (T, 2); their circular mean (not the line between the
    robots, which tilts with any shear between them: docs/decisions/0041)."""
    turns = []
    for robot in range(N_HANDS):
        first, second = np.flatnonzero(np.asarray(trap_robot) == robot)[:2]
        now = traps_um[:, second] - traps_um[:, first]
        reference = offsets_um[second] - offsets_um[first]
        turns.append(np.arctan2(now[:, 1], now[:, 0]) - np.arctan2(reference[1], reference[0]))
    turns = np.stack(turns, axis=1)
    return np.arctan2(np.sin(turns).sum(axis=1), np.cos(turns).sum(axis=1))


class SimulatedParticipants:
    """E simulated participants (one per environment), each with two hands.

    Per tick: ``intend(percept, trap_robot)`` gives the hands' trap increments dP_h from
    what the window shows (``otgym.human.percept.Percept``) and ``feel(obs, ...)`` the
    stylus force each hand feels next. ``route``: the route and the robots' shape as the
    window shows them; ``task``: one ``ParticipantTask`` for all, or one per
    environment; ``display_latency_s``: the window's latency, to which the person has
    adapted (one for all, or one per environment)."""

    def __init__(
        self,
        params: list[HumanParams],
        tick_s: float,
        seed: int,
        route: ShownRoute,
        retarget: RetargetConfig,
        feedback: FeedbackConfig,
        bend_distance_um: float,
        task: ParticipantTask | Sequence[ParticipantTask] = ParticipantTask(),
        wall_distance_um=None,
        display_latency_s=DISPLAY_LATENCY_S,
    ):
        self.n_env = len(params)
        task = ParticipantTasks(task, self.n_env)
        self.wall_distance_um = wall_distance_um
        """``(n, 2) um -> (n,)`` distance to the chip's walls, or None (no walls)."""
        self.tick_s = tick_s
        self.route = route
        self.task = task
        self.retarget_config = retarget
        self.feedback_config = feedback
        self.bend_distance_um = bend_distance_um
        hands = [p for p in params for _ in range(N_HANDS)]
        self.motor = HumanMotor(
            hands, 1.0 / tick_s, np.random.default_rng(seed), hands_per_person=N_HANDS if task.bimanual else 1
        )
        self.retargeter = BatchRetargeter(retarget, 1.0 / tick_s, self.n_env * N_HANDS)
        self._latency_ticks = latency_ticks(display_latency_s, tick_s)
        self._max_latency_ticks = int(np.max(self._latency_ticks))
        self.delay_s = (self.motor.delay_ticks[::N_HANDS] + self._latency_ticks) * tick_s
        """(E,) how old what the person perceives is: their reaction delay plus the window's latency."""
        self._glimpses = np.maximum(1, np.rint(task.glimpse_s / tick_s).astype(np.int64))  # (E,)
        self._history: list[np.ndarray] = []
        self._own_um: np.ndarray | None = None  # the hands' own trap motion, summed (efference copy)
        self._own_shown: list[np.ndarray] = []  # the same, as old as the window's picture
        self._pending_um = np.zeros((self.n_env, N_HANDS, 2))
        self._pending_keep = np.exp(-tick_s / task.pending_memory_s)[:, None, None]
        self._seen_pace_um_s = task.carry_speed_um_s.copy()  # the robots' pace, watched
        self._resting_ticks = np.zeros(self.n_env, np.int64)  # shared mode: ticks the hand has rested, watching
        self._intended_um: np.ndarray | None = None  # shared mode: where the person wants the formation's centre
        self.feedback_n = np.zeros((self.n_env, N_HANDS, 2))
        self.closing = np.zeros(self.n_env, bool)
        self._side_steps: tuple | None = None  # (max_um, steps (E, S), counts (E,)): _side_steps_um

    def _grip_places(self, cell_now, traps_now, phase, trap_robot):
        """Each trap's place (E, T, 2): around the cell at the robots' present orientation,
        closed or held open (module docstring); updates ``closing``."""
        task = self.task
        offsets = np.asarray(self.route.offsets_um, float)
        heading = robots_heading(traps_now, offsets, trap_robot)
        centre = (traps_now - rotate(offsets[None], heading)).mean(axis=1)  # the formation centre the traps imply
        along = np.abs(np.sum((cell_now - centre) * np.stack([np.cos(heading), np.sin(heading)], axis=-1), axis=-1))
        approach = phase == APPROACH
        closing = np.where(
            approach, along < np.where(self.closing, 2.0, 1.0) * task.align_tolerance_um, along < task.seat_tolerance_um
        )
        self.closing = closing
        side = np.sign(np.array([offsets[trap_robot == r, 1].mean() for r in range(N_HANDS)]))[trap_robot]  # (T,)
        opened = offsets + np.where(
            closing[:, None, None], 0.0, task.open_gap_um[:, None, None] * side[None, :, None] * [0.0, 1.0]
        )
        about = np.where(((phase == CARRY) & closing)[:, None], centre, cell_now)
        return about[:, None] + rotate(opened, heading)

    def _intended_places(self, places, want, acting):
        """Shared mode, acting (``acting`` (E,)): the grip places (E, T, 2) about the
        place the person intends for the formation, which moves on at the intended
        velocity ``want`` (E, 2) from where they perceived the robots when the cue showed,
        at most ``shared_lead_um`` from where they perceive them now; elsewhere
        ``places`` as they are (about the robots as perceived)."""
        perceived = places.mean(axis=1)
        if self._intended_um is None:
            self._intended_um = perceived.copy()
        intended = np.where(acting[:, None], self._intended_um + want * self.tick_s, perceived)
        lead = intended - perceived
        lead = (
            lead * np.minimum(1.0, self.task.shared_lead_um / np.maximum(np.linalg.norm(lead, axis=-1), 1e-12))[:, None]
        )
        self._intended_um = perceived + lead
        return places + np.where(acting[:, None, None], lead[:, None], 0.0)

    def _guard_closing(self, reach_um, want, duration, traps_now, places, phase, trap_robot):
        """While approaching, each hand closes its robot on the cell (moves it toward the
        other robot, beyond the cell's own drift ``want`` (E, 2)) fast only while it is
        more than ``close_guard_um`` from its grip place (``places`` (E, T, 2)); the last
        ``close_guard_um`` at most ``close_speed_um_s``: the careful end of a grip."""
        robots = np.stack([traps_now[:, trap_robot == r].mean(axis=1) for r in range(N_HANDS)], axis=1)
        goals = np.stack([places[:, trap_robot == r].mean(axis=1) for r in range(N_HANDS)], axis=1)
        across = unit(robots[:, 1] - robots[:, 0])  # closing is along the line between the robots
        inward = np.stack([across, -across], axis=1)  # (E, hands, 2)
        needed = np.sum((goals - robots) * inward, axis=-1)
        allowed = np.maximum(self.task.close_speed_um_s[:, None] * duration, needed - self.task.close_guard_um[:, None])
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
        normal = unit(np.stack([distance[1] - distance[0], distance[2] - distance[0]], axis=-1))
        short = np.maximum(self.task.wall_clearance_um[:, None] - distance[0], 0.0)  # (E, T)
        shift = np.zeros_like(places)
        for r in range(N_HANDS):
            mine = trap_robot == r
            worst = np.argmax(short[:, mine], axis=1)
            rows = np.arange(len(places))
            shift[:, mine] = (short[:, mine][rows, worst, None] * normal[:, mine][rows, worst])[:, None]
        common = np.stack([shift[:, trap_robot == r][:, 0] for r in range(N_HANDS)], axis=1).sum(axis=1)
        return places + np.where(carried[:, None, None], common[:, None], shift)

    def _side_steps_um(self, max_um: float):
        """(E, S) each environment's side steps, 0 to ``max_um`` in steps of its
        ``side_step_resolution_um``, the last repeated to the longest grid, and (E,) how
        many are its own; made once per distinct resolution and kept while ``max_um``
        stays (it changes only with the pace)."""
        if self._side_steps is None or self._side_steps[0] != max_um:
            resolutions, which = np.unique(self.task.side_step_resolution_um, return_inverse=True)
            grids = [np.arange(0.0, max_um + r, r) for r in resolutions]
            longest = max(len(grid) for grid in grids)
            padded = np.stack([np.pad(grid, (0, longest - len(grid)), mode="edge") for grid in grids])
            self._side_steps = max_um, padded[which], np.array([len(grid) for grid in grids])[which]
        return self._side_steps[1:]

    def _side_room_um(self, traps_um, route_direction, max_um: float):
        """(E, 2) how far the formation of traps (E, T, 2) can move to the left and to the
        right of ``route_direction`` (E, 2), in steps of ``side_step_resolution_um``, up to
        ``max_um``, before a handle comes ``wall_clearance_um`` from a wall (or closer
        than it is now); None without walls."""
        if self.wall_distance_um is None:
            return None
        task = self.task
        steps_um, counts = self._side_steps_um(max_um)
        left = np.stack([-route_direction[:, 1], route_direction[:, 0]], axis=-1)
        sides = np.stack([left, -left], axis=1)  # (E, 2, 2)
        probes = traps_um[:, None, None] + steps_um[:, None, :, None, None] * sides[:, :, None, None]
        distance = np.asarray(self.wall_distance_um(probes.reshape(-1, 2)), float).reshape(probes.shape[:-1])
        limit = np.minimum(task.wall_clearance_um[:, None, None, None], distance[:, :, :1])  # (E, 2, 1, T)
        blocked = np.any(distance < limit - 1e-6, axis=-1)  # (E, 2, S)
        free_steps = np.where(blocked.any(axis=-1), np.argmax(blocked, axis=-1) - 1, counts[:, None] - 1)
        return np.take_along_axis(steps_um, np.maximum(free_steps, 0), axis=1)

    def _perceive(self, percept: Percept, trap_robot):
        """What each participant perceives now (one reaction time after the window showed
        it): cell, traps, obstacles, the cell's arc and phase, the fine-tune prompt and
        alpha as shown; the drift of the cell, the obstacles and the robots' motion their
        own hand does not explain, over a glimpse; their own trap motion since what is
        seen."""
        n_traps, n_obs = percept.trap_xy_um.shape[1], percept.obstacle_xy_um.shape[1]
        if self._own_um is None:
            self._own_um = np.zeros((self.n_env, n_traps, 2))
        self._own_shown.append(self._own_um.copy())
        if len(self._own_shown) > self._max_latency_ticks + 1:
            self._own_shown.pop(0)
        own_at_picture = rows_at_latency(self._own_shown, self._latency_ticks)  # own motion as old as the picture
        now = np.concatenate(
            [
                percept.cell_xy_um,
                percept.trap_xy_um.reshape(self.n_env, -1),
                percept.obstacle_xy_um.reshape(self.n_env, -1),
                percept.cell_arc_um[:, None],
                percept.phase[:, None].astype(float),
                own_at_picture.reshape(self.n_env, -1),
                percept.alpha_shown[:, None],
                percept.fine_tune_shown[:, None].astype(float),
            ],
            axis=1,
        )
        seen = self.motor.perceive(np.repeat(now, N_HANDS, axis=0))[::N_HANDS]
        self._history.append(seen)
        if len(self._history) > int(self._glimpses.max()) + 1:
            self._history.pop(0)
        split = np.cumsum([2, 2 * n_traps, 2 * n_obs, 1, 1, 2 * n_traps, 1])
        cell, traps, obstacles, arc, phase, own, alpha, prompt = np.split(seen, split, axis=1)
        earlier = np.split(rows_at_latency(self._history, self._glimpses), split, axis=1)  # a glimpse ago
        elapsed = np.maximum(np.minimum(len(self._history) - 1, self._glimpses), 1) * self.tick_s  # (E,)
        obstacles = obstacles.reshape(self.n_env, n_obs, 2)
        traps = traps.reshape(self.n_env, n_traps, 2)
        own = own.reshape(self.n_env, n_traps, 2)
        seen_moved = (traps - earlier[1].reshape(traps.shape)) - (own - earlier[5].reshape(own.shape))
        unexplained = seen_moved / elapsed[:, None, None]  # the robots' seen motion less the hand's own
        return dict(
            cell=cell,
            cell_velocity=(cell - earlier[0]) / elapsed[:, None],
            traps=traps,
            obstacles=obstacles,
            velocity=(obstacles - earlier[2].reshape(self.n_env, n_obs, 2)) / elapsed[:, None, None],
            arc=arc[:, 0],
            phase=phase[:, 0].round().astype(int),
            since_um=self._own_um - own + self._pending_um[:, trap_robot],
            unexplained_um_s=unexplained,
            alpha=np.clip(alpha[:, 0], 0.0, 1.0),
            prompt=prompt[:, 0] > 0.5,
        )

    def intend(self, percept: Percept, trap_robot):
        """Plan the hands' sub-movements (those due) from what the window shows
        (``percept``) and return dP_h (E, 2 hands, 2) um for this tick."""
        task = self.task
        seen = self._perceive(percept, trap_robot)
        cell, cell_velocity, obstacles, velocity = (seen[k] for k in ("cell", "cell_velocity", "obstacles", "velocity"))
        phase, since_um = seen["phase"], seen["since_um"]
        delay = self.delay_s[:, None]
        carrying = (phase == CARRY)[:, None]
        shared = np.asarray(percept.mode) == "shared"
        acting = shared & carrying[:, 0] & seen["prompt"]  # the fine-tune prompt seen: the hands act
        # the robots' motion the hands do not explain (the autonomy's part, as seen), extrapolated
        other_um_s = np.where(shared[:, None, None], seen["unexplained_um_s"], 0.0)
        traps_now = seen["traps"] + since_um + other_um_s * delay[:, :, None]
        cell_now = np.where(
            carrying, cell + since_um.mean(axis=1) + other_um_s.mean(axis=1) * delay, cell + cell_velocity * delay
        )
        obstacles_now = obstacles + velocity * delay[:, :, None]
        route_direction = unit(self.route.point_at(seen["arc"] + task.lookahead_um) - cell_now)
        watching = shared & carrying[:, 0] & ~seen["prompt"]  # the hand rests: the pace the robots keep
        self._resting_ticks = np.where(watching, self._resting_ticks + 1, 0)
        settled = watching & (self._resting_ticks > self._glimpses)  # the whole glimpse is the robots' own motion
        self._seen_pace_um_s = np.where(settled, np.linalg.norm(cell_velocity, axis=-1), self._seen_pace_um_s)
        pace = np.where(shared, self._seen_pace_um_s, task.carry_speed_um_s)
        want = np.where(
            carrying, route_direction * pace[:, None], np.where(phase[:, None] == APPROACH, cell_velocity, 0.0)
        )
        room = self._side_room_um(traps_now, route_direction, float(np.max(pace * task.horizon_s)))
        chosen, _ = choose_velocity(cell_now, obstacles_now, velocity, want, route_direction, task, room)
        want = np.where(carrying, chosen, want)
        places = self._grip_places(cell_now, traps_now, phase, trap_robot)
        places = self._intended_places(places, want, acting)
        error = np.stack([(places - traps_now)[:, trap_robot == r].mean(axis=1) for r in range(N_HANDS)], axis=1)
        if not task.bimanual:  # one hand moves the formation: only the common part of the correction
            error = np.repeat(error.mean(axis=1, keepdims=True), N_HANDS, axis=1)
        scale = self.retarget_config.motion_scale_um_per_mm
        limit_mm_s = self.retarget_config.max_trap_speed_um_s / scale
        tolerance_mm = np.repeat(task.grip_tolerance_um / scale, N_HANDS)  # per hand
        duration = self.motor.submovement_duration_s(
            np.linalg.norm(error, axis=-1).ravel() / scale, tolerance_mm, limit_mm_s
        ).reshape(self.n_env, N_HANDS)
        # where the hands go in this sub-movement: the places where they will be when it
        # ends, kept off the walls, less the motion the robots make without the hands
        ahead = places + want[:, None] * duration[:, trap_robot, None]  # (E, T, 2)
        off_wall = self._off_walls(ahead, (phase == CARRY) & self.closing, trap_robot) - ahead

        def per_hand(traps):
            return np.stack([traps[:, trap_robot == r].mean(axis=1) for r in range(N_HANDS)], axis=1)

        drift = per_hand(other_um_s)  # (E, hands, 2) um/s
        reach_um = per_hand(ahead - traps_now)
        duration = self.motor.submovement_duration_s(
            np.linalg.norm(reach_um - drift * duration[..., None] + per_hand(off_wall), axis=-1).ravel() / scale,
            tolerance_mm,
            limit_mm_s,
        ).reshape(self.n_env, N_HANDS)
        reach_um = self._guard_closing(reach_um, want, duration, traps_now, places, phase, trap_robot)
        reach_um = reach_um + per_hand(off_wall) - drift * duration[..., None]  # a wall is escaped at once
        if not task.bimanual:
            reach_um = np.repeat(reach_um.mean(axis=1, keepdims=True), N_HANDS, axis=1)
        hand_um_s = reach_um / duration[..., None]
        hand_um_s = np.where(shared[:, None, None] & ~acting[:, None, None], 0.0, hand_um_s)
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
        # efference copy: the hands' own trap motion, weighted by the share the panel shows
        weight = seen["alpha"][:, None, None]
        self._pending_um = self._pending_um * self._pending_keep + weight * (planned_um - increments)
        self._own_um = self._own_um + weight * increments[:, trap_robot]
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
