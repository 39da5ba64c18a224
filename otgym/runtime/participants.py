"""Simulated participants: a closed-loop model of a person driving the interactive task
with two haptic styluses (bimanual: hand 0 moves robot A's traps, hand 1 robot B's),
vectorised over E environments. The hand itself is ``otgym.planning.human``'s motor
model (reaction delay, intermittent sub-movements with Fitts timing, neuromuscular lag,
speed-dependent noise, tremor, yielding to the stylus force); this module is the task
level: what the person intends each time a sub-movement starts.

What the person does, on what they saw one reaction time ago:
* APPROACH: bring each robot to its place around the cell (the grip formation),
  pursuing the cell as it drifts (its velocity seen over a glimpse, fed forward).
* CARRY: move the assembly toward the route point ``lookahead_um`` ahead of the cell at
  their carry speed, each hand also correcting its robot's place in the grip (bimanual
  coordination is the person's job: each hand errs on its own). A hand translates its
  robot's traps and cannot turn it, so the person keeps the grip as it is: the places
  are those of the formation at the robots' present orientation (the line between
  the robots' traps), not the route's.
  Manual: at ``carry_speed_um_s`` (a careful pace; an assumption, see
  ``ParticipantTask``). Shared: at the pace of the autonomy's motion, which they follow.
* Obstacles: each obstacle's motion is extrapolated from two glimpses ``glimpse_s``
  apart; if, with the assembly moving as intended, it would pass within
  ``clearance_um`` of the assembly in the next ``horizon_s``, the person waits (or backs
  away along the line from the obstacle if waiting would not clear it either).
* Shared mode: they leave the autonomy's command alone (follow it) unless a threat is
  seen while the interface's cue shows alpha in the fine-tuning band; then they
  command what brings the blend to their intention, dP_h = (dP_want - (1 - alpha)
  dP_r) / alpha, as far as the trap-speed clamp allows.
Stylus units: chip um -> stylus mm through the retargeting scale (tau) and plane; the
hands feel the feedback force (``otgym.teleop.feedback.chip_force_n`` on the trap
forces of their robot's handles) and yield to it.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from otgym.planning.human import HumanMotor, HumanParams
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
    (8.7 um) plus the obstacle's (3 um) plus 3 um to spare."""

    carry_speed_um_s: float = 2.0
    lookahead_um: float = 5.0
    grip_gain_per_s: float = 2.0
    grip_tolerance_um: float = 0.5
    clearance_um: float = 14.7
    horizon_s: float = 6.0
    glimpse_s: float = 0.5
    fine_tune_alpha: float = 0.3
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


def _rotate(vectors, angle):
    """Rotate (..., T, 2) vectors by ``angle`` (...,) rad."""
    cos, sin = np.cos(angle)[..., None], np.sin(angle)[..., None]
    return np.stack([cos * vectors[..., 0] - sin * vectors[..., 1], sin * vectors[..., 0] + cos * vectors[..., 1]],
                    axis=-1)


