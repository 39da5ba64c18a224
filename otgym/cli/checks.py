"""The checks that ``otgym play`` and ``otgym node`` share, written once: each returns
the value (cleaned) or raises ValueError with the one line the user sees (``error:
...``, exit code 2), before any expensive work."""

from __future__ import annotations

from pathlib import Path

AUTONOMY_SOURCES = ("local", "remote")
"""Where the sim node's dP_r comes from: its own navigator, or an autonomy node."""
MAX_SEED = 2**32 // 10_000
"""Trial t meets scenario seed * 10000 + t, a 32-bit seed."""
MAX_DURATION_S = 24 * 3600


def check_mode(mode: str) -> str:
    from otgym.shared import MODES

    if mode not in MODES:
        raise ValueError(f"unknown mode {mode!r}; choose one of {', '.join(MODES)}")
    return mode


def check_participant(participant: str) -> str:
    """A participant ID (written in every trial row): non-empty, no commas; stripped."""
    if not participant.strip() or "," in participant:
        raise ValueError(f"--participant must be a non-empty ID without commas, got {participant!r}")
    return participant.strip()


def check_navigator(navigator: str) -> str:
    """A registered navigator (``otgym list navigators``)."""
    from otgym import registry

    return registry.check("navigators", navigator)


def check_autonomy_source(autonomy: str) -> str:
    if autonomy not in AUTONOMY_SOURCES:
        raise ValueError(f"--autonomy must be local or remote, got {autonomy!r}")
    return autonomy


def check_seed(seed: int) -> int:
    if not 0 <= seed < MAX_SEED:
        raise ValueError(f"--seed must lie in [0, {MAX_SEED}), got {seed}")
    return seed


def check_duration(duration_s: float | None) -> float | None:
    """Seconds of simulated time in all, or None (until stopped)."""
    if duration_s is not None and not 0 < duration_s <= MAX_DURATION_S:
        raise ValueError(f"--duration must lie in (0, {MAX_DURATION_S}] seconds, got {duration_s}")
    return duration_s


def bus_names(text: str | None, drop_empty: bool = True) -> list[str]:
    """Comma-separated device names on the bus (``otgym.bus.messages.check_name`` each);
    empty entries dropped, or (``drop_empty`` False) an error."""
    from otgym.bus import messages as msg

    names = [name.strip() for name in text.split(",")] if text else []
    return [msg.check_name(name) for name in names if name or not drop_empty]


def check_zenoh_config(path: Path | None) -> Path | None:
    if path is not None and not path.is_file():
        raise FileNotFoundError(f"no zenoh config file {path}")
    return path
