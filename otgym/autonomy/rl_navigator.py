"""The learned-speed route navigator ``rl`` (the paper's speed control by DQN, section
II-C, carried over to the interactive task's world): the formation follows the planned
route exactly as ``RouteNavigator`` does, but its cruise speed is chosen every
``decision_s`` (0.5 s) by a small Q-network from ``SPEEDS_UM_S`` instead of being the
constant 5 um/s.

The network sees ``speed_features`` (``otgym.tasks.transport.speed_features``:
``N_FEATURES`` numbers per environment in the route's frame: the nearest obstacles
along and across the route, their closing speed as a 1 s least-squares fit of what the
camera showed, their gaps and whether they were ever seen moving; the speed now, the
share of the route left, the traps' margin and whether the cell is carried).

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
from otgym.tasks.transport.speed_features import (  # noqa: F401  (the names the policy's users import from here)
    DECISION_S,
    N_FEATURES,
    SPEEDS_UM_S,
    TRACKER_WINDOW_S,
    route_tangents,
    speed_features,
)

SPEED_POLICY = Path(__file__).resolve().parent.parent / "data" / "policies" / "speed_interactive.npz"
"""The learned speed policy shipped with the package (``otgym.experiments.learned_speed.train``)."""


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


POLICY_TASKS = ("interactive-speed", "interactive")
"""The tasks whose policy files this navigator reads: ``interactive-speed``
(``otgym train --task interactive-speed``), and ``interactive``, the name the first
trainer wrote."""


def load_speed_policy(path=SPEED_POLICY) -> SpeedPolicy:
    """The speed policy in ``path`` (default: the shipped one); raises FileNotFoundError,
    or ValueError for a file that is not an interactive speed policy."""
    meta = policy_meta(path)
    if meta.get("task") not in POLICY_TASKS or meta.get("obs_size") != N_FEATURES:
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
