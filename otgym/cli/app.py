"""The ``otgym`` command. Each sub-command lives in its own module and registers
itself here; user errors (ValueError, missing files) end as one clear line on
stderr and exit code 2, never a traceback."""

from __future__ import annotations

import sys

import typer
from typer import Abort

try:  # typer 0.2x carries its own copy of click
    from typer._click.exceptions import BadParameter, ClickException, NoArgsIsHelpError
except ImportError:  # older typer runs on click itself
    from click.exceptions import BadParameter, ClickException, NoArgsIsHelpError

from otgym.cli.errors import USER_ERRORS, bad_parameter_line

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


def register_commands() -> None:
    """Add every sub-command to ``app`` (once; later calls do nothing)."""
    global _registered
    if _registered:
        return
    from otgym.cli import (
        chip,
        demo,
        evaluate,
        experiment,
        list_parts,
        node,
        plan,
        play,
        replay,
        study,
        sweep,
        train,
    )

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
    list_parts.register(app)
    sweep.register(app, entry_point=main)
    _registered = True


_registered = False
_built: list = []  # the click command built from ``app``, once per process


def command():
    """The click command of ``app`` with every sub-command, built once per process:
    typer derives it from the commands' signatures, which takes longer than checking
    a command line, so a process that runs several command lines (a test, a sweep)
    builds it only once."""
    if not _built:
        register_commands()
        _built.append(typer.main.get_command(app))
    return _built[0]


def _fail(message: str) -> None:
    print(f"error: {message}", file=sys.stderr)
    sys.exit(2)


def main(argv: list[str] | None = None) -> None:
    """Entry point of the ``otgym`` console script: runs the command and exits with its
    code (0 on success). A bad command line (an unknown option, a value outside its
    range, a missing file) or a user error raised by the command is one ``error:`` line
    on stderr and exit code 2."""
    cli = command()
    _use_persistent_jax_cache()
    try:
        code = cli.main(args=argv, prog_name="otgym", standalone_mode=False)
    except NoArgsIsHelpError as error:  # ``otgym`` or ``otgym chip`` alone: the help
        print(error.format_message())
        sys.exit(0)
    except BadParameter as error:
        _fail(bad_parameter_line(error))
    except ClickException as error:
        _fail(error.format_message())
    except Abort:
        _fail("aborted")
    except USER_ERRORS as error:
        _fail(str(error))
    sys.exit(code if isinstance(code, int) else 0)


def _use_persistent_jax_cache() -> None:
    """Every command, and every process it starts, keeps compiled XLA programs in JAX's
    persistent cache (``$JAX_COMPILATION_CACHE_DIR`` when set, else the ``jax`` folder
    of otgym's cache, ``$OTGYM_CACHE_DIR`` or ``~/.cache/otgym``): a second run, or a
    node started again, skips most of its compiling. Set before JAX is imported, so
    it reaches child processes through the environment."""
    import os

    if "JAX_COMPILATION_CACHE_DIR" not in os.environ:
        from otgym.sim.cache_dir import cache_dir

        os.environ["JAX_COMPILATION_CACHE_DIR"] = str(cache_dir() / "jax")
    os.environ.setdefault("JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS", "0")
    if "jax" in sys.modules:  # imported already (a test, an embedding program): tell JAX directly
        import jax

        if not jax.config.jax_compilation_cache_dir:
            jax.config.update("jax_compilation_cache_dir", os.environ["JAX_COMPILATION_CACHE_DIR"])


if __name__ == "__main__":
    main()
