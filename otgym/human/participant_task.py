"""The task-level parameters of the simulated participants (``ParticipantTask``): what
a person intends with the robots, not the motor constants of their hands
(``otgym.human.params.HumanParams``). Lengths in um at the chip, speeds in um/s, times
in s, angles in degrees."""

from __future__ import annotations

import dataclasses

import numpy as np


@dataclasses.dataclass(frozen=True)
class ParticipantTask:
    """Task-level parameters of the simulated participants (not motor constants).

    ``carry_speed_um_s``: manual transport pace, 2 um/s. Not a literature constant: manual
    optical-tweezers transport of cells is reported at a few um/s, and here each hand
    must also keep its robot in the grip (a gripper that strays 1 um from the cell loses
    it), which sets a careful pace. ``clearance_um``: the assembly's radius (8.7 um) plus
    the obstacle's (3 um) plus 1.5 um to spare (the scenarios park an obstacle 14 um from
    the route, which must count as passable). ``grip_tolerance_um``: the Fitts tolerance
    of a reach to a grip place. ``along_angle_deg``: a threat whose track lies within
    this angle of the route moves along it (``otgym.human.avoidance``).
    ``side_step_resolution_um``: the step in which the person judges the room beside the
    assembly. ``squeeze_um``: how much of ``still_clearance_um`` the person gives up to
    pass a standing obstacle when no option keeps all of it: beside the assembly its
    handles reach 7.75 um from the cell's centre (6.5 um offset plus their 1.25 um
    radius), 0.95 um less than the 8.7 um radius that the clearances count, so such a
    pass still leaves about 0.45 um of water. The other fields are named in
    ``otgym.human.participants``' docstring; the reasons for their values in
    docs/decisions/0041-0045."""

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
    pending_memory_s: float = 0.5
    wall_clearance_um: float = 2.0
    close_speed_um_s: float = 0.75
    close_guard_um: float = 1.5
    along_angle_deg: float = 45.0
    side_step_resolution_um: float = 0.5
    squeeze_um: float = 1.0
    shared_lead_um: float = 2.0
    """Shared mode, acting on the cue: the place the person intends for the robots moves
    on at the intended velocity, but at most this far from where they perceive the
    robots (a place that ran away while the robots could not follow would make the hands
    jump when they could). Assumed (reasoning, no source): range 1-5 um, of the order of
    the grip's own tolerances (``open_gap_um``) and below ``lookahead_um``."""
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


class ParticipantTasks:
    """The task parameters of E participants side by side: each ``ParticipantTask``
    field as an (E,) float array (``bimanual`` one bool for all: it is the set-up, not a
    person's parameter). ``SimulatedParticipants`` reads its task through this, so one
    batch can give every environment its own task parameters at the cost of one."""

    def __init__(self, tasks, n_env: int):
        tasks = [tasks] * n_env if isinstance(tasks, ParticipantTask) else list(tasks)
        if len(tasks) != n_env:
            raise ValueError(f"{len(tasks)} participant tasks for {n_env} participants")
        if not all(isinstance(task, ParticipantTask) for task in tasks):
            raise TypeError("participant tasks must be ParticipantTask instances")
        if len({task.bimanual for task in tasks}) > 1:
            raise ValueError("every participant of a batch must use the same set-up (bimanual)")
        self.n_env = n_env
        self.bimanual = tasks[0].bimanual if tasks else True
        for field in dataclasses.fields(ParticipantTask):
            if field.name != "bimanual":
                setattr(self, field.name, np.array([getattr(task, field.name) for task in tasks], dtype=float))
