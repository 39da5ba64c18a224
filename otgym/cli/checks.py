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


def _node_options(device: str) -> dict[str, tuple[str, bool]]:
    """``--OPTION`` -> (driver keyword, required) of a registered device (extra ``node_options``)."""
    from otgym import registry

    spec = registry.entry("devices", device).extras.get("node_options", "")
    pairs = (item.strip().partition("=") for item in spec.split(",") if item.strip())
    return {option: (keyword.rstrip("!"), keyword.endswith("!")) for option, _, keyword in pairs}


def device_node_options(device: str, given: dict) -> dict:
    """The driver keywords of ``otgym node device``'s ``--OPTION`` values ``given``
    (None: not given) for ``device``; ValueError for an option the device does not take
    or a required one left out (the registry's ``node_options`` say which)."""
    from otgym import registry

    accepted = _node_options(device)
    for option, value in given.items():
        if value is not None and option not in accepted:
            takers = [name for name in registry.names("devices", "node") if option in _node_options(name)]
            raise ValueError(f"--{option} needs --device {' or '.join(takers)}, not --device {device}")
    for option, (_, required) in accepted.items():
        if required and given.get(option) is None:
            raise ValueError(f"--device {device} needs --{option}")
    return {keyword: given[option] for option, (keyword, _) in accepted.items() if given.get(option) is not None}


def device_node_arguments(device: str, keywords: dict) -> list[str]:
    """The ``otgym node device`` arguments that give ``device``'s driver ``keywords``
    (the inverse of ``device_node_options``)."""
    option_of = {keyword: option for option, (keyword, _) in _node_options(device).items()}
    return [text for keyword, value in keywords.items() for text in (f"--{option_of[keyword]}", str(value))]


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
