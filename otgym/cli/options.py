"""Options that several commands share, declared once with their ranges and kinds.

Every option of every command says what a good value is, so that typer refuses a bad one
while it parses the command line, before the command starts: numbers carry ``min`` and
``max`` (NaN and infinities are outside every range), paths say whether they are an
input (``exists``) and a file or a folder, and text options name their kind with a
metavar (``CHIP``, ``NAME``, ``POLICY``, ``X,Y``, ``NUMBERS``, ``MODES``, ``ENDPOINT``,
``NAMES``, or ``TEXT`` for free text) and check it in a callback. ``tests/cli/
test_bad_input.py`` reads these declarations from the app and tries bad values of each.
"""

from __future__ import annotations

from pathlib import Path

import typer

SEED_MAX = 2**32 - 1
"""The largest seed: JAX's ``PRNGKey`` keeps the low 32 bits of a larger one, so seeds
2**32 and 0 would draw the same numbers."""


def seed(default: int, help: str) -> typer.Option:
    """``--seed``: an integer in [0, 2**32 - 1]."""
    return typer.Option(default, "--seed", min=0, max=SEED_MAX, help=f"{help} [0, 2**32 - 1].")


def time_limit_s(default: float = 300.0, help: str = "A trial not done by then ends unfinished, in s.") -> typer.Option:
    """``--time-limit-s``: a trial's time limit in [1, 3600] s."""
    return typer.Option(default, "--time-limit-s", min=1.0, max=3600.0, help=help)


def out_dir(default: Path | None, help: str) -> typer.Option:
    """``--out``: a folder (made if missing; an existing file is refused)."""
    return typer.Option(default, "--out", file_okay=False, dir_okay=True, metavar="DIR", help=help)


def check_chip(value: str | None) -> str | None:
    """A typer callback: ``value`` a shipped chip's name or a readable chip PNG."""
    if value is None:
        return value
    from otgym.sim.chip import check_chip_source

    try:
        check_chip_source(value)
    except (ValueError, OSError) as error:
        raise typer.BadParameter(str(error)) from None
    return value


def chip(default: str | None, help: str = "Shipped chip name (e.g. default) or a PNG file.") -> typer.Option:
    """``--chip``: a shipped chip's name or a readable PNG."""
    return typer.Option(default, "--chip", metavar="CHIP", callback=check_chip, help=help)


def chip_argument(default: str, help: str = "Shipped chip name (e.g. default) or a PNG file.") -> typer.Argument:
    return typer.Argument(default, metavar="CHIP", callback=check_chip, help=help)


def check_choice(option: str, choices: tuple[str, ...]):
    """A typer callback refusing a value outside ``choices``, naming them."""

    def check(value: str | None) -> str | None:
        if value is not None and value not in choices:
            raise typer.BadParameter(f"{value!r} is not one of {', '.join(choices)}", param_hint=option)
        return value

    return check


def name(default: str | None, option: str, choices: tuple[str, ...], help: str) -> typer.Option:
    """An option whose value is one of a closed set of names."""
    return typer.Option(
        default,
        option,
        metavar="NAME",
        callback=check_choice(option, choices),
        help=f"{help} One of: {', '.join(choices)}.",
    )


def registered(default: str | None, option: str, kind: str, tag: str | None, help: str) -> typer.Option:
    """An option whose value is a registered part of ``kind`` (``otgym.registry``),
    with ``tag`` if given; checked against the registry when the command runs, so parts
    that installed packages add are accepted too."""
    from otgym import registry

    def check(value: str | None) -> str | None:
        if value is not None:
            try:
                registry.check(kind, value, tag)
            except ValueError as error:
                raise typer.BadParameter(str(error), param_hint=option) from None
        return value

    return typer.Option(
        default,
        option,
        metavar="NAME",
        callback=check,
        help=f"{help} One of: {', '.join(registry.names(kind, tag))} (otgym list {kind}).",
    )


def parse_point(option: str, text: str) -> tuple[float, float]:
    """``"X,Y"`` -> (x, y), two finite numbers; a ValueError naming the option otherwise."""
    import math

    parts = text.split(",")
    try:
        if len(parts) != 2:
            raise ValueError
        x, y = float(parts[0]), float(parts[1])
        if not (math.isfinite(x) and math.isfinite(y)):
            raise ValueError
        return x, y
    except ValueError:
        raise ValueError(f"{option} must be two finite numbers X,Y in um, got {text!r}") from None


def point(default: str | None, option: str, help: str) -> typer.Option:
    """An ``X,Y`` option in um, checked while parsing."""

    def check(value: str | None) -> str | None:
        if value is not None:
            try:
                parse_point(option, value)
            except ValueError as error:
                raise typer.BadParameter(str(error)) from None
        return value

    return typer.Option(default, option, metavar="X,Y", callback=check, help=help)


def _check_policy(value: str | None) -> str | None:
    if value is None:
        return value
    from otgym.rl.policy import policy_meta, resolve_policy

    try:
        policy_meta(resolve_policy(value))
    except (ValueError, OSError) as error:
        raise typer.BadParameter(str(error)) from None
    return value


def policy(
    default: str | None, help: str = "Policy file (policy.npz from otgym train) or 'pretrained'."
) -> typer.Option:
    """``--policy``: ``pretrained`` or a readable policy file."""
    return typer.Option(default, "--policy", metavar="POLICY", callback=_check_policy, help=help)


def _as_bad_parameter(check):
    """A typer callback from a check that raises ValueError (or OSError)."""

    def callback(value):
        if value is None:
            return value
        try:
            result = check(value)
        except (ValueError, OSError) as error:
            raise typer.BadParameter(str(error)) from None
        return value if result is None else result

    return callback


