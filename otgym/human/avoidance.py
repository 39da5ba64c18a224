"""How a simulated participant avoids the obstacles it sees: a choice among assembly
velocities (``choose_velocity``), each judged by the closest approach of every obstacle,
extrapolated at its seen velocity, within a horizon (``miss_um``). All arrays carry a
leading environment axis E; positions in um, velocities in um/s.

Options: the intended velocity, a hurried one (``hurry_factor`` times faster), a slowed
one (half), holding still, backing along the route, stepping straight away from the
threat, and side-steps to either side of the route (forward and aside at 45 and 70
degrees, and straight aside), a side-step foreseen to end where the walls stop it. An
option is safe if no obstacle comes within ``clearance_um`` of the cell in ``horizon_s``
(``still_clearance_um`` for one seen standing still). Of the safe options the person
takes the first in a preference that depends on the threat: crossing the route (track
more than ``along_angle_deg`` off it), keep the path and change the speed; moving along
the route or standing in it, change the path first (waiting does not clear the way; the
pedestrian-avoidance findings of Huber et al., PLoS ONE 9, e89589, 2014). With none
safe, the widest miss; past a standing obstacle a forward option may squeeze to
``squeeze_um`` inside its clearance before the person holds still. Why these rules:
docs/decisions/0044-participant-obstacle-preferences.md.
"""

from __future__ import annotations

import numpy as np

from otgym.human.participant_task import ParticipantTask, ParticipantTasks


def unit(vectors):
    """Unit vectors (..., 2) along ``vectors`` (zero stays zero)."""
    return vectors / np.maximum(np.linalg.norm(vectors, axis=-1, keepdims=True), 1e-9)


def _closest_um(
    cell_um, obstacle_um, obstacle_velocity_um_s, assembly_velocity_um_s, horizon_s, until_s=None, then_um_s=None
):
    """(E, K) the closest each obstacle comes to the cell within ``horizon_s`` (one for
    all, or (E,)) if the assembly moves at ``assembly_velocity_um_s`` (E, 2), or at it
    until ``until_s`` (E,) and at ``then_um_s`` (E, 2) after (a step aside that a wall
    ends)."""
    options = (
        None if until_s is None else np.asarray(until_s)[:, None],
        None if then_um_s is None else np.asarray(then_um_s)[:, None],
    )
    velocity = np.asarray(assembly_velocity_um_s)[:, None]
    return _closest_per_option_um(cell_um, obstacle_um, obstacle_velocity_um_s, velocity, horizon_s, *options)[:, 0]


def _closest_per_option_um(
    cell_um, obstacle_um, obstacle_velocity_um_s, velocities_um_s, horizon_s, until_s=None, then_um_s=None
):
    """``_closest_um`` for O options at once: (E, O, K) for the assembly's velocities
    (E, O, 2), ``until_s`` (E, O) and ``then_um_s`` (E, O, 2); elementwise the same
    arithmetic, so each option's distances are bitwise those of its own call."""

    def closest(relative, closing, duration_s):
        speed2 = np.maximum(np.sum(closing**2, axis=-1), 1e-9)
        t_star = np.clip(-np.sum(relative * closing, axis=-1) / speed2, 0.0, duration_s)
        return np.linalg.norm(relative + closing * t_star[..., None], axis=-1)

    horizon_s = np.broadcast_to(np.asarray(horizon_s, dtype=float), (len(cell_um),))[:, None, None]  # (E, 1, 1)
    relative = (obstacle_um - cell_um[:, None])[:, None]  # (E, 1, K, 2)
    closing = obstacle_velocity_um_s[:, None] - velocities_um_s[:, :, None]  # (E, O, K, 2)
    if until_s is None:
        return closest(relative, closing, horizon_s)
    until = np.clip(until_s[..., None], 0.0, horizon_s)  # (E, O, 1)
    later = relative + closing * until[..., None]
    return np.minimum(
        closest(relative, closing, until),
        closest(later, obstacle_velocity_um_s[:, None] - then_um_s[:, :, None], horizon_s - until),
    )


