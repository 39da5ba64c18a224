"""Shared helpers of the sweep tests: sweeps of the stand-in command
(``fake_command``) and reading ``cells.csv``."""

from __future__ import annotations

import csv
import json
from pathlib import Path

from otgym.cluster.sweep_file import CommandSpec, OptionSpec, load_sweep

REPO = Path(__file__).resolve().parents[2]

FAKE = CommandSpec(
    ("fake",),
    {
        "value": OptionSpec("value", "--value", "int"),
        "fail-on": OptionSpec("fail-on", "--fail-on", "int"),
        "stop-if": OptionSpec("stop-if", "--stop-if", "text"),
        "calls": OptionSpec("calls", "--calls", "text"),
        "count": OptionSpec("count", "--count", "int"),
        "hold": OptionSpec("hold", "--hold", "text"),
    },
)


def toml_value(value) -> str:
    if isinstance(value, list):
        return "[" + ", ".join(toml_value(item) for item in value) + "]"
    if isinstance(value, bool):
        return "true" if value else "false"
    return json.dumps(value) if isinstance(value, str) else str(value)


def write_sweep_file(path: Path, command: str, options: dict, grid: dict) -> Path:
    lines = [f"command = {toml_value(command)}", "[options]"]
    lines += [f"{name} = {toml_value(value)}" for name, value in options.items()]
    lines += ["[grid]"] + [f"{name} = {toml_value(values)}" for name, values in grid.items()]
    path.write_text("\n".join(lines) + "\n")
    return path


def fake_sweep(tmp_path: Path, options: dict, values=(1, 2, 3)):
    path = write_sweep_file(tmp_path / "fake.toml", "fake", options, {"value": list(values)})
    return load_sweep(path, {"fake": FAKE})


def read_cells(out_dir: Path) -> dict:
    with open(out_dir / "cells.csv", newline="") as handle:
        return {row["cell"]: row for row in csv.DictReader(handle)}
