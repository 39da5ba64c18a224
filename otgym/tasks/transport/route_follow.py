"""The route follower's arithmetic (the paper's "progressive" autonomy, section II-C),
written once for both array modules: ``xp`` is ``numpy`` (the real-time navigator
``otgym.autonomy.navigator.RouteNavigator``, float64, batched over E environments)
or ``jax.numpy`` (the jittable ``interactive-speed`` task,
``otgym.tasks.transport.interactive_speed``). Lengths in um, angles in rad.

``route_increments`` is one tick's dP_r (E, T, 2): in APPROACH the formation is
centred on the cell facing along the route; in CARRY a commanded arc advances at the
cruise speed but at most ``lead_um`` ahead of the cell, and the command is the
formation places' feed-forward motion plus ``carry_gain_per_s`` times each trap's
offset from its place, the common drift capped at ``carry_gain_per_s * lead_um`` and
the shape corrected in full (docs/decisions/0046-route-navigator-capped-correction.md).
Each trap's increment is capped at ``max_speed_um_s`` times the tick.
"""

from __future__ import annotations

import dataclasses

import numpy as np

HEADING_LOOKAROUND_UM = 2.0
APPROACH, CARRY, DONE = 0, 1, 2
"""The interactive task's phases (``otgym.task.task`` counts them)."""


def rotate(vectors, angle, xp=np):
    """Rotate (..., T, 2) vectors by ``angle`` (...,) rad."""
    cos, sin = xp.cos(angle)[..., None], xp.sin(angle)[..., None]
    return xp.stack(
        [cos * vectors[..., 0] - sin * vectors[..., 1], sin * vectors[..., 0] + cos * vectors[..., 1]], axis=-1
    )


def route_point(route_um, route_arc_um, arc_um, xp=np):
    """Points (..., 2) on the route at arc lengths ``arc_um`` (...,), clipped to its ends."""
    arc = xp.clip(arc_um, 0.0, route_arc_um[-1])
    return xp.stack(
        [xp.interp(arc, route_arc_um, route_um[:, 0]), xp.interp(arc, route_arc_um, route_um[:, 1])], axis=-1
    )


def route_heading(route_um, route_arc_um, arc_um, xp=np):
    """Tangent angle (rad) of the route at ``arc_um``, by a central difference."""
    delta = route_point(route_um, route_arc_um, arc_um + HEADING_LOOKAROUND_UM, xp) - route_point(
        route_um, route_arc_um, arc_um - HEADING_LOOKAROUND_UM, xp
    )
    return xp.arctan2(delta[..., 1], delta[..., 0])


def cap_speed(increment_um, max_step_um: float, xp=np):
    """Scale each (..., 2) increment down to at most ``max_step_um`` long."""
    norm = xp.linalg.norm(increment_um, axis=-1, keepdims=True)
    return increment_um * xp.minimum(1.0, max_step_um / xp.maximum(norm, 1e-12))


@dataclasses.dataclass(frozen=True)
class RouteFollow:
    """The follower's route (M, 2) and arc lengths (M,), the formation's trap offsets
    (T, 2) in its own frame (x along the route), and its gains (module docstring)."""

    route_um: object
    route_arc_um: object
    offsets_um: object
    tick_s: float
    lead_um: float = 1.0
    max_speed_um_s: float = 20.0
    carry_gain_per_s: float = 3.0

    def formation_targets(self, centre_arc_um, centre_um, xp=np):
        """Trap places (E, T, 2) of the formation centred at ``centre_um`` (E, 2) facing
        the route at ``centre_arc_um`` (E,)."""
        heading = route_heading(self.route_um, self.route_arc_um, centre_arc_um, xp)
        return centre_um[:, None] + rotate(self.offsets_um[None], heading, xp)

    def increments(self, commanded_arc_um, cruise_speed_um_s, phase, cell_arc_um, cell_xy_um, trap_xy_um, xp=np):
        """(dP_r (E, T, 2) um, the new commanded arc (E,) um) for one tick."""
        carrying = phase == CARRY
        start = carrying & (commanded_arc_um < cell_arc_um - self.lead_um)
        commanded = xp.where(start | (phase == APPROACH), cell_arc_um, commanded_arc_um)
        previous_arc = commanded
        advanced = xp.minimum(commanded + cruise_speed_um_s * self.tick_s, cell_arc_um + self.lead_um)
        commanded = xp.where(carrying, advanced, commanded)
        # with numpy, each command only where some environment uses it (one environment: one of the two)
        lazy = xp is np
        carry = self._carry(commanded, previous_arc, trap_xy_um, xp) if not lazy or carrying.any() else 0.0
        chase = (
            self.formation_targets(cell_arc_um, cell_xy_um, xp) - trap_xy_um if not lazy or not carrying.all() else 0.0
        )
        step = xp.where(carrying[:, None, None], carry, chase)
        return cap_speed(step, self.max_speed_um_s * self.tick_s, xp), commanded

    def _carry(self, commanded_arc_um, previous_arc_um, trap_xy_um, xp):
        """The carrying command (E, T, 2): feed-forward along the advanced arc plus the
        capped correction of the formation's common drift and its full shape correction."""
        at = lambda arc: self.formation_targets(arc, route_point(self.route_um, self.route_arc_um, arc, xp), xp)  # noqa: E731
        places = at(commanded_arc_um)
        advanced_from = xp.minimum(previous_arc_um, commanded_arc_um)  # an arc pulled back moves nothing
        feed_forward = places - at(advanced_from)
        correction = self.carry_gain_per_s * self.tick_s * (places - trap_xy_um)
        common = correction.mean(axis=1, keepdims=True)  # the formation's drift as a whole
        return (
            feed_forward
            + cap_speed(common, self.carry_gain_per_s * self.lead_um * self.tick_s, xp)
            + (correction - common)
        )
