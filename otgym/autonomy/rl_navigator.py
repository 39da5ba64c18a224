"""The learned-speed route navigator ``rl`` (the paper's speed control by DQN, section
II-C, carried over to the interactive task's world): the formation follows the planned
route exactly as ``RouteNavigator`` does, but its cruise speed is chosen every
``decision_s`` (0.5 s) by a small Q-network from ``SPEEDS_UM_S`` instead of being the
constant 5 um/s.

The network sees ``speed_features`` (``N_FEATURES`` numbers per environment), all in the
route's frame so that they do not depend on where on the chip the route runs:

* per obstacle (the ``K_OBSTACLES`` nearest by their gap to the assembly; missing ones
  padded as far away): where it is along the route relative to the cell (its nearest
  route point's arc minus the cell's, / 50 um), how far it is off the route (/ 20 um),
  how fast it closes on the route (its velocity across the route towards it, / 2 um/s,
  from ``ObstacleTracker``'s 1 s least-squares fit of what the camera showed), its
  gap to the assembly (/ 20 um), each clipped to [-2, 2], and whether it has never yet
  been seen moving (1: it may still cross; one that moved and stopped has crossed:
  the scenarios' obstacles wait beside the route, cross once and park);
* the speed now (/ 8 um/s), the share of the route left, the traps' margin (the largest
  handle-to-trap distance over the trap law's escape distance: 1 is a trap lost) and
  whether the formation carries the cell.

The policy file (``otgym.rl.policy``'s format, ``__meta__`` with ``task:
"interactive"``, the speeds, the decision period and the layer widths) is trained by
``otgym experiment learned-speed`` (``otgym.experiments.learned_speed.train``: double DQN on the batched
interactive task in autonomous mode; see that module). ``SPEED_POLICY`` is the one
shipped with the package.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Sequence
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

from otgym.autonomy.navigator import RouteNavigator
from otgym.autonomy.obstacle_prediction import ObstacleTracker
from otgym.rl.network import QNetwork
from otgym.rl.policy import load_policy, policy_meta
from otgym.task.task import CARRY, Observation

SPEEDS_UM_S = (0.0, 2.0, 3.5, 5.0, 6.5, 8.0)
"""The cruise speeds the policy chooses from, um/s (5: the route navigator's constant
cruise; 8: a person's hurried pace)."""
DECISION_S = 0.5
"""How often the policy chooses a speed, s (an obstacle at 2 um/s moves 1 um meanwhile)."""
K_OBSTACLES = 4
"""Obstacles the policy sees (the task's scenarios have four)."""
PER_OBSTACLE = 5
N_GLOBAL = 4
N_FEATURES = K_OBSTACLES * PER_OBSTACLE + N_GLOBAL
ALONG_SCALE_UM = 50.0
ACROSS_SCALE_UM = 20.0
CLOSING_SCALE_UM_S = 2.0
GAP_SCALE_UM = 20.0
SPEED_SCALE_UM_S = 8.0
FEATURE_CLIP = 2.0
TRACKER_WINDOW_S = 1.0
FAR_OBSTACLE = (FEATURE_CLIP, FEATURE_CLIP, 0.0, FEATURE_CLIP, 0.0)
"""The features of an obstacle that is not there: far ahead, far off the route, still."""
SPEED_POLICY = Path(__file__).resolve().parent.parent / "data" / "policies" / "speed_interactive.npz"
"""The learned speed policy shipped with the package (``otgym.experiments.learned_speed.train``)."""


def route_tangents(route_um) -> np.ndarray:
    """Unit tangents (M, 2) of a dense route (M, 2), by central differences."""
    tangent = np.gradient(np.asarray(route_um, float), axis=0)
    return tangent / np.maximum(np.linalg.norm(tangent, axis=1, keepdims=True), 1e-12)


def speed_features(
    route_um,
    route_arc_um,
    tangents,
    cell_arc_um,
    obstacle_xy_um,
    obstacle_velocity_um_s,
    obstacle_gap_um,
    obstacle_idle,
    speed_um_s,
    trap_margin,
    carrying,
) -> np.ndarray:
    """Features (E, ``N_FEATURES``) float32 (module docstring). Obstacles (E, K, 2) are
    placed on the route by their nearest route point; ``obstacle_idle`` (E, K) is 1 for
    one never seen moving; ``speed_um_s``, ``trap_margin`` and ``carrying`` are (E,)."""
    route_um = np.asarray(route_um, float)
    xy = np.asarray(obstacle_xy_um, float)
    n_env, n_obstacles = xy.shape[:2]
    if n_obstacles:
        nearest = np.argmin(np.sum((xy[:, :, None] - route_um[None, None]) ** 2, axis=-1), axis=-1)  # (E, K)
        tangent = tangents[nearest]
        offset = xy - route_um[nearest]
        across = tangent[..., 0] * offset[..., 1] - tangent[..., 1] * offset[..., 0]
        velocity = np.asarray(obstacle_velocity_um_s, float)
        across_velocity = tangent[..., 0] * velocity[..., 1] - tangent[..., 1] * velocity[..., 0]
        per_obstacle = np.stack(
            [
                (route_arc_um[nearest] - np.asarray(cell_arc_um, float)[:, None]) / ALONG_SCALE_UM,
                np.abs(across) / ACROSS_SCALE_UM,
                -np.sign(across) * across_velocity / CLOSING_SCALE_UM_S,
                np.asarray(obstacle_gap_um, float) / GAP_SCALE_UM,
                np.asarray(obstacle_idle, float),
            ],
            axis=-1,
        )
        order = np.argsort(np.asarray(obstacle_gap_um, float), axis=1, kind="stable")[:, :K_OBSTACLES]
        per_obstacle = np.take_along_axis(per_obstacle, order[..., None], axis=1)
    else:
        per_obstacle = np.zeros((n_env, 0, PER_OBSTACLE))
    padding = np.broadcast_to(np.array(FAR_OBSTACLE), (n_env, K_OBSTACLES - per_obstacle.shape[1], PER_OBSTACLE))
    obstacles = np.clip(np.concatenate([per_obstacle, padding], axis=1), -FEATURE_CLIP, FEATURE_CLIP)
    length = float(route_arc_um[-1])
    general = np.stack(
        [
            np.asarray(speed_um_s, float) / SPEED_SCALE_UM_S,
            (length - np.asarray(cell_arc_um, float)) / length,
            np.asarray(trap_margin, float),
            np.asarray(carrying, float),
        ],
        axis=-1,
    )
    return np.concatenate(
        [obstacles.reshape(n_env, -1), np.clip(general, -FEATURE_CLIP, FEATURE_CLIP)], axis=-1
    ).astype(np.float32)


@dataclasses.dataclass(frozen=True)
class SpeedPolicy:
    """A trained Q-network over ``speed_features``: ``q_values`` (E, n_speeds) and the
    greedy speed index ``choose``."""

    q_params: dict
    hidden: tuple[int, ...]
    speeds_um_s: tuple[float, ...] = SPEEDS_UM_S
    decision_s: float = DECISION_S

    def __post_init__(self):
        _check_speeds(self.speeds_um_s, self.decision_s)
        object.__setattr__(self, "_apply", _q_apply(len(self.speeds_um_s), tuple(self.hidden)))

    def q_values(self, features) -> np.ndarray:
        features = np.asarray(features, np.float32)
        if features.ndim != 2 or features.shape[1] != N_FEATURES:
            raise ValueError(f"features must be (E, {N_FEATURES}), got {features.shape}")
        return np.asarray(self._apply(self.q_params, jnp.asarray(features)))

    def choose(self, features) -> np.ndarray:
        return np.argmax(self.q_values(features), axis=1)


@functools.cache
def _q_apply(n_speeds: int, hidden: tuple[int, ...]):
    """The jitted forward pass of one architecture, shared by every policy with it (one
    compilation, not one per policy loaded)."""
    return jax.jit(QNetwork(n_speeds, hidden).apply)


def _check_speeds(speeds_um_s: Sequence[float], decision_s: float) -> None:
    speeds = np.asarray(speeds_um_s, float)
    if speeds.ndim != 1 or len(speeds) < 2 or not np.all(np.isfinite(speeds)) or np.any(speeds < 0):
        raise ValueError(f"speeds_um_s must be two or more finite speeds >= 0, got {speeds_um_s!r}")
    if not (np.isfinite(decision_s) and decision_s > 0):
        raise ValueError(f"decision_s must be positive, got {decision_s!r}")


def load_speed_policy(path=SPEED_POLICY) -> SpeedPolicy:
    """The speed policy in ``path`` (default: the shipped one); raises FileNotFoundError,
    or ValueError for a file that is not an interactive speed policy."""
    meta = policy_meta(path)
    if meta.get("task") != "interactive" or meta.get("obs_size") != N_FEATURES:
        raise ValueError(
            f"{path} is not an interactive-task speed policy with {N_FEATURES} features "
            f"(task {meta.get('task')!r}, observation size {meta.get('obs_size')!r})"
        )
    speeds = tuple(float(v) for v in meta["speeds_um_s"])
    q_params, _ = load_policy(path, N_FEATURES, len(speeds))
    return SpeedPolicy(q_params, tuple(meta["hidden"]), speeds, float(meta["decision_s"]))


class RLNavigator(RouteNavigator):
    """``RouteNavigator`` whose cruise speed (per environment) comes from ``policy``
    every ``policy.decision_s``; offers ``otgym.autonomy.protocol.Navigator``.
    ``policy``: anything with ``choose(features) -> (n,)`` speed indices,
    ``speeds_um_s`` and ``decision_s`` (a ``SpeedPolicy``, or training's explorer).
    After each ``increments``, ``last_decided`` (E,) says which environments chose and
    ``last_features`` / ``last_actions`` hold their features and choices."""

    def __init__(
        self,
        route_um,
        route_arc_um,
        offsets_um,
        tick_s: float,
        policy,
        escape_distance_um: float,
        max_speed_um_s: float = 20.0,
        **route_options,
    ):
        _check_speeds(policy.speeds_um_s, policy.decision_s)
        top = max(float(max(policy.speeds_um_s)), 1e-9)
        super().__init__(
            route_um, route_arc_um, offsets_um, tick_s, top, max_speed_um_s=max_speed_um_s, **route_options
        )
        if not (np.isfinite(escape_distance_um) and escape_distance_um > 0):
            raise ValueError(f"escape_distance_um must be positive, got {escape_distance_um!r}")
        self.policy = policy
        self.speeds_um_s = np.asarray(policy.speeds_um_s, float)
        self.escape_distance_um = float(escape_distance_um)
        self.decision_ticks = max(1, int(round(policy.decision_s / tick_s)))
        self.tangents = route_tangents(self.route_um)
        self.tracker = ObstacleTracker(TRACKER_WINDOW_S, tick_s)
        self.ticks = np.zeros(0, int)
        self.last_decided = np.zeros(0, bool)
        self.last_features = np.zeros((0, N_FEATURES), np.float32)
        self.last_actions = np.zeros(0, int)

    @classmethod
    def for_task(cls, task, policy=None, max_speed_um_s: float = 20.0) -> RLNavigator:
        """The navigator on ``task``'s route and formation (``policy`` default: the shipped one)."""
        return cls(
            task.route_um,
            task.route_arc_um,
            task.offsets_um,
            task.config.tick_s,
            policy if policy is not None else load_speed_policy(),
            task.config.scene.trap_law.escape_distance,
            max_speed_um_s=max_speed_um_s,
        )

    def reset(self, n_env: int):
        super().reset(n_env)
        self.cruise_speed_um_s = np.zeros(n_env)  # RouteNavigator's arithmetic takes a speed per environment
        self.ticks = np.zeros(n_env, int)
        self.tracker.reset(n_env, 0)
        self.last_decided = np.zeros(n_env, bool)

    def features(self, obs: Observation) -> np.ndarray:
        """``speed_features`` of every environment now (the tracker must have seen ``obs``)."""
        if self.tracker.xy_um.shape[2] != obs.obstacle_xy_um.shape[1]:
            raise ValueError("the tracker has not seen this observation's obstacles")
        return speed_features(
            self.route_um,
            self.route_arc_um,
            self.tangents,
            obs.cell_arc_um,
            obs.obstacle_xy_um,
            self.tracker.velocity_um_s(),
            obs.obstacle_gap_um,
            ~self.tracker.seen_moving,
            self.cruise_speed_um_s,
            obs.trap_distance_um.max(axis=1) / self.escape_distance_um,
            obs.phase == CARRY,
        )

    def increments(self, obs: Observation) -> np.ndarray:
        if len(self.ticks) != len(obs.time_s):
            raise ValueError(f"reset({len(obs.time_s)}) first: the navigator holds {len(self.ticks)} environments")
        if self.tracker.xy_um.shape[2] != obs.obstacle_xy_um.shape[1]:
            self.tracker.reset(len(obs.time_s), obs.obstacle_xy_um.shape[1])
        self.tracker.observe(obs.time_s, obs.obstacle_xy_um)
        due = self.ticks % self.decision_ticks == 0
        self.last_decided = due
        if due.any():
            rows = np.flatnonzero(due)
            features = self.features(obs)[rows]
            actions = np.asarray(self.policy.choose(features), int)
            self.cruise_speed_um_s = self.cruise_speed_um_s.copy()
            self.cruise_speed_um_s[rows] = self.speeds_um_s[actions]
            self.last_features, self.last_actions = features, actions
        self.ticks = self.ticks + 1
        return super().increments(obs)


class TrialAutonomy:
    """A navigator as the real-time loop's ``otgym.autonomy.protocol.Autonomy`` (one
    environment) across a session's trials: ``reset(1)`` on the first call and whenever
    the observation's time goes back (a new trial starts at 0 s), as the autonomy node
    resets at each ``trial_start``."""

    def __init__(self, navigator):
        self.navigator = navigator
        self.last_time_s = None

    def __call__(self, observation: Observation) -> np.ndarray:
        time_s = float(observation.time_s[0])
        if self.last_time_s is None or time_s < self.last_time_s:
            self.navigator.reset(1)
        self.last_time_s = time_s
        return self.navigator.increments(observation)
