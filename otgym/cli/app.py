"""The ``otgym`` command. Each sub-command lives in its own module and registers
itself here; user errors (ValueError, missing files) end as one clear line on
stderr and exit code 2, never a traceback."""

from __future__ import annotations

import sys

import typer

app = typer.Typer(
    name="otgym",
    help="otgym: optical-tweezer microrobotics simulator, planner and learning gym.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
)


@app.callback()
def _root() -> None:
    """otgym: optical-tweezer microrobotics simulator, planner and learning gym."""


USER_ERRORS = (ValueError, FileNotFoundError, IsADirectoryError, NotADirectoryError, PermissionError)


def report_worker_error(error: Exception) -> None:
    """A process of otgym's own failed (no user error): its traceback, if any, then one
    ``error:`` line last, exit code 1."""
    lines = str(error).splitlines() or [type(error).__name__]
    if len(lines) > 1:
        print("\n".join(lines[1:]), file=sys.stderr)
    print(f"error: {lines[0]}", file=sys.stderr)
    raise SystemExit(1)


def _register_commands() -> None:
    from otgym.cli import chip, demo, evaluate, experiment, node, plan, play, replay, study, sweep, train

    demo.register(app)
    plan.register(app)
    chip.register(app)
    train.register(app)
    evaluate.register(app)
    experiment.register(app)
    play.register(app)
    study.register(app)
    replay.register(app)
    node.register(app)
    sweep.register(app)


_registered = False


def main(argv: list[str] | None = None) -> None:
    """Entry point of the ``otgym`` console script."""
    global _registered
    if not _registered:
        _register_commands()
        _registered = True
    try:
        app(args=argv, prog_name="otgym")
    except USER_ERRORS as error:
        print(f"error: {error}", file=sys.stderr)
        sys.exit(2)


if __name__ == "__main__":
    main()
