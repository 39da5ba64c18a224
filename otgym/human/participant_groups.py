"""Simulated participants whose task-level parameters differ between environments:
one ``SimulatedParticipants`` per distinct ``ParticipantTask``, each over its own rows of
the batch, behind the same three calls (``intend``, ``moved``, ``feel``). Lets one batch
of trials compare task parameters (``otgym experiment human-sensitivity``) at the cost
of one batch, not one per value."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from otgym.human.params import HumanParams
from otgym.human.participant_task import ParticipantTask
from otgym.human.participants import N_HANDS, SimulatedParticipants


def _rows(obs, rows: np.ndarray):
    """The observation of the environments ``rows`` only (every array field sliced)."""
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
        navigator,
        retarget,
        feedback,
        bend_distance_um: float,
        tasks: Sequence[ParticipantTask],
        wall_distance_um=None,
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
                navigator,
                retarget,
                feedback,
                bend_distance_um,
                task,
                wall_distance_um,
            )
            self.groups.append((rows, people))

    def intend(self, obs, mode: np.ndarray, alpha: np.ndarray, robot_increment_um: np.ndarray, trap_robot):
        """dP_h (E, 2 hands, 2) um: each group's ``intend`` on its rows."""
        out = np.zeros((self.n_env, N_HANDS, 2))
        for rows, people in self.groups:
            out[rows] = people.intend(_rows(obs, rows), mode[rows], alpha[rows], robot_increment_um[rows], trap_robot)
        return out

    def moved(self, trap_increment_um: np.ndarray, human_weight: np.ndarray, trap_robot) -> None:
        """Each group's efference copy (``SimulatedParticipants.moved``) on its rows."""
        increments, weight = np.asarray(trap_increment_um), np.asarray(human_weight)
        for rows, people in self.groups:
            people.moved(increments[rows], weight[rows], trap_robot)

    def feel(self, obs, trap_force_pn: np.ndarray, trap_robot) -> None:
        """Each group's stylus force (``SimulatedParticipants.feel``) on its rows."""
        forces = np.asarray(trap_force_pn)
        for rows, people in self.groups:
            people.feel(_rows(obs, rows), forces[rows], trap_robot)