IP_PROTOCOLS = ("tcp", "udp", "tls", "quic", "ws")
"""zenoh's protocols whose address is HOST:PORT (zenoh's endpoint syntax:
PROTOCOL/ADDRESS[?METADATA][#CONFIG])."""


def _endpoints(values: list[str]) -> list[str]:
    """Each value a zenoh endpoint; for an IP protocol, a host and a port in [0, 65535]
    (0: any free port), which zenoh itself would refuse only once the session opens."""
    import re

    for value in values:
        if not re.fullmatch(r"[a-z][a-z0-9-]*/\S+", value):
            raise ValueError(f"{value!r} is not a zenoh endpoint (PROTOCOL/ADDRESS, e.g. tcp/127.0.0.1:7447)")
        protocol, address = value.split("/", 1)
        if protocol not in IP_PROTOCOLS:
            continue
        address = re.split(r"[?#]", address, maxsplit=1)[0]
        host, colon, port = address.rpartition(":")
        if not colon or not host or not port.isdigit():
            raise ValueError(f"{value!r}: a {protocol} endpoint needs HOST:PORT (e.g. {protocol}/127.0.0.1:7447)")
        if int(port) > 65535:
            raise ValueError(f"{value!r}: the port must lie in [0, 65535], not {port}")
    return values


def _namespace(value: str) -> str:
    from otgym.bus import ros_graph

    return ros_graph.check_namespace(value)


def _topic(value: str) -> str:
    from otgym.bus import ros_graph

    return ros_graph.check_topic_name(value)


def _host(value: str) -> str:
    import ipaddress
    import re

    try:
        ipaddress.ip_address(value)
    except ValueError:
        if not re.fullmatch(r"[A-Za-z0-9]([A-Za-z0-9.-]*[A-Za-z0-9])?", value):
            raise ValueError(f"{value!r} is neither an IP address nor a host name") from None
    return value


def _bus_names(value: str) -> str:
    from otgym.cli import checks

    checks.bus_names(value, drop_empty=False) if value else None
    return value


check_endpoints = _as_bad_parameter(_endpoints)
check_namespace = _as_bad_parameter(_namespace)
check_topic = _as_bad_parameter(_topic)
check_host = _as_bad_parameter(_host)
check_bus_names = _as_bad_parameter(_bus_names)


def _ray_address(value: str) -> str:
    """``auto`` or a Ray head's HOST:PORT (port 1-65535)."""
    if value == "auto":
        return value
    host, colon, port = value.rpartition(":")
    if not colon or not port.isdigit() or not 0 < int(port) < 65536:
        raise ValueError(f"{value!r} is neither auto nor a Ray head's HOST:PORT")
    _host(host)
    return value


check_ray_address = _as_bad_parameter(_ray_address)


def mode(default: str) -> typer.Option:
    """``--mode``: manual, shared or autonomous."""
    from otgym.shared import MODES

    return name(default, "--mode", MODES, "The control mode (keys 1/2/3 switch in the window).")


def navigator(default: str) -> typer.Option:
    """``--navigator``: the autonomy's navigator."""
    return registered(default, "--navigator", "navigators", None, "The autonomy's navigator.")


def participant(default: str) -> typer.Option:
    """``--participant``: a participant ID (free text, no commas)."""
    from otgym.cli import checks

    return typer.Option(
        default,
        "--participant",
        metavar="TEXT",
        callback=_as_bad_parameter(checks.check_participant),
        help="Participant ID written with every trial (no commas).",
    )


def trial_seed(default: int) -> typer.Option:
    """``--seed`` of the interactive task: trial t meets scenario seed * 10000 + t."""
    from otgym.cli import checks

    return typer.Option(
        default,
        "--seed",
        min=0,
        max=checks.MAX_SEED - 1,
        help=f"Trial t meets scenario seed * 10000 + t, [0, {checks.MAX_SEED - 1}].",
    )


def duration() -> typer.Option:
    """``--duration``: seconds of simulated time in all (default: until stopped)."""
    from otgym.cli import checks

    return typer.Option(
        None,
        "--duration",
        min=0.02,
        max=float(checks.MAX_DURATION_S),
        help="Seconds of simulated time in all (default: until stopped).",
    )


def parse_numbers(option: str, text: str, allow_zero: bool = False) -> tuple[float, ...]:
    """``"100,1000"`` -> (100.0, 1000.0): at least one finite number, each positive (or
    zero with ``allow_zero``), no repeats; a ValueError naming the option otherwise."""
    import math

    try:
        values = tuple(float(v) for v in text.split(",") if v.strip())
    except ValueError:
        values = ()
    low_ok = (lambda v: v >= 0) if allow_zero else (lambda v: v > 0)  # noqa: E731
    if not values or not all(math.isfinite(v) and low_ok(v) for v in values) or len(set(values)) != len(values):
        kind = "non-negative" if allow_zero else "positive"
        raise ValueError(f"{option} must be distinct comma-separated {kind} numbers, got {text!r}")
    return values


def numbers(default: str, option: str, help: str, allow_zero: bool = False) -> typer.Option:
    """A comma-separated list of numbers (metavar ``NUMBERS``), checked while parsing."""

    def check(value: str) -> str:
        try:
            parse_numbers(option, value, allow_zero)
        except ValueError as error:
            raise typer.BadParameter(str(error), param_hint=option) from None
        return value

    return typer.Option(default, option, metavar="NUMBERS", callback=check, help=help)
