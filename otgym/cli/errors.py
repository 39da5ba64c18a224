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


def bad_parameter_line(error: Exception) -> str:
    """The one line that tells a user what was wrong with a value on the command line.

    The command-line library's own wording names the validator, not the option's range
    ("Input should be less than or equal to 65535"); a value outside a declared range
    is said with both ends of the range and the value given
    ("--port must lie in [0, 65535], not 70000"), a choice with the choices
    ("--mode must be one of manual, shared, autonomous, not 'x'"), a missing path with the
    path; any other message is the check's own, after the option's name."""
    message = error.format_message() if hasattr(error, "format_message") else str(error)
    param = getattr(error, "param", None)
    if param is None or not getattr(param, "opts", None):
        return message
    name = max(param.opts, key=len)
    if getattr(param, "param_type_name", "") == "argument":
        name = getattr(param, "metavar", None) or name.upper()
    cause = error.__cause__
    if cause is not None and hasattr(cause, "errors"):
        info = param.get_runtime_param().parameter_info if hasattr(param, "get_runtime_param") else None
        low, high = (getattr(info, "min", None), getattr(info, "max", None)) if info else (None, None)
        details = cause.errors()
        given = details[0].get("input") if details else None
        if low is not None or high is not None:
            if low is not None and high is not None:
                bound = f"must lie in [{low}, {high}]"
            elif low is not None:
                bound = f"must be at least {low}"
            else:
                bound = f"must be at most {high}"
            return f"{name} {bound}, not {given}"
        if given is not None:
            return f"{name}: {given!r} is not valid ({details[0].get('msg', 'invalid')})"
    raw = getattr(error, "message", "")
    if " is not one of " in raw:
        given, choices = raw.split(" is not one of ", 1)
        return f"{name} must be one of {choices}, not {given}"
    for kind, plain in ((" is a file.", "is a file, not a folder"), (" is a directory.", "is a folder, not a file")):
        if raw.endswith(kind) and "'" in raw:
            path = raw.split("'", 1)[1].rsplit("'", 1)[0]
            return f"{name} {path} {plain}"
    if raw.endswith(" does not exist.") and "'" in raw:
        path = raw.split("'", 1)[1].rsplit("'", 1)[0]
        is_argument = getattr(param, "param_type_name", "") == "argument"
        return f"{path} does not exist" if is_argument else f"{name} {path} does not exist"
    if raw and not raw.startswith(name):
        return f"{name}: {raw}"
    return message
