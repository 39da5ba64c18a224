"""How the ``otgym`` command ends on an error: a user's mistake is one ``error:`` line
and exit code 2 (``main`` catches ``USER_ERRORS``); a process of otgym's own that
failed is its traceback, then one ``error:`` line, exit code 1
(``report_worker_error``). Its own module, so that the commands use it without
importing the app that registers them."""

from __future__ import annotations

import sys

USER_ERRORS = (ValueError, FileNotFoundError, IsADirectoryError, NotADirectoryError, PermissionError)


def report_worker_error(error: Exception) -> None:
    """A process of otgym's own failed (no user error): its traceback, if any, then one
    ``error:`` line last, exit code 1."""
    lines = str(error).splitlines() or [type(error).__name__]
    if len(lines) > 1:
        print("\n".join(lines[1:]), file=sys.stderr)
    print(f"error: {lines[0]}", file=sys.stderr)
    raise SystemExit(1)
