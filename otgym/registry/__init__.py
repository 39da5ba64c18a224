"""The one registry of otgym's named parts: tasks, robots, devices, navigators,
shared-control laws, chips and plants. Every command-line choice, the window's device list, the
runtime's checks and the docs' lists read their names here; nothing else keeps a list.

An entry maps a name to a target, ``"module:attribute"``, imported only when the part is
asked for (``load``), so listing or checking names imports neither JAX nor pygame. A
chip's target is the path of its JSON sidecar (its PNG beside it).

Three sources, in this order (a later one may not reuse a name; ``register(...,
replace=True)`` may):

1. otgym's own parts (``otgym.registry.builtin``) and the chips shipped in
   ``otgym/data/chips/``;
2. installed packages' entry points, group ``otgym.<kind>`` (``otgym.tasks``,
   ``otgym.robots``, ``otgym.devices``, ``otgym.navigators``, ``otgym.laws``,
   ``otgym.chips``, ``otgym.plants``), e.g. in a user's ``pyproject.toml``::

       [project.entry-points."otgym.tasks"]
       push-bead = "my_lab.push_bead:PushBead"

   (a chip's entry point names an attribute holding its sidecar's path);
3. ``register(kind, name, target, description)`` at run time.

An entry point carries no description: ``describe`` takes the first line of the
target's docstring, importing it then.
"""

from __future__ import annotations

import dataclasses
import importlib
import importlib.metadata
import threading
import warnings
from pathlib import Path
from types import MappingProxyType

KINDS = MappingProxyType(
    {
        "tasks": "task",
        "robots": "robot",
        "devices": "device",
        "navigators": "navigator",
        "laws": "shared-control law",
        "chips": "chip",
        "plants": "plant",
    }
)
"""Each kind of registered part (plural, as in ``otgym list KIND``) and its singular
as error messages name it."""

CHIP_DATA_DIR = Path(__file__).resolve().parents[1] / "data" / "chips"
"""Where otgym's own chips live: ``NAME.png`` and its sidecar ``NAME.json``."""

ENTRY_POINT_GROUP = "otgym.{kind}"


@dataclasses.dataclass(frozen=True)
class Entry:
    """One named part. ``target``: ``"module:attribute"`` (a chip: its sidecar's path);
    ``tags``: what the part is usable for (e.g. a device's ``play``, ``window``,
    ``node``); ``extras``: kind-specific strings (a task's Gymnasium id and vector
    entry point); ``source``: ``otgym``, ``entry point DIST`` or ``register()``."""

    kind: str
    name: str
    target: str
    description: str = ""
    tags: frozenset[str] = frozenset()
    extras: MappingProxyType = dataclasses.field(default_factory=lambda: MappingProxyType({}))
    source: str = "otgym"

    def load(self):
        """The target, imported now (a chip: its sidecar's ``Path``)."""
        if self.kind == "chips":
            return Path(self.target)
        return _import(self.target)

    def load_extra(self, name: str):
        """Extra ``name``, a ``"module:attribute"``, imported now (KeyError if it has none)."""
        return _import(self.extras[name])


def _import(target: str):
    module, _, attribute = target.partition(":")
    value = importlib.import_module(module)
    for part in attribute.split(".") if attribute else ():
        value = getattr(value, part)
    return value


_entries: dict[str, dict[str, Entry]] = {kind: {} for kind in KINDS}
_loaded = False
_lock = threading.RLock()


def _check_kind(kind: str) -> str:
    if kind not in KINDS:
        raise ValueError(f"unknown kind {kind!r}; choose one of {', '.join(KINDS)}")
    return kind


def _check_target(kind: str, name: str, target: str) -> None:
    if not isinstance(name, str) or not name or any(c.isspace() for c in name) or "," in name:
        raise ValueError(f"a {KINDS[kind]} name must be a non-empty word without spaces or commas, not {name!r}")
    if kind != "chips":
        module, colon, attribute = target.partition(":")
        if not module or not colon or not attribute:
            raise ValueError(f"{KINDS[kind]} {name!r}: target must be 'module:attribute', not {target!r}")


def _add(entry: Entry, replace: bool) -> Entry:
    table = _entries[entry.kind]
    if entry.name in table and not replace:
        raise ValueError(
            f"{KINDS[entry.kind]} {entry.name!r} is registered already (by {table[entry.name].source}); "
            "pass replace=True to replace it"
        )
    table[entry.name] = entry
    return entry


