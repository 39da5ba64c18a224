"""otgym's tasks, each a ``Task`` (``otgym.tasks.base``: the contract every consumer
relies on), one folder per task, registered by name in ``otgym.registry`` (kind
``tasks``). ``load(name)`` returns a task instance; ``otgym list tasks`` lists them."""

from __future__ import annotations

from otgym import registry
from otgym.tasks.base import Task


def load(name: str) -> Task:
    """An instance of the registered task ``name`` (ValueError naming the known ones)."""
    target = registry.load("tasks", name)
    task = target() if isinstance(target, type) else target
    if not isinstance(task, Task):
        raise TypeError(f"task {name!r} is registered as {target!r}, which is not an otgym.tasks.base.Task")
    if not task.name:
        task.name = name
    return task


__all__ = ["Task", "load"]
