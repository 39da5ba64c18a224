"""The safety-speed front of speed controllers on paired episodes: which policies and
constant speeds are on the front, and the paired tests behind the speed front's goals.

Every policy ran the same episodes, so each comparison is paired by episode:

- Safety: McNemar's exact test (McNemar 1947), the binomial test on the discordant
  episodes (those exactly one of the two lost) with p = 1/2; ``less_safe_p`` is the
  one-sided p that the policy loses more often than the constant speed.
- Speed: a one-sided sign test (Dixon & Mood 1946) on the episodes both completed that
  the policy's completion time is below ``1 - FASTER_BY`` of the constant speed's in
  more than half of them (ties, within ``TIE_S``, dropped): the median episode is at
  least 10 % faster.

Both from ``scipy.stats.binomtest``. A policy *covers* a constant speed when it is at
least as safe (``less_safe_p >= SIGNIFICANCE_SAFETY`` and its success rate is no lower)
and at least 10 % faster (``faster_p < SIGNIFICANCE_SPEED``). Constant speeds whose
success rate is below ``ELIGIBLE_SUCCESS`` are exempt: a policy need not cover them.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.stats import binomtest

from otgym.study.stats import wilson_interval

FASTER_BY = 0.10
"""A covering policy is at least this fraction faster than the constant speed."""

ELIGIBLE_SUCCESS = 0.90
"""Constant speeds with a success rate below this are exempt from the goal."""

SIGNIFICANCE_SAFETY = 0.05
"""McNemar's one-sided p below this shows a policy less safe."""

SIGNIFICANCE_SPEED = 0.01
"""The sign test's one-sided p must be below this to call a policy 10 % faster."""

TIE_S = 1e-6


@dataclasses.dataclass(frozen=True)
class Outcomes:
    """One policy's or constant speed's results on the shared episodes: ``success`` (N,)
    bool, ``time_s`` (N,) episode length in s; ``speed_um_s`` for a constant speed, None
    for a policy; ``group`` labels a family member (its reward) or ``constant``."""

    name: str
    success: np.ndarray
    time_s: np.ndarray
    speed_um_s: float | None = None
    group: str = "constant"

    @property
    def is_constant(self) -> bool:
        return self.speed_um_s is not None

    @property
    def successes(self) -> int:
        return int(np.sum(self.success))

    @property
    def episodes(self) -> int:
        return int(np.size(self.success))

    @property
    def success_rate(self) -> float:
        return self.successes / self.episodes

    @property
    def atct_s(self) -> float | None:
        """Mean completion time of the completed episodes (None if none completed)."""
        return float(np.mean(self.time_s[self.success])) if self.successes else None

    def interval(self) -> tuple[float, float]:
        return wilson_interval(self.successes, self.episodes)


@dataclasses.dataclass(frozen=True)
class Comparison:
    """A policy against a constant speed on the same episodes."""

    policy: str
    constant: str
    policy_only_lost: int
    constant_only_lost: int
    less_safe_p: float
    faster_episodes: int  # both completed, policy time < (1 - FASTER_BY) x constant time
    not_faster_episodes: int  # both completed, policy time > (1 - FASTER_BY) x constant time
    faster_p: float
    time_ratio: float | None  # policy ATCT / constant ATCT
    success_not_lower: bool

    @property
    def as_safe(self) -> bool:
        return self.success_not_lower and self.less_safe_p >= SIGNIFICANCE_SAFETY

    @property
    def faster(self) -> bool:
        return self.faster_p < SIGNIFICANCE_SPEED

    @property
    def covers(self) -> bool:
        return self.as_safe and self.faster


