"""A study protocol for real participants (``otgym study run PROTOCOL.toml``): what each
participant does, in which order, read from a TOML file (template:
docs/study-protocol.toml) and checked before anything starts.

The file's tables and keys (every key not named here is refused, so a typo cannot pass
silently)::

    [study]            name, instructions (text shown before the practice), chip,
                       device, navigator (the autonomy of shared and autonomous mode),
                       seed_base, trial_time_limit_s (optional: the task's own limit)
    [practice]         trials (0: none), mode
    [modes]            names (the modes compared, each once per participant),
                       trials_per_mode
    [questionnaires]   after_each_mode (true: NASA-TLX and UEQ-S after each mode's
                       block), weighted_tlx (the 15 pairwise TLX comparisons too)

The order of the modes is counterbalanced by a Latin square over participant numbers
(``williams_square``, ``mode_order``). Which mode names, devices and navigators exist is
the caller's and the registry's to say: ``load_protocol`` gets the runtime's modes as
``known_modes`` and reads devices (tag ``play``), navigators and chips from
``otgym.registry``.

Trials: the practice trials come first, then each mode's block in the participant's
order. Trial numbers run from 1 over the whole session (practice included), and trial
t meets scenario ``seed_base * 10000 + t`` (``otgym.runtime.session``'s numbering): every
participant meets the same scenarios in the same positions, and the Latin square
spreads the modes over those positions."""

from __future__ import annotations

import dataclasses
import hashlib
import tomllib
from pathlib import Path

from otgym import registry

MAX_SEED_BASE = 2**32 // 10_000
"""Trial t meets scenario seed_base * 10000 + t, a 32-bit seed."""
MAX_TRIALS = 1000
"""At most this many trials in one block (a guard against a typo such as 800 for 8)."""
WINDOW_NAVIGATORS_TAG = "shared"
"""Navigators the study may name: those shared control can blend with (tag ``shared``)."""

HOLD_KEYS = ("up", "down", "left", "right")
"""Keys a script may hold down: the keyboard device's arrows (``otgym.teleop.pygame_devices``)."""

_SCHEMA = {
    "study": {
        "name": str,
        "instructions": str,
        "chip": str,
        "device": str,
        "navigator": str,
        "seed_base": int,
        "trial_time_limit_s": float,
    },
    "practice": {"trials": int, "mode": str},
    "modes": {"names": list, "trials_per_mode": int},
    "questionnaires": {"after_each_mode": bool, "weighted_tlx": bool},
}
_REQUIRED = {("modes", "names"), ("modes", "trials_per_mode"), ("study", "seed_base")}


@dataclasses.dataclass(frozen=True)
class StudyProtocol:
    """A checked protocol; ``text`` is the file as read and ``sha256`` its hash (what a
    participant's folder records, and what a resumed session must match)."""

    modes: tuple[str, ...]
    trials_per_mode: int
    seed_base: int
    name: str = "otgym study"
    instructions: str = ""
    chip: str = "default"
    device: str = "keyboard"
    navigator: str = "route"
    trial_time_limit_s: float | None = None
    practice_trials: int = 0
    practice_mode: str = ""
    questionnaires: bool = True
    weighted_tlx: bool = False
    text: str = ""
    sha256: str = ""


@dataclasses.dataclass(frozen=True)
class Slot:
    """One trial of a participant's plan: ``trial`` (from 1, over the whole session),
    ``mode``, ``block`` (``practice`` or the mode's name), ``position`` (0 for the
    practice, else the block's place 1..n in this participant's order) and
    ``last_in_block``."""

    trial: int
    mode: str
    block: str
    position: int
    last_in_block: bool

    @property
    def practice(self) -> bool:
        return self.position == 0


def _where(path: Path, table: str, key: str | None = None) -> str:
    return f"{path}: [{table}]" + (f" {key}" if key else "")


def _typed(path: Path, table: str, key: str, value, kind):
    if kind is float and isinstance(value, int) and not isinstance(value, bool):
        value = float(value)
    if kind is int and isinstance(value, bool) or not isinstance(value, kind):
        raise ValueError(f"{_where(path, table, key)} must be {kind.__name__}, got {value!r}")
    return value


