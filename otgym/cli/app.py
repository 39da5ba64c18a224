"""The ``otgym`` command. Each sub-command lives in its own module and registers
itself here; user errors (ValueError, missing files: ``otgym.cli.errors``) end as one
clear line on stderr and exit code 2, never a traceback."""

from __future__ import annotations

import sys

import typer

from otgym.cli.errors import USER_ERRORS

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


def _register_commands() -> None:
    from otgym.cli import chip, demo, evaluate, experiment, node, plan, play, replay, study, train

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
