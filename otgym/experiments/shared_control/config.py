"""What ``otgym experiment shared-control`` runs (``SharedControlConfig``), checked
before any work or any file: its modes (the arbitration modes and the navigators
registered as trial modes, ``otgym.runtime.trials.trial_modes``), its sizes, the
navigators' own options and the trial it traces."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

from otgym.runtime.trials import shared_autonomies, trial_modes


def parse_modes(text: str) -> list[str]:
    modes = [m.strip() for m in text.split(",") if m.strip()]
    choices = trial_modes()
    unknown = [m for m in modes if m not in choices]
    if unknown or not modes:
        raise ValueError(f"unknown mode(s) {', '.join(unknown) or '(none)'}; choose from {', '.join(choices)}")
    if len(set(modes)) != len(modes):
        raise ValueError(f"--modes lists a mode twice: {text}")
    return modes


def check_arguments(participants: int, trials: int, seed: int) -> None:
    """Refuse bad sizes before any work or any file."""
    if participants < 1:
        raise ValueError(
            f"--participants must be at least 1 (2 or more for the repeated-measures tests), got {participants}"
        )
    if trials < 1:
        raise ValueError(f"--trials must be at least 1, got {trials}")
    if not 0 <= seed < 2**32:
        raise ValueError(f"--seed must lie in [0, 2**32), got {seed}")


@dataclasses.dataclass(frozen=True)
class SharedControlConfig:
    """One run of the study: ``participants`` simulated participants x ``trials`` trials
    per mode (trial t meets scenario ``seed * 10000 + t``) on ``chip``, each trial cut at
    ``time_limit_s``; shared control blends with navigator ``shared_autonomy``;
    ``navigator_config`` (name -> keywords of its ``for_task``) gives the navigators
    their own options; ``trace`` (participant, trial) is written tick by tick."""

    participants: int = 8
    trials: int = 8
    modes: tuple[str, ...] = ("manual", "autonomous", "shared")
    seed: int = 0
    chip: str = "default"
    time_limit_s: float = 300.0
    shared_autonomy: str = "route"
    navigator_config: Mapping[str, Mapping] = dataclasses.field(default_factory=dict)
    trace: tuple[int, int] | None = None

    def __post_init__(self):
        check_arguments(self.participants, self.trials, self.seed)
        parse_modes(",".join(self.modes))
        autonomies = shared_autonomies()
        if self.shared_autonomy not in autonomies:
            raise ValueError(f"--shared-autonomy must be one of {', '.join(autonomies)}, got {self.shared_autonomy!r}")
        if not 0 < self.time_limit_s <= 3600:
            raise ValueError(f"--time-limit-s must lie in (0, 3600], got {self.time_limit_s}")
        if self.trace is not None and not (0 <= self.trace[0] < self.participants and 0 <= self.trace[1] < self.trials):
            raise ValueError(f"--trace {self.trace[0]}:{self.trace[1]} lies beyond the run's participants or trials")
