"""``otgym sweep SWEEP.toml --out DIR``: one otgym command over a grid of options, each
cell a Ray task (on a Ray started here, or on a cluster with ``--address``), or one after
another without Ray (``--serial``). The engine is ``otgym.cluster``; this module tells
it which commands exist and what their options take (from the typer app itself)."""

from __future__ import annotations

import types
import typing
from pathlib import Path

import typer

from otgym.cli import options
from otgym.cluster.sweep_file import CommandSpec, OptionSpec


def _annotation_and_choices(param):
    """The Python type an option converts to, and its choices (None if free): from
    typer's own description of the parameter (typer >= 0.20), else from click's type."""
    descriptor = getattr(param, "type_descriptor", None)
    if descriptor is not None:
        annotation = descriptor.annotation
        if typing.get_origin(annotation) in (typing.Union, types.UnionType):  # Optional[float] -> float
            annotation = next(arg for arg in typing.get_args(annotation) if arg is not type(None))
        choices = descriptor.choices
        return annotation, None if choices is None else tuple(str(choice) for choice in choices)
    name = type(param.type).__name__
    choices = getattr(param.type, "choices", None)
    annotation = {"IntParamType": int, "IntRange": int, "FloatParamType": float, "FloatRange": float}.get(name, str)
    if name == "BoolParamType" or getattr(param, "is_flag", False):
        annotation = bool
    return annotation, None if choices is None else tuple(str(choice) for choice in choices)


def _option_spec(param, name: str) -> OptionSpec:
    flag = None if param.param_type_name == "argument" else next(o for o in param.opts if o.startswith("--"))
    annotation, choices = _annotation_and_choices(param)
    if annotation is bool:
        negative = next((opt for opt in param.secondary_opts if opt.startswith("--")), None)
        return OptionSpec(name, flag, "bool", negative_flag=negative)
    if choices is not None:
        return OptionSpec(name, flag, "choice", choices)
    if annotation is int:
        return OptionSpec(name, flag, "int")
    if annotation is float:
        return OptionSpec(name, flag, "float")
    return OptionSpec(name, flag, "text")


def command_specs(root) -> dict[str, CommandSpec]:
    """Every command under ``root`` (the ``otgym`` click group) that writes an ``--out``
    folder (``sweep`` itself excepted), by name (``"experiment shared-control"``), with
    its options and arguments as a sweep file spells them (the long flag without dashes)."""
    specs: dict[str, CommandSpec] = {}

    def walk(command, words: tuple[str, ...]) -> None:
        if hasattr(command, "commands"):  # a group
            for name, sub in command.commands.items():
                walk(sub, words + (name,))
            return
        options, writes_out = {}, False
        for param in command.params:
            if param.param_type_name == "option":
                long = [opt for opt in param.opts if opt.startswith("--")]
                if not long or long[0] == "--help":
                    continue
                name = long[0][2:]
            else:
                name = param.name.replace("_", "-")
            if name == "out":
                writes_out = True
                continue
            options[name] = _option_spec(param, name)
        if writes_out and words != ("sweep",):
            specs[" ".join(words)] = CommandSpec(words, options)

    walk(root, ())
    return specs


def register(app: typer.Typer, entry_point: typing.Callable[[list[str]], None]) -> None:
    """Add ``otgym sweep`` to ``app``; each cell runs ``entry_point(argv)`` (the ``otgym``
    console script's ``main``, handed in by the app so that this module does not import it)."""

    @app.command()
    def sweep(
        context: typer.Context,
        sweep_file: Path = typer.Argument(
            ...,
            exists=True,
            file_okay=True,
            dir_okay=False,
            metavar="SWEEP.toml",
            help="Sweep file (TOML): command = ..., [options], [grid].",
        ),
        out: Path = options.out_dir(..., "Folder for cells.csv, the summary and one folder per cell."),
        address: str = typer.Option(
            None,
            "--address",
            metavar="ADDRESS",
            callback=options.check_ray_address,
            help="Run on a Ray cluster: auto (the one RAY_ADDRESS or Ray's record of the last `ray start` names) "
            "or the head's HOST:PORT. Default: start a new Ray of its own on this machine, whatever else runs.",
        ),
        serial: bool = typer.Option(False, "--serial", help="Run the cells one after another here, without Ray."),
        workers: int = typer.Option(
            None, "--workers", min=1, max=1024, help="Cells at once on a Ray started here (default: one per CPU core)."
        ),
        cpus_per_cell: float = typer.Option(
            1.0, "--cpus-per-cell", min=0.01, max=1024.0, help="CPU cores Ray reserves for each cell."
        ),
        gpus_per_cell: float = typer.Option(
            0.0, "--gpus-per-cell", min=0.0, max=64.0, help="GPUs Ray reserves for each cell."
        ),
    ) -> None:
        """Run one otgym command over a grid of options, each combination (cell) into
        OUT/<cell>/, with OUT/cells.csv (options, status, wall time, node of each cell)
        and a summary side by side. A stopped sweep resumes: finished cells are skipped.

        Example: otgym sweep seeds.toml --serial --out results/sweep"""
        from rich.console import Console

        from otgym.cluster.engine import ray_available, run_sweep
        from otgym.cluster.output import CELLS_CSV
        from otgym.cluster.summary import write_summary
        from otgym.cluster.sweep_file import load_sweep
        from otgym.experiments.common.output_folder import check_out_dir

        loaded = load_sweep(sweep_file, command_specs(context.find_root().command))
        if serial and address is not None:
            raise ValueError("--serial runs without Ray; --address joins a Ray cluster: give one of them")
        if workers is not None and (workers < 1 or address is not None or serial):
            raise ValueError("--workers must be at least 1, and only sizes a Ray started here (no --address, --serial)")
        if not cpus_per_cell > 0 or gpus_per_cell < 0:
            raise ValueError("--cpus-per-cell must be positive and --gpus-per-cell not negative")
        if not serial and not ray_available():
            raise ValueError("Ray is not installed: pip install 'otgym[cluster]', or run the cells here with --serial")
        check_out_dir(out)
        console = Console()
        run = run_sweep(loaded, out, entry_point, serial, address, workers, cpus_per_cell, gpus_per_cell, console)
        written = write_summary(loaded, out)
        names = ", ".join([CELLS_CSV] + [path.name for path in written])
        counts = f"{len(run.done)} done, {len(run.skipped)} skipped (finished earlier), {len(run.failed)} failed"
        console.print(f"[bold]otgym sweep[/bold] {loaded.command.name}: {len(loaded.cells)} cells: {counts}")
        console.print(f"wrote {out}/{{{names}}} and one folder per finished cell")
        if run.failed:
            first = run.failed[0]
            typer.echo(
                f"error: {len(run.failed)} of {len(loaded.cells)} cells failed ({first.name}: {first.error}); "
                f"see {out / CELLS_CSV}",
                err=True,
            )
            raise SystemExit(1)