class SimulatedParticipants:
    """E simulated participants (one per environment), each with two hands."""

    def __init__(self, params: list[HumanParams], tick_s: float, seed: int, navigator,
                 retarget: RetargetConfig, feedback: FeedbackConfig, bend_distance_um: float,
                 task: ParticipantTask = ParticipantTask()):
        self.n_env = len(params)
        self.tick_s = tick_s
        self.navigator = navigator
        self.task = task
        self.retarget_config = retarget
        self.feedback_config = feedback
        self.bend_distance_um = bend_distance_um
        hands = [p for p in params for _ in range(N_HANDS)]
        self.motor = HumanMotor(hands, 1.0 / tick_s, np.random.default_rng(seed))
        self.retargeter = BatchRetargeter(retarget, 1.0 / tick_s, self.n_env * N_HANDS)
        self._glimpses = max(1, int(round(task.glimpse_s / tick_s)))
        self._history: list[np.ndarray] = []
        self.feedback_n = np.zeros((self.n_env, N_HANDS, 2))

    def _perceive(self, obs):
        """What each participant sees now (delayed): cell, traps, obstacles now and a glimpse ago."""
        now = np.concatenate([obs.cell_xy_um, obs.trap_xy_um.reshape(self.n_env, -1),
                              obs.obstacle_xy_um.reshape(self.n_env, -1), obs.cell_arc_um[:, None],
                              obs.phase[:, None].astype(float)], axis=1)
        seen = self.motor.perceive(np.repeat(now, N_HANDS, axis=0))[::N_HANDS]
        self._history.append(seen)
        if len(self._history) > self._glimpses + 1:
            self._history.pop(0)
        n_traps = obs.trap_xy_um.shape[1]
        n_obs = obs.obstacle_xy_um.shape[1]
        split = np.cumsum([2, 2 * n_traps, 2 * n_obs, 1])
        cell, traps, obstacles, arc, phase = np.split(seen, split, axis=1)
        earlier = np.split(self._history[0], split, axis=1)
        elapsed = max(len(self._history) - 1, 1) * self.tick_s
        velocity = (obstacles.reshape(self.n_env, n_obs, 2) - earlier[2].reshape(self.n_env, n_obs, 2)) / elapsed
        cell_velocity = (cell - earlier[0]) / elapsed
        return (cell, cell_velocity, traps.reshape(self.n_env, n_traps, 2), obstacles.reshape(self.n_env, n_obs, 2),
                velocity, arc[:, 0], phase[:, 0].round().astype(int))

    def _threat(self, cell, obstacles, velocity, assembly_velocity):
        """(E,) whether moving at ``assembly_velocity`` (E, 2) an obstacle would come
        within the clearance in the horizon, and the unit vector away from the worst one."""
        relative = obstacles - cell[:, None]
        closing = velocity - assembly_velocity[:, None]
        speed2 = np.maximum(np.sum(closing**2, axis=-1), 1e-9)
        t_star = np.clip(-np.sum(relative * closing, axis=-1) / speed2, 0.0, self.task.horizon_s)
        miss = np.linalg.norm(relative + closing * t_star[..., None], axis=-1)
        danger = miss < self.task.clearance_um
        worst = np.argmin(np.where(danger, t_star, np.inf), axis=1)
        away = -relative[np.arange(self.n_env), worst]
        away /= np.maximum(np.linalg.norm(away, axis=-1, keepdims=True), 1e-9)
        return danger.any(axis=1), away

    def intend(self, obs, mode: np.ndarray, alpha: np.ndarray, robot_increment_um: np.ndarray, trap_robot):
        """Plan the hands' sub-movements (those due) and return dP_h (E, 2 hands, 2) um for this tick."""
        task = self.task
        cell, cell_velocity, traps, obstacles, velocity, arc, phase = self._perceive(obs)
        ahead = self.navigator.route_point_at(arc + task.lookahead_um) - cell
        direction = ahead / np.maximum(np.linalg.norm(ahead, axis=-1, keepdims=True), 1e-9)
        autonomy_velocity = robot_increment_um.mean(axis=1) / self.tick_s
        follow = np.linalg.norm(autonomy_velocity, axis=-1, keepdims=True)
        speed = np.where((mode == "shared")[:, None], follow, task.carry_speed_um_s)
        want = np.where((phase == 1)[:, None], direction * speed, cell_velocity)  # (E, 2) assembly velocity, um/s
        threat, away = self._threat(cell, obstacles, velocity, want)
        still_threat, _ = self._threat(cell, obstacles, velocity, np.zeros_like(want))
        evade = np.where(still_threat[:, None], away * task.carry_speed_um_s, 0.0)
        want = np.where((threat & (phase == 1))[:, None], evade, want)
        across = traps[:, trap_robot == 1].mean(axis=1) - traps[:, trap_robot == 0].mean(axis=1)
        grip_heading = np.arctan2(-across[:, 0], across[:, 1])  # robot A -> B along the formation's normal
        targets = cell[:, None] + _rotate(self.navigator.offsets_um[None], grip_heading)  # (E, T, 2)
        correction = np.stack([(targets - traps)[:, trap_robot == r].mean(axis=1) for r in range(N_HANDS)], axis=1)
        if not task.bimanual:  # one hand moves the formation: only the common part of the correction
            correction = np.repeat(correction.mean(axis=1, keepdims=True), N_HANDS, axis=1)
        hand_um_s = want[:, None] + task.grip_gain_per_s * correction  # (E, hands, 2)
        shared = (mode == "shared")[:, None, None]
        robot_hand = np.stack([robot_increment_um[:, trap_robot == r].mean(axis=1) for r in range(N_HANDS)], axis=1)
        cue = (alpha >= task.fine_tune_alpha) & threat
        safe_alpha = np.maximum(alpha, 1e-3)[:, None, None]
        override = (hand_um_s * self.tick_s - (1 - safe_alpha) * robot_hand) / safe_alpha / self.tick_s
        hand_um_s = np.where(shared, np.where(cue[:, None, None], override, robot_hand / self.tick_s), hand_um_s)
        scale = self.retarget_config.motion_scale_um_per_mm
        planar_mm_s = (hand_um_s * np.array([1.0, -1.0]) / scale).reshape(-1, 2)  # chip -> stylus x, y
        horizon = self.motor.submovement_duration_s(0.0, 1.0)  # the correction interval
        speed_mm_s = np.maximum(np.linalg.norm(planar_mm_s, axis=-1), 1e-6)
        self.motor.plan(planar_mm_s * horizon[:, None], task.grip_tolerance_um / scale, speed_mm_s * 1.0001)
        stylus = self.motor.step(self.feedback_n.reshape(-1, 2) * np.array([1.0, -1.0]))
        increments = self.retargeter(stylus).reshape(self.n_env, N_HANDS, 2)
        return increments if task.bimanual else np.repeat(increments[:, :1], N_HANDS, axis=1)

    def feel(self, obs, trap_force_pn: np.ndarray, trap_robot):
        """The stylus force each hand feels next tick, from its robot's handle forces (E, T, 2)."""
        offsets = obs.trap_xy_um - obs.handle_xy_um
        valid = np.ones(offsets.shape[:2], bool)
        forces = [chip_force_n(trap_force_pn[:, trap_robot == r], offsets[:, trap_robot == r],
                               obs.contact_force_pn[:, r], valid[:, trap_robot == r], self.feedback_config,
                               self.bend_distance_um) for r in range(N_HANDS)]
        force = np.stack(forces, axis=1)
        norm = np.linalg.norm(force, axis=-1, keepdims=True)
        limit = self.feedback_config.force_limit_n
        self.feedback_n = force * np.minimum(1.0, limit / np.maximum(norm, 1e-300))
