"""The sweep file: which otgym command, its fixed options and a grid of options to vary.

```toml
command = "train"            # or "evaluate", "experiment shared-control", ...
[options]                    # the same for every cell
preset = "paper"
steps = 4096
[grid]                       # every combination is one cell
seed = [0, 1, 2, 3]
```

Options are spelled as on the command line without the leading dashes (``time-limit-s``
for ``--time-limit-s``); a positional argument by its name. ``out`` is the sweep's own:
each cell writes into ``DIR/<cell>/``. Every error names the file and says what is
wrong in one line (``SweepFileError``, a ``ValueError``), before anything is written.
"""

from __future__ import annotations

import dataclasses
import itertools
import re
import tomllib
from pathlib import Path

KINDS = ("int", "float", "bool", "text", "choice")
TOP_LEVEL_KEYS = ("command", "options", "grid")


class SweepFileError(ValueError):
    """A sweep file that cannot be run: its message is one line naming the file."""


@dataclasses.dataclass(frozen=True)
class OptionSpec:
    """One option of a command as the sweep file may set it.

    ``flag``: the command-line flag (``--seed``), None for a positional argument;
    ``kind``: one of ``KINDS`` (``choice``: one of ``choices``); ``negative_flag``: for
    a ``bool`` option, the flag that turns it off (``--no-x``), if it has one."""

    name: str
    flag: str | None
    kind: str
    choices: tuple[str, ...] = ()
    negative_flag: str | None = None


@dataclasses.dataclass(frozen=True)
class CommandSpec:
    """A command (``words``: ``("experiment", "shared-control")``) and its options by name."""

    words: tuple[str, ...]
    options: dict[str, OptionSpec]

    @property
    def name(self) -> str:
        return " ".join(self.words)


@dataclasses.dataclass(frozen=True)
class Cell:
    """One combination of the grid: ``name`` (its folder under the sweep's output),
    ``options`` (fixed and grid values by option name), ``grid`` (its grid values) and
    ``argv`` (the command's words and options as on the command line, without ``--out``)."""

    name: str
    options: dict
    grid: dict
    argv: tuple[str, ...]


@dataclasses.dataclass(frozen=True)
class Sweep:
    path: Path
    command: CommandSpec
    fixed: dict
    grid: dict
    cells: tuple[Cell, ...]


def _describe(kind: str, spec: OptionSpec) -> str:
    return {
        "int": "an integer",
        "float": "a number",
        "bool": "true or false",
        "text": "a string",
        "choice": "one of " + ", ".join(repr(c) for c in spec.choices),
    }[kind]


def _check_value(where: str, command: CommandSpec, spec: OptionSpec, value) -> None:
    kind = spec.kind
    valid = {
        "int": isinstance(value, int) and not isinstance(value, bool),
        "float": isinstance(value, (int, float)) and not isinstance(value, bool),
        "bool": isinstance(value, bool),
        "text": isinstance(value, str),
        "choice": isinstance(value, str) and value in spec.choices,
    }[kind]
    if not valid:
        raise SweepFileError(
            f"{where}: option '{spec.name}' of '{command.name}' takes {_describe(kind, spec)}, got {value!r}"
        )


def _arguments(spec: OptionSpec, value) -> list[str]:
    if spec.kind == "bool":
        if value:
            return [spec.flag]
        return [spec.negative_flag] if spec.negative_flag else []
    text = repr(value) if isinstance(value, float) else str(value)
    return [text] if spec.flag is None else [spec.flag, text]


def _cell_name(grid_values: dict) -> str:
    if not grid_values:
        return "cell"
    parts = []
    for name, value in grid_values.items():
        text = (
            repr(value) if isinstance(value, float) else str(value).lower() if isinstance(value, bool) else str(value)
        )
        parts.append(f"{name}-{re.sub(r'[^A-Za-z0-9.+-]', '_', text)}")
    return "_".join(parts)


def load_sweep(path, commands: dict[str, CommandSpec]) -> Sweep:
    """Read and check the sweep file ``path`` against ``commands`` (by name, e.g.
    ``"experiment shared-control"``: the commands that write an ``--out`` folder).
    Raises ``SweepFileError`` (one line) for a missing or malformed file, an unknown
    command, key or option, a value of the wrong type, an empty grid axis or two cells
    with the same folder name."""
    path = Path(path)
    where = str(path)
    if not path.is_file():
        raise SweepFileError(f"sweep file {where} does not exist")
    try:
        data = tomllib.loads(path.read_text())
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as error:
        raise SweepFileError(f"{where} is not valid TOML: {str(error).splitlines()[0]}") from None
    unknown = sorted(set(data) - set(TOP_LEVEL_KEYS))
    if unknown:
        raise SweepFileError(f"{where}: unknown key '{unknown[0]}' (a sweep file has command, [options] and [grid])")
    name = data.get("command")
    if not isinstance(name, str):
        raise SweepFileError(f'{where}: give the command to run, e.g. command = "train"')
    name = " ".join(name.split())
    if name not in commands:
        raise SweepFileError(
            f"{where}: unknown command '{name}' (commands that write an --out folder: {', '.join(sorted(commands))})"
        )
    command = commands[name]
    fixed, grid = data.get("options", {}), data.get("grid", {})
    for table, value in (("options", fixed), ("grid", grid)):
        if not isinstance(value, dict):
            raise SweepFileError(f"{where}: [{table}] must be a table of options")
    for option in itertools.chain(fixed, grid):
        if option == "out":
            raise SweepFileError(f"{where}: 'out' is set by the sweep (each cell writes into DIR/<cell>/)")
        if option not in command.options:
            known = ", ".join(sorted(command.options))
            raise SweepFileError(f"{where}: '{command.name}' has no option '{option}' (its options: {known})")
    for option, values in grid.items():
        if not isinstance(values, list) or not values:
            raise SweepFileError(f"{where}: grid option '{option}' must be a non-empty list of values")
        if option in fixed:
            raise SweepFileError(f"{where}: option '{option}' is both fixed in [options] and varied in [grid]")
        for value in values:
            _check_value(where, command, command.options[option], value)
    for option, value in fixed.items():
        _check_value(where, command, command.options[option], value)
    cells, names = [], set()
    for combination in itertools.product(*grid.values()):
        grid_values = dict(zip(grid, combination))
        options = {**fixed, **grid_values}
        cell_name = _cell_name(grid_values)
        if cell_name in names:
            raise SweepFileError(f"{where}: two cells would share the folder '{cell_name}' (a grid value repeats)")
        names.add(cell_name)
        argv = list(command.words)
        for option, value in options.items():
            argv += _arguments(command.options[option], value)
        cells.append(Cell(cell_name, options, grid_values, tuple(argv)))
    return Sweep(path, command, dict(fixed), dict(grid), tuple(cells))
