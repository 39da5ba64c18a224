"""What ``otgym experiment speed-front`` runs (``FrontConfig``), checked before any
work; light to import (no JAX), so bad input is refused at once."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from otgym.experiments.common import seeds as seed_protocol

DEFAULT_STEPS = 204_800
"""Env steps per training: the shipped policy's (``otgym.rl.dqn.DQNConfig``'s default
200,000 runs as 32 chunks of 64 environments x 100 iterations, 204,800 steps)."""

DEFAULT_PENALTIES = (100.0, 1000.0)
"""Failure penalties (magnitudes) of the default family; 100 is the paper preset's."""


@dataclasses.dataclass(frozen=True)
class FrontConfig:
    """What ``run_front`` trains and evaluates. ``penalties`` and ``time_costs`` are
    magnitudes (the reward adds -penalty on a failure, -time_cost per control step);
    ``seeds``: trainings per reward; ``steps``: env steps per training; ``episodes``:
    evaluation episodes shared by every policy; ``seed``: the run's seed (evaluation
    batches ``seed ..``, training seeds from ``training_seeds``)."""

    penalties: tuple[float, ...] = DEFAULT_PENALTIES
    time_costs: tuple[float, ...] = (0.05,)
    seeds: int = 3
    steps: int = DEFAULT_STEPS
    episodes: int = 1024
    seed: int = seed_protocol.REPORT_SEEDS["speed-front"]
    pretrained: bool = True

    def __post_init__(self):
        if not self.penalties or any(not (math.isfinite(p) and p > 0) for p in self.penalties):
            raise ValueError(f"--penalties must be positive finite numbers, got {self.penalties}")
        if not self.time_costs or any(not (math.isfinite(t) and t >= 0) for t in self.time_costs):
            raise ValueError(f"--time-costs must be non-negative finite numbers, got {self.time_costs}")
        for name, low in (("seeds", 1), ("steps", 1), ("episodes", 1)):
            if not isinstance(getattr(self, name), int) or getattr(self, name) < low:
                raise ValueError(f"--{name} must be a positive integer, got {getattr(self, name)!r}")
        if not 0 <= self.seed <= 2**32 - 1 - self.batches:
            raise ValueError(f"--seed must lie in [0, 2**32 - 1 - batches], got {self.seed}")

    @property
    def batches(self) -> int:
        return math.ceil(self.episodes / seed_protocol.EPISODES_PER_BATCH)

    @property
    def batch_size(self) -> int:
        return math.ceil(self.episodes / self.batches)

    @property
    def total_episodes(self) -> int:
        """Episodes actually run: ``batches`` x ``batch_size`` (at least ``episodes``)."""
        return self.batches * self.batch_size

    @property
    def rewards(self) -> list[tuple[float, float]]:
        return [(p, t) for p in self.penalties for t in self.time_costs]

    @property
    def trainings(self) -> int:
        return len(self.rewards) * self.seeds


def training_seeds(seed: int, count: int) -> list[int]:
    """The run's training seeds: ``count`` 32-bit draws of NumPy's SeedSequence of
    (seed, 29), disjoint in practice from the small seeds development trained on."""
    return [int(s) for s in np.random.SeedSequence([seed, 29]).generate_state(count)]


def group_name(penalty: float, time_cost: float) -> str:
    return f"penalty {penalty:g}, time {time_cost:g}"