def compare(policy: Outcomes, constant: Outcomes) -> Comparison:
    """McNemar's exact test (one-sided: the policy loses more often) and the sign test
    of a 10 % shorter completion time, paired by episode."""
    if policy.episodes != constant.episodes:
        raise ValueError(f"{policy.name} and {constant.name} ran different numbers of episodes")
    policy_only = int(np.sum(~policy.success & constant.success))
    constant_only = int(np.sum(policy.success & ~constant.success))
    discordant = policy_only + constant_only
    less_safe_p = binomtest(policy_only, discordant, 0.5, alternative="greater").pvalue if discordant else 1.0
    both = policy.success & constant.success
    bound = (1.0 - FASTER_BY) * constant.time_s
    faster = int(np.sum(both & (policy.time_s < bound - TIE_S)))
    not_faster = int(np.sum(both & (policy.time_s > bound + TIE_S)))
    faster_p = binomtest(faster, faster + not_faster, 0.5, alternative="greater").pvalue if faster + not_faster else 1.0
    ratio = None if policy.atct_s is None or constant.atct_s is None else policy.atct_s / constant.atct_s
    return Comparison(
        policy.name,
        constant.name,
        policy_only,
        constant_only,
        float(less_safe_p),
        faster,
        not_faster,
        float(faster_p),
        ratio,
        policy.success_rate >= constant.success_rate,
    )


def pareto_front(outcomes: list[Outcomes]) -> list[str]:
    """Names of the non-dominated entries (higher success rate and shorter ATCT are
    better; an entry none completed is dominated by any that completed one), in order of
    ATCT. B dominates A when it is no worse in both and better in one."""

    def key(o: Outcomes):
        return o.success_rate, -(o.atct_s if o.atct_s is not None else np.inf)

    def dominates(b, a):
        kb, ka = key(b), key(a)
        return kb[0] >= ka[0] and kb[1] >= ka[1] and kb != ka

    front = [a for a in outcomes if not any(dominates(b, a) for b in outcomes if b is not a)]
    return [o.name for o in sorted(front, key=lambda o: -key(o)[1])]


@dataclasses.dataclass(frozen=True)
class Goals:
    """The speed front's goals, measured."""

    eligible: list[str]  # constant speeds with success >= ELIGIBLE_SUCCESS
    covered_by: dict[str, list[str]]  # eligible constant -> the policies that cover it
    exempt: list[str]
    reference: str  # the constant the shipped policy and the training seeds are held against (G3)
    pretrained_covers_reference: bool | None  # None: no pretrained policy ran
    seeds_covering_reference: dict[str, tuple[int, int]]  # family group -> (covering, trained)

    @property
    def every_eligible_covered(self) -> bool:
        return all(self.covered_by[name] for name in self.eligible)


def measure_goals(
    outcomes: list[Outcomes], comparisons: dict[tuple[str, str], Comparison], reference: str = "G3"
) -> Goals:
    """Which eligible constant speeds some policy covers, whether ``pretrained`` covers
    ``reference``, and per family group how many of its trained members do."""
    constants = [o for o in outcomes if o.is_constant]
    policies = [o for o in outcomes if not o.is_constant]
    eligible = [c.name for c in constants if c.success_rate >= ELIGIBLE_SUCCESS]
    exempt = [c.name for c in constants if c.name not in eligible]
    covered = {c: [p.name for p in policies if comparisons[(p.name, c)].covers] for c in eligible}
    names = {p.name for p in policies}
    has_reference = any(c.name == reference for c in constants)
    pretrained = comparisons[("pretrained", reference)].covers if "pretrained" in names and has_reference else None
    groups: dict[str, tuple[int, int]] = {}
    for p in policies:
        if p.group in ("constant", "pretrained") or not has_reference:
            continue
        done, total = groups.get(p.group, (0, 0))
        groups[p.group] = (done + int(comparisons[(p.name, reference)].covers), total + 1)
    return Goals(eligible, covered, exempt, reference, pretrained, groups)


def compare_all(outcomes: list[Outcomes]) -> dict[tuple[str, str], Comparison]:
    """Every policy against every constant speed: {(policy, constant): Comparison}."""
    constants = [o for o in outcomes if o.is_constant]
    return {(p.name, c.name): compare(p, c) for p in outcomes if not p.is_constant for c in constants}