def load_protocol(path, known_modes) -> StudyProtocol:
    """The protocol at ``path``, checked: FileNotFoundError, or ValueError with one line
    naming the file and the first problem (not TOML, an unknown table or key, a wrong
    type, a missing key, an unknown mode, device, navigator or chip, a number out of
    range). ``known_modes``: the modes the runtime's session runs."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no protocol file {path}")
    raw = path.read_bytes()
    try:
        data = tomllib.loads(raw.decode("utf-8"))
    except (UnicodeDecodeError, tomllib.TOMLDecodeError) as error:
        raise ValueError(f"{path} is not a TOML protocol: {str(error).splitlines()[0]}") from None
    values: dict = {}
    for table, content in data.items():
        if table not in _SCHEMA:
            raise ValueError(f"{path}: unknown table [{table}]; the tables are {', '.join(_SCHEMA)}")
        if not isinstance(content, dict):
            raise ValueError(f"{path}: {table} must be a table ([{table}])")
        for key, value in content.items():
            if key not in _SCHEMA[table]:
                raise ValueError(f"{_where(path, table)}: unknown key {key!r}; known: {', '.join(_SCHEMA[table])}")
            values[(table, key)] = _typed(path, table, key, value, _SCHEMA[table][key])
    for table, key in sorted(_REQUIRED):
        if (table, key) not in values:
            raise ValueError(f"{_where(path, table, key)} is missing")
    known_modes = tuple(known_modes)
    modes = values[("modes", "names")]
    if not modes or not all(isinstance(m, str) for m in modes):
        raise ValueError(f"{_where(path, 'modes', 'names')} must be a non-empty list of mode names")
    for mode in modes:
        if mode not in known_modes:
            raise ValueError(
                f"{_where(path, 'modes', 'names')}: unknown mode {mode!r}; choose from {', '.join(known_modes)}"
            )
    if len(set(modes)) != len(modes):
        raise ValueError(f"{_where(path, 'modes', 'names')} names a mode twice: {modes}")
    trials = values[("modes", "trials_per_mode")]
    practice = values.get(("practice", "trials"), 0)
    for key, number, low in (("modes", trials, 1), ("practice", practice, 0)):
        if not low <= number <= MAX_TRIALS:
            name = "trials_per_mode" if key == "modes" else "trials"
            raise ValueError(f"{_where(path, key, name)} must lie in [{low}, {MAX_TRIALS}], got {number}")
    practice_mode = values.get(("practice", "mode"), modes[0] if practice else "")
    if practice and practice_mode not in known_modes:
        raise ValueError(
            f"{_where(path, 'practice', 'mode')}: unknown mode {practice_mode!r}; choose from {', '.join(known_modes)}"
        )
    seed = values[("study", "seed_base")]
    if not 0 <= seed < MAX_SEED_BASE:
        raise ValueError(f"{_where(path, 'study', 'seed_base')} must lie in [0, {MAX_SEED_BASE}), got {seed}")
    limit = values.get(("study", "trial_time_limit_s"))
    if limit is not None and not 0 < limit <= 3600:
        raise ValueError(f"{_where(path, 'study', 'trial_time_limit_s')} must lie in (0, 3600] seconds, got {limit}")
    device = values.get(("study", "device"), StudyProtocol.device)
    navigator = values.get(("study", "navigator"), StudyProtocol.navigator)
    chip = values.get(("study", "chip"), StudyProtocol.chip)
    try:
        registry.check("devices", device, "play")
        registry.check("navigators", navigator, WINDOW_NAVIGATORS_TAG)
    except ValueError as error:
        raise ValueError(f"{path}: [study] {error}") from None
    if chip not in registry.names("chips") and not Path(chip).is_file():
        raise ValueError(f"{path}: [study] unknown chip {chip!r}; choose one of {', '.join(registry.names('chips'))}")
    return StudyProtocol(
        modes=tuple(modes),
        trials_per_mode=trials,
        seed_base=seed,
        name=values.get(("study", "name"), StudyProtocol.name),
        instructions=values.get(("study", "instructions"), ""),
        chip=chip,
        device=device,
        navigator=navigator,
        trial_time_limit_s=limit,
        practice_trials=practice,
        practice_mode=practice_mode,
        questionnaires=values.get(("questionnaires", "after_each_mode"), True),
        weighted_tlx=values.get(("questionnaires", "weighted_tlx"), False),
        text=raw.decode("utf-8"),
        sha256=hashlib.sha256(raw).hexdigest(),
    )


def williams_square(n: int) -> list[list[int]]:
    """A Williams design over ``n`` conditions (Williams 1949, "Experimental designs
    balanced for the estimation of residual effects of treatments"): rows are orders in
    which each condition takes each position equally often and follows each other
    condition equally often. For even ``n``, ``n`` rows (the first row 0, 1, n-1, 2,
    n-2, ..., each next row shifted by 1 mod n); for odd ``n`` one square cannot balance
    the first-order carry-over, so its ``2n`` rows are that square and its rows
    reversed."""
    if n < 1:
        raise ValueError(f"a Latin square needs at least one condition, got {n}")
    first, low, high = [0], 1, n - 1
    while len(first) < n:
        first.append(low)
        low += 1
        if len(first) < n:
            first.append(high)
            high -= 1
    rows = [[(value + shift) % n for value in first] for shift in range(n)]
    return rows if n % 2 == 0 else rows + [row[::-1] for row in rows]


def mode_order(protocol: StudyProtocol, number: int) -> tuple[str, ...]:
    """The modes in participant ``number``'s order (from 1): row ``(number - 1) mod
    rows`` of ``williams_square``; a study whose participant count is a multiple of the
    rows (n for an even number of modes, 2n for an odd) is fully counterbalanced."""
    if number < 1:
        raise ValueError(f"participant numbers start at 1, got {number}")
    rows = williams_square(len(protocol.modes))
    return tuple(protocol.modes[i] for i in rows[(number - 1) % len(rows)])


def trial_plan(protocol: StudyProtocol, order) -> list[Slot]:
    """Every trial of a participant whose modes come in ``order``: the practice, then
    each mode's block; trial numbers from 1 over all of them."""
    slots: list[Slot] = []
    blocks = [("practice", protocol.practice_mode, 0, protocol.practice_trials)] + [
        (mode, mode, position, protocol.trials_per_mode) for position, mode in enumerate(order, start=1)
    ]
    for block, mode, position, count in blocks:
        for index in range(count):
            slots.append(Slot(len(slots) + 1, mode, block, position, index == count - 1))
    return slots


def load_answer_script(path) -> dict:
    """Scripted questionnaire answers for a dry run or a test (``otgym study run
    --script``): a TOML file with ``nasa_tlx`` (six ratings, 0-100 in steps of 5, in the
    form's order), ``ueq_s`` (eight raw values 1-7) and optionally ``tlx_pairs`` (15
    choices, 1 or 2, for a weighted TLX; default all 1), and optionally ``hold_keys``
    (arrow keys, of ``HOLD_KEYS``, held down for the whole session: the keyboard
    device's scripted driving). The window's form is answered by these key presses, so
    the answers take the same path as a person's. One-line FileNotFoundError or
    ValueError."""
    from otgym.study.questionnaires import TLX_PAIR_COUNT, TLX_STEP, TLX_SUBSCALES, UEQ_ITEM_NAMES

    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no answer script {path}")
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, tomllib.TOMLDecodeError) as error:
        raise ValueError(f"{path} is not a TOML answer script: {str(error).splitlines()[0]}") from None
    expected = {
        "nasa_tlx": (len(TLX_SUBSCALES), 0, 100, TLX_STEP),
        "ueq_s": (len(UEQ_ITEM_NAMES), 1, 7, 1),
        "tlx_pairs": (TLX_PAIR_COUNT, 1, 2, 1),
    }
    unknown = sorted(set(data) - set(expected) - {"hold_keys"})
    if unknown:
        raise ValueError(f"{path}: unknown key(s) {unknown}; known: {', '.join(expected)}")
    data.setdefault("tlx_pairs", [1] * TLX_PAIR_COUNT)
    for key, (count, low, high, step) in expected.items():
        values = data.get(key)
        if (
            not isinstance(values, list)
            or len(values) != count
            or not all(type(v) is int and low <= v <= high and v % step == 0 for v in values)
        ):
            raise ValueError(f"{path}: {key} must be {count} whole numbers in [{low}, {high}] (steps of {step})")
    held = data.setdefault("hold_keys", [])
    if not isinstance(held, list) or not all(key in HOLD_KEYS for key in held):
        raise ValueError(f"{path}: hold_keys must be a list of {', '.join(HOLD_KEYS)}, got {held!r}")
    return data
