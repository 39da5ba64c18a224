"""``otgym list KIND``: the registered parts of one kind (tasks, robots, devices,
navigators, laws, chips, plants), each with a one-line description, from ``otgym.registry``."""

from __future__ import annotations

import typer


def _check_kind(value: str) -> str:
    from otgym import registry

    if value not in registry.KINDS:
        raise typer.BadParameter(f"{value!r} is not one of {', '.join(registry.KINDS)}", param_hint="KIND")
    return value


def register(app: typer.Typer) -> None:
    @app.command("list")
    def list_parts(
        kind: str = typer.Argument(
            ...,
            metavar="KIND",
            callback=_check_kind,
            help="tasks, robots, devices, navigators, laws or chips.",
        ),
    ) -> None:
        """Print the registered parts of KIND: name, what it is, and what it is usable
        for (tags) or where it comes from when not from otgym itself.

        Example: otgym list tasks
        """
        from otgym import registry

        rows = []
        for found in registry.entries(kind):
            notes = [", ".join(sorted(found.tags))] if found.tags else []
            if found.extras.get("gym_id"):
                notes.append(found.extras["gym_id"])
            if found.source != "otgym":
                notes.append(f"from {found.source}")
            rows.append((found.name, registry.describe(found), "; ".join(notes)))
        width = max((len(name) for name, _, _ in rows), default=0)
        for name, description, notes in rows:
            typer.echo(f"{name:<{width}}  {description}" + (f"  [{notes}]" if notes else ""))
