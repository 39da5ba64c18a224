"""Simulated people: otgym's one human motor model (``motor``: a hand at a stylus, in
mm; its parameters and population: ``params``) and its two task-level users, the
planner's simulated manual operator (``operator``: the manual row of Table I) and the
simulated study participants (``participants``, with ``participant_task`` and
``avoidance``: two hands driving the interactive task closed loop)."""

from otgym.human.motor import HumanMotor
from otgym.human.params import POPULATION_CV, HumanParams, sample_population

__all__ = ["POPULATION_CV", "HumanMotor", "HumanParams", "sample_population"]
