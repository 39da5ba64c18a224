"""The autonomous command dP_r of the interactive task: the formation of four traps
follows the planned route (the paper's "progressive" autonomy, section II-C). Numpy,
batched over E environments; increments (E, T, 2) um per tick.

* APPROACH: the formation is centred on the cell as the camera sees it now, facing
  along the route, so the robots close in and grip it (the free cell drifts with the
  flow; the formation chases it).
* CARRY: a commanded arc advances at ``cruise_speed_um_s`` but never runs more than
  ``lead_um`` ahead of the cell's own progress, also when the cell goes back. The
  command is a rate, as the paper's speed control along the path: the motion of the
  formation's places as the arc advances (feed-forward; an arc pulled back with the
  cell moves nothing) plus ``carry_gain_per_s`` times each trap's offset from its place
  (drift removed in 1 / gain), the formation's common drift capped at
  ``carry_gain_per_s * lead_um`` (3 um/s) and its shape (the robots' places relative to
  each other, which hold the cell) corrected in full. So a person sharing control who
  holds the assembly back or steps it aside is opposed by at most 3 um/s, not by a
  position servo (docs/decisions/0046-route-navigator-capped-correction.md).
Each trap's increment is capped at ``max_speed_um_s`` times the tick.

The speed is a constant cruise speed, not the shipped DQN speed policy: that policy
was trained on the ``paper`` preset (the paper's weak trap law, 0.27-0.51 um/s in
water at 20 C), whose speeds and observations do not carry over to this task's
literature traps, where obstacles, not trap loss, set the danger. The speed policy
learned for this task's world is navigator ``rl`` (``otgym.autonomy.rl_navigator``).
"""

from __future__ import annotations

import numpy as np

from otgym.task.task import Observation
from otgym.tasks.transport.route_follow import (  # noqa: F401  (the names the navigators' users import from here)
    HEADING_LOOKAROUND_UM,
    RouteFollow,
    cap_speed,
    route_heading,
    route_point,
)


class RouteNavigator:
    """The route navigator (module docstring); offers ``otgym.autonomy.protocol.Navigator``.
    ``route_um`` (M, 2) and ``route_arc_um`` (M,): the planned route and its arc length;
    ``offsets_um`` (T, 2): each trap's place in the formation's frame (x along the route)."""

    def __init__(
        self,
        route_um,
        route_arc_um,
        offsets_um,
        tick_s: float,
        cruise_speed_um_s: float = 5.0,
        lead_um: float = 1.0,
        max_speed_um_s: float = 20.0,
        carry_gain_per_s: float = 3.0,
    ):
        if not (
            cruise_speed_um_s > 0
            and max_speed_um_s >= cruise_speed_um_s
            and lead_um > 0
            and tick_s > 0
            and 0 < carry_gain_per_s * tick_s <= 1
        ):
            raise ValueError(
                f"need 0 < cruise_speed_um_s <= max_speed_um_s, lead_um > 0, tick_s > 0 and "
                f"0 < carry_gain_per_s * tick_s <= 1; got {cruise_speed_um_s}, {max_speed_um_s}, "
                f"{lead_um}, {tick_s}, {carry_gain_per_s}"
            )
        self.route_um = np.asarray(route_um, float)
        self.route_arc_um = np.asarray(route_arc_um, float)
        self.offsets_um = np.asarray(offsets_um, float)
        self.tick_s = tick_s
        self.cruise_speed_um_s = cruise_speed_um_s
        self.lead_um = lead_um
        self.max_speed_um_s = max_speed_um_s
        self.carry_gain_per_s = carry_gain_per_s
        self.commanded_arc_um = np.zeros(0)

    @classmethod
    def for_task(cls, task, max_speed_um_s: float = 20.0, cruise_speed_um_s: float = 5.0) -> RouteNavigator:
        """The navigator on ``task``'s route, formation and tick (what every registered
        navigator offers: ``otgym node autonomy`` and ``otgym play`` build them so)."""
        return cls(
            task.route_um,
            task.route_arc_um,
            task.offsets_um,
            task.config.tick_s,
            cruise_speed_um_s,
            max_speed_um_s=max_speed_um_s,
        )

    def reset(self, n_env: int):
        self.commanded_arc_um = np.zeros(n_env)

    @property
    def follow(self) -> RouteFollow:
        """The follower's arithmetic (``otgym.tasks.transport.route_follow``) with this navigator's settings."""
        return RouteFollow(
            self.route_um,
            self.route_arc_um,
            self.offsets_um,
            self.tick_s,
            self.lead_um,
            self.max_speed_um_s,
            self.carry_gain_per_s,
        )

    def route_point_at(self, arc_um):
        return route_point(self.route_um, self.route_arc_um, arc_um)

    def formation_targets(self, centre_arc_um, centre_um):
        """Trap places (E, T, 2) of the formation centred at ``centre_um`` facing the route at ``centre_arc_um``."""
        return self.follow.formation_targets(centre_arc_um, centre_um)

    def increments(self, obs: Observation) -> np.ndarray:
        """dP_r (E, T, 2) in um for this tick."""
        increment, self.commanded_arc_um = self.follow.increments(
            self.commanded_arc_um, self.cruise_speed_um_s, obs.phase, obs.cell_arc_um, obs.cell_xy_um, obs.trap_xy_um
        )
        return increment
