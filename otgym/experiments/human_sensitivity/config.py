"""What ``otgym experiment human-sensitivity`` runs: its methods, the modes and Fig. 8
items it analyses, the design's constants, and the checks of its parameters and sizes
before any work or any file."""

from __future__ import annotations

from otgym.human.assumptions import by_label

METHODS = ("morris", "sobol")
MODES = ("manual", "shared")
OUTPUTS = ("b", "d")
"""Fig. 8's items analysed: (b) the manual / shared time ratio, (d) shared - manual success."""
DUMMY = "dummy"
"""A parameter sampled like the others that the model never reads: the noise floor."""
MORRIS_LEVELS = 4
CONFIDENCE = 0.95
RESAMPLES = 1000


def parse_parameters(text: str) -> list[str]:
    """``all`` (every assumption's label, in the table's order) or comma-separated labels
    (``Assumption.label``), each once."""
    labels = list(by_label())
    if text.strip() == "all":
        return labels
    names = [name.strip() for name in text.split(",") if name.strip()]
    unknown = [name for name in names if name not in labels]
    if unknown or not names:
        raise ValueError(
            f"unknown parameter(s) {', '.join(unknown) or '(none)'}; all or names from: {', '.join(labels)}"
        )
    if len(set(names)) != len(names):
        raise ValueError(f"--parameters names a parameter twice: {text}")
    return names


def check_arguments(method: str, size: int, participants: int, trials: int, seed: int) -> None:
    """Refuse bad sizes before any work or any file: ``size`` is Morris' trajectories or
    Sobol's base sample (a power of 2)."""
    if method not in METHODS:
        raise ValueError(f"--method must be one of {', '.join(METHODS)}, got {method!r}")
    if method == "morris" and size < 2:
        raise ValueError(f"--trajectories must be at least 2 (mu*'s interval is over them), got {size}")
    if method == "sobol" and (size < 2 or size & (size - 1)):
        raise ValueError(f"--samples must be a power of 2, at least 2 (Sobol's sequence), got {size}")
    if participants < 1:
        raise ValueError(f"--participants must be at least 1, got {participants}")
    if trials < 1:
        raise ValueError(f"--trials must be at least 1, got {trials}")
    if not 0 <= seed < 2**32:
        raise ValueError(f"--seed must lie in [0, 2**32), got {seed}")


def size_of(method: str, size: int, n_parameters: int) -> int:
    """The number of samples of a design (``design``'s n) for ``n_parameters`` (dummy included)."""
    return size * (n_parameters + (1 if method == "morris" else 2))