def miss_um(cell_um, obstacle_um, obstacle_velocity_um_s, assembly_velocity_um_s, horizon_s):
    """(E,) the closest any obstacle (E, K, 2) moving at its velocity comes to the cell
    (E, 2) within ``horizon_s`` (one for all, or (E,)) if the assembly moves at ``assembly_velocity_um_s`` (E, 2),
    and (E, 2) the unit vector from that obstacle to the cell now."""
    miss = _closest_um(cell_um, obstacle_um, obstacle_velocity_um_s, assembly_velocity_um_s, horizon_s)
    worst = np.argmin(miss, axis=1)
    return miss.min(axis=1), unit(cell_um - obstacle_um[np.arange(len(cell_um)), worst])


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
    cell_um,
    obstacle_um,
    obstacle_velocity_um_s,
    want_um_s,
    route_direction,
    task: ParticipantTask | ParticipantTasks,
    room_um=None,
):
    """The person's choice of assembly velocity (E, 2) and whether it differs from
    ``want_um_s``. ``task``: one ``ParticipantTask`` for all, or ``ParticipantTasks``
    (one per environment). Options: intended, hurried, slowed, still, backing along the route,
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
    task = ParticipantTasks(task, len(cell_um)) if isinstance(task, ParticipantTask) else task
    _, away = miss_um(cell_um, obstacle_um, obstacle_velocity_um_s, np.zeros_like(want_um_s), task.horizon_s)
    speed_k = np.linalg.norm(obstacle_velocity_um_s, axis=-1)  # (E, K)
    still_k = speed_k < task.still_speed_um_s[:, None]
    clearance = np.where(still_k, task.still_clearance_um[:, None], task.clearance_um[:, None])
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
        task.hurry_factor[:, None] * want_um_s,
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
    velocities = np.stack(options, axis=1)  # (E, options, 2)
    if room_um is None:
        miss = _closest_per_option_um(cell_um, obstacle_um, obstacle_velocity_um_s, velocities, task.horizon_s)
    else:  # sideways only until a wall, then along the route; a side-step into a wall is no option
        sideways_um_s = np.sum(velocities * left[:, None], axis=-1)  # (E, options)
        free_um = np.where(sideways_um_s > 0, room_um[:, :1], room_um[:, 1:])
        until_s = free_um / np.maximum(np.abs(sideways_um_s), 1e-9)
        miss = _closest_per_option_um(
            cell_um,
            obstacle_um,
            obstacle_velocity_um_s,
            velocities,
            task.horizon_s,
            until_s,
            velocities - sideways_um_s[..., None] * left[:, None],
        )
        walled = (free_um < task.side_step_resolution_um[:, None]) & (np.arange(len(options)) >= len(SPEED_OPTIONS))
        miss = np.where(walled[..., None], -np.inf, miss)
    room = (miss - clearance[:, None]).min(axis=2)  # (E, options)
    safe = room >= 0.0
    onward = np.array(
        [name in ("intended", "hurried", "slowed") for name in SPEED_OPTIONS]
        + [a < 90.0 for a in SIDE_STEP_DEG for _ in range(2)]
    )
    squeeze = still_k[rows, worst][:, None] & onward & ~safe & (room >= -task.squeeze_um[:, None])
    rank = np.where(squeeze, _option_ranks()[1, SPEED_OPTIONS.index("still")] - 0.5, rank)  # just before waiting
    chosen = safe | squeeze
    first = np.min(np.where(chosen, rank, np.inf), axis=1, keepdims=True)
    best = np.argmax(np.where(chosen & (rank == first), room, -np.inf), axis=1)
    choice = np.where(chosen.any(axis=1), best, np.argmax(room, axis=1))
    return velocities[rows, choice], choice > 0
