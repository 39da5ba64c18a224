"""A stand-in for an otgym command's entry point, for the sweep engine's tests:
``main(["fake", "--value", "3", ..., "--out", DIR])`` writes DIR/value.txt (the value
squared) and behaves as told:

- ``--fail-on N``: the cell with value N prints an ``error:`` line and exits 2;
- ``--stop-if PATH``: the cell with value 2 raises KeyboardInterrupt while PATH exists
  (a sweep stopped by hand);
- ``--calls DIR``: every run leaves a file DIR/<value>-<unique> (to count runs);
- ``--count N``: no effect (an option for sweeps to differ by);
- ``--hold DIR``: writes DIR/holding-<value>@<node ip> and waits until DIR/release-<value>
  exists.
Waits end with a deadline (``DEADLINE_S``) and fail the cell, never hang a test.
"""

from __future__ import annotations

import argparse
import sys
import time
import uuid
from pathlib import Path

DEADLINE_S = 600.0
POLL_S = 0.05


def _node_ip() -> str:
    try:
        import ray

        if ray.is_initialized():
            return ray.util.get_node_ip_address()
    except ImportError:
        pass
    return "local"


def _wait_for(condition, what: str) -> None:
    deadline = time.monotonic() + DEADLINE_S
    while not condition():
        if time.monotonic() > deadline:
            raise TimeoutError(f"gave up waiting for {what}")
        time.sleep(POLL_S)  # polling a file's appearance


def main(argv: list[str]) -> None:
    parser = argparse.ArgumentParser(prog="fake")
    parser.add_argument("word")
    parser.add_argument("--value", type=int, required=True)
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--fail-on", type=int)
    parser.add_argument("--stop-if", type=Path)
    parser.add_argument("--calls", type=Path)
    parser.add_argument("--count", type=int, default=1)
    parser.add_argument("--hold", type=Path)
    args = parser.parse_args(argv)
    if args.calls:
        args.calls.mkdir(parents=True, exist_ok=True)
        (args.calls / f"{args.value}-{uuid.uuid4().hex}").touch()
    if args.value == 2 and args.stop_if and args.stop_if.exists():
        raise KeyboardInterrupt
    if args.value == args.fail_on:
        print(f"error: cell {args.value} was told to fail", file=sys.stderr)
        raise SystemExit(2)
    if args.hold:
        (args.hold / f"holding-{args.value}@{_node_ip()}").touch()
        _wait_for(lambda: (args.hold / f"release-{args.value}").exists(), "the release")
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "value.txt").write_text(f"{args.value**2}\n")
    print(f"value {args.value}: wrote {args.value**2}")
    raise SystemExit(0)
