"""What ``otgym experiment shared-control`` runs, checked before any work or any file:
its modes (the arbitration modes and the navigators registered as trial modes,
``otgym.runtime.trials.trial_modes``) and its sizes."""

from __future__ import annotations

from otgym.runtime.trials import trial_modes


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
