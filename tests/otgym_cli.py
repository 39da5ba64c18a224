"""Run the ``otgym`` command in this process, as a user would from a shell, and keep
what it printed: the same ``subprocess.CompletedProcess`` a child process would give,
without a fresh interpreter importing JAX and compiling again for each call. Tests
whose point is a separate process (nodes, faults) start real ones instead."""

from __future__ import annotations

import io
import subprocess
from contextlib import redirect_stderr, redirect_stdout

from otgym.cli.app import main


def run_otgym(argv) -> subprocess.CompletedProcess:
    """``otgym ARGV...``: its exit code (0 on success, 2 for bad input), stdout, stderr."""
    argv = [str(a) for a in argv]
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err):
        try:
            main(argv)
            code = 0
        except SystemExit as exit_:
            code = exit_.code if isinstance(exit_.code, int) else (0 if exit_.code is None else 1)
    return subprocess.CompletedProcess(["otgym", *argv], code, out.getvalue(), err.getvalue())


def run_cli(argv) -> int:
    """``otgym ARGV...`` in-process, its output left to pytest's capsys: the exit code
    (``main`` always exits: 0 on success, 1 for a failed run, 2 for bad input)."""
    try:
        main([str(a) for a in argv])
    except SystemExit as exit_:
        return exit_.code if isinstance(exit_.code, int) else (0 if exit_.code is None else 1)
    raise AssertionError("otgym's main returned without exiting")