def _load_sources() -> None:
    global _loaded
    with _lock:
        if _loaded:
            return
        _loaded = True
        from otgym.registry import builtin

        for kind, name, target, description, tags, extras in builtin.ENTRIES:
            _add(Entry(kind, name, target, description, frozenset(tags), MappingProxyType(dict(extras))), False)
        for sidecar in sorted(CHIP_DATA_DIR.glob("*.json")):
            if sidecar.with_suffix(".png").is_file():
                _add(Entry("chips", sidecar.stem, str(sidecar)), False)
        for kind in KINDS:
            for point in importlib.metadata.entry_points(group=ENTRY_POINT_GROUP.format(kind=kind)):
                dist = getattr(point.dist, "name", None) or "a package"
                if point.name in _entries[kind]:
                    continue  # otgym's own entry, or an earlier package's, keeps the name
                try:
                    target = str(Path(point.load())) if kind == "chips" else point.value
                    _check_target(kind, point.name, target)
                except Exception as error:  # one broken package must not break every command
                    warnings.warn(f"otgym: entry point {point.name!r} of {dist} left out: {error}", stacklevel=2)
                    continue
                _add(Entry(kind, point.name, target, source=f"entry point {dist}"), False)


def _chip_description(sidecar: Path) -> str:
    """A chip's sidecar ``description``, else its size, scale and ports from the sidecar
    and the PNG's header."""
    import json

    try:
        meta = json.loads(sidecar.read_text())
    except (OSError, ValueError) as error:
        return f"(unreadable sidecar: {error})"
    if meta.get("description"):
        return str(meta["description"])
    kinds = [port.get("kind") for port in meta.get("ports", ())]
    ports = f"{kinds.count('inlet')} inlets, {kinds.count('outlet')} outlets"
    try:
        from PIL import Image

        with Image.open(sidecar.with_suffix(".png")) as image:
            width_px, height_px = image.size
        pixel_um = float(meta["pixel_size_um"])
        return f"{width_px * pixel_um:g} x {height_px * pixel_um:g} um at {pixel_um:g} um per pixel, {ports}"
    except (OSError, KeyError, ValueError, TypeError):
        return ports


def register(
    kind: str,
    name: str,
    target: str | Path,
    description: str = "",
    *,
    tags: tuple[str, ...] = (),
    replace: bool = False,
    **extras: str,
) -> Entry:
    """Add part ``name`` of ``kind``; ValueError for a bad name or target, or a name
    taken (unless ``replace``)."""
    _check_kind(kind)
    _load_sources()
    target = str(Path(target).resolve()) if kind == "chips" else str(target)
    _check_target(kind, name, target)
    with _lock:
        entry = Entry(kind, name, target, description, frozenset(tags), MappingProxyType(dict(extras)), "register()")
        return _add(entry, replace)


def unregister(kind: str, name: str) -> None:
    """Remove part ``name`` of ``kind`` (KeyError if absent)."""
    _check_kind(kind)
    _load_sources()
    with _lock:
        del _entries[kind][name]


def entries(kind: str, tag: str | None = None) -> tuple[Entry, ...]:
    """The entries of ``kind`` (with ``tag``, if given), in registration order."""
    _check_kind(kind)
    _load_sources()
    return tuple(e for e in _entries[kind].values() if tag is None or tag in e.tags)


def names(kind: str, tag: str | None = None) -> tuple[str, ...]:
    """The names of ``kind`` (with ``tag``, if given), in registration order."""
    return tuple(e.name for e in entries(kind, tag))


def entry(kind: str, name: str, tag: str | None = None) -> Entry:
    """The entry of ``name``; ValueError naming the choices for an unknown one."""
    choices = names(kind, tag)
    if name not in choices:
        raise ValueError(f"unknown {KINDS[kind]} {name!r}; choose one of {', '.join(choices) or '(none registered)'}")
    return _entries[kind][name]


def check(kind: str, name: str, tag: str | None = None) -> str:
    """``name`` if it is a registered part of ``kind`` (with ``tag``); else ValueError."""
    entry(kind, name, tag)
    return name


def load(kind: str, name: str):
    """The target of ``name``, imported now."""
    return entry(kind, name).load()


def describe(found: Entry) -> str:
    """A one-line description: the entry's own, else its target's docstring's first line."""
    if found.description:
        return found.description
    if found.kind == "chips":
        return _chip_description(Path(found.target))
    try:
        doc = (getattr(found.load(), "__doc__", None) or "").strip()
    except Exception as error:  # a broken plugin is listed, with why it does not load
        return f"(does not load: {type(error).__name__}: {error})"
    return doc.splitlines()[0] if doc else ""
