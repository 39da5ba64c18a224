"""Obstacle motion predicted from what the microscope shows.

The model-predictive navigator (``otgym.autonomy.mpc``) may not read a scenario's
future tracks: it sees obstacle positions tick by tick, like a person at the
microscope. ``ObstacleTracker`` keeps each obstacle's last ``window_s`` of observed
positions and fits a constant velocity to them by ordinary least squares (the slope
of position against time, per axis). The prediction is the constant-velocity model:
the obstacle goes on from where it was last seen at that velocity, the usual baseline
of pedestrian and vehicle prediction (Schoeller et al., "What the constant velocity
model can teach us about pedestrian motion prediction", IEEE RA-L 5, 1696, 2020).

Noise: a free sphere of radius a diffuses with D = kT / (6 pi eta a) (0.08 um^2/s for
a 3 um obstacle in water at 25 C); the least-squares slope of a Brownian path sampled
densely over a window T has variance 12 D / (5 T), so 0.44 um/s per axis over the
default 1 s, against obstacles that move at 2 um/s. The prediction is expressed as tracks in the form the task's scenarios use
(``otgym.tasks.transport.scenario.propulsion_um_s``), so the model steers its obstacles with
the same bounded propulsion as the task, but along the predicted line.
"""

from __future__ import annotations

import numpy as np

from otgym.tasks.transport.speed_features import MOVING_SPEED_UM_S, tracked_velocity_um_s

PREDICTION_LENGTH_S = 1e6
"""Predicted tracks never end: the model has no way of knowing where an obstacle stops."""


class ObstacleTracker:
    """Observed positions of K obstacles in E environments over a sliding window."""

    def __init__(self, window_s: float, tick_s: float):
        if not (window_s > 0 and tick_s > 0 and np.isfinite(window_s) and np.isfinite(tick_s)):
            raise ValueError(f"window_s and tick_s must be positive, got {window_s}, {tick_s}")
        self.capacity = max(2, int(round(window_s / tick_s)) + 1)
        self.times_s = np.zeros((0, self.capacity))
        self.xy_um = np.zeros((0, self.capacity, 0, 2))
        self.count = np.zeros(0, int)
        self.seen_moving = np.zeros((0, 0), bool)

    def reset(self, n_env: int, n_obstacles: int) -> None:
        self.times_s = np.zeros((n_env, self.capacity))
        self.xy_um = np.zeros((n_env, self.capacity, n_obstacles, 2))
        self.count = np.zeros(n_env, int)
        self.seen_moving = np.zeros((n_env, n_obstacles), bool)

    def observe(self, time_s, obstacle_xy_um) -> None:
        """Add one observation per environment: times (E,) s, positions (E, K, 2) um."""
        slot = self.count % self.capacity
        rows = np.arange(len(slot))
        self.times_s[rows, slot] = np.asarray(time_s, float)
        self.xy_um[rows, slot] = np.asarray(obstacle_xy_um, float)
        self.count += 1
        self.seen_moving |= (self.count >= self.capacity)[:, None] & (
            np.linalg.norm(self.velocity_um_s(), axis=-1) > MOVING_SPEED_UM_S
        )

    def latest_um(self) -> np.ndarray:
        """The last observed positions (E, K, 2)."""
        slot = (self.count - 1) % self.capacity
        return self.xy_um[np.arange(len(slot)), slot]

    def velocity_um_s(self) -> np.ndarray:
        """Least-squares velocity (E, K, 2) over the window; zero with fewer than two observations."""
        return tracked_velocity_um_s(self.times_s, self.xy_um, self.count)

    def predicted_tracks(self, now_s) -> dict[str, np.ndarray]:
        """Constant-velocity tracks (E, K, ...) from the last observed positions at
        ``now_s`` (E,), in the form of ``otgym.tasks.transport.scenario.stack_tracks``, plus
        ``idle`` (E, K): 1 for an obstacle never yet seen moving (it may still start;
        one that moved and stopped has come to rest), else 0."""
        velocity = self.velocity_um_s()
        speed = np.linalg.norm(velocity, axis=-1)
        direction = np.where(speed[..., None] > 0, velocity / np.maximum(speed, 1e-12)[..., None], 0.0)
        now = np.broadcast_to(np.asarray(now_s, float)[:, None], speed.shape)
        latest = self.latest_um()
        # departed one second ago from one second back along the line: moving from the first model step on
        return {
            "start_um": latest - velocity,
            "direction": direction,
            "speed_um_s": speed,
            "depart_s": now - 1.0,
            "end_s": now + PREDICTION_LENGTH_S,
            "idle": (~self.seen_moving).astype(float),
        }
