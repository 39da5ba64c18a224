"""Simulated participants whose task-level parameters differ between environments:
one ``SimulatedParticipants`` per distinct ``ParticipantTask``, each over its own rows of
the batch, behind the same two calls (``intend``, ``feel``). Lets one batch
of trials compare task parameters (``otgym experiment human-sensitivity``) at the cost
of one batch, not one per value."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from otgym.human.params import HumanParams
from otgym.human.participant_task import ParticipantTask
from otgym.human.participants import N_HANDS, SimulatedParticipants
from otgym.human.percept import DISPLAY_LATENCY_S, Percept, ShownRoute


def _rows(obs, rows: np.ndarray):
    """The observation or percept of the environments ``rows`` only (every array field sliced)."""
    return type(obs)(
        **{name: value[rows] if isinstance(value, np.ndarray) else value for name, value in vars(obs).items()}
    )


class ParticipantGroups:
    """E simulated participants, participant ``e`` with task parameters ``tasks[e]``.

    Group g (the g-th distinct task, in order of first appearance) is a
    ``SimulatedParticipants`` over its rows with random seed ``seed + g``: with one
    task it is that one ``SimulatedParticipants`` (seed ``seed``)."""

    def __init__(
        self,
        params: Sequence[HumanParams],
        tick_s: float,
        seed: int,
        route: ShownRoute,
        retarget,
        feedback,
        bend_distance_um: float,
        tasks: Sequence[ParticipantTask],
        wall_distance_um=None,
        display_latency_s: float = DISPLAY_LATENCY_S,
    ):
        if len(tasks) != len(params):
            raise ValueError(f"{len(tasks)} participant tasks for {len(params)} participants")
        self.n_env = len(params)
        distinct = list(dict.fromkeys(tasks))
        self.groups = []
        for g, task in enumerate(distinct):
            rows = np.flatnonzero([t == task for t in tasks])
            people = SimulatedParticipants(
                [params[i] for i in rows],
                tick_s,
                seed + g,
                route,
                retarget,
                feedback,
                bend_distance_um,
                task,
                wall_distance_um,
                display_latency_s,
            )
            self.groups.append((rows, people))

    def intend(self, percept: Percept, trap_robot):
        """dP_h (E, 2 hands, 2) um: each group's ``intend`` on its rows of ``percept``."""
        out = np.zeros((self.n_env, N_HANDS, 2))
        for rows, people in self.groups:
            out[rows] = people.intend(_rows(percept, rows), trap_robot)
        return out

    def feel(self, obs, trap_force_pn: np.ndarray, trap_robot) -> None:
        """Each group's stylus force (``SimulatedParticipants.feel``) on its rows."""
        forces = np.asarray(trap_force_pn)
        for rows, people in self.groups:
            people.feel(_rows(obs, rows), forces[rows], trap_robot)
