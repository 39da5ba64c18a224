"""The one registry (``otgym.registry``): every built-in target imports, run-time
registration and its errors, installed packages' entry points, ``otgym list``, and no
list of part names kept anywhere else in otgym."""

from __future__ import annotations

import ast
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from otgym import registry

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("kind", [k for k in registry.KINDS if k != "chips"])
def test_every_built_in_target_imports_and_is_callable(kind):
    """Every target loads: a robot is a ``RobotSpec``, a task a ``Task`` class, any other
    part something callable."""
    from otgym.physics.robots import RobotSpec
    from otgym.tasks.base import Task

    found = registry.entries(kind)
    assert found, kind
    for entry in found:
        target = entry.load()
        if kind == "robots":
            assert isinstance(target, RobotSpec), f"{kind} {entry.name}: {entry.target}"
        elif kind == "tasks":
            assert isinstance(target, type) and issubclass(target, Task), f"{kind} {entry.name}: {entry.target}"
        else:
            assert callable(target), f"{kind} {entry.name}: {entry.target}"
        assert registry.describe(entry), f"{kind} {entry.name} has no description"


def test_the_shipped_chips_are_registered_with_their_sidecars():
    chip = registry.entry("chips", "default")
    assert chip.load().name == "default.json" and chip.load().with_suffix(".png").is_file()
    assert "300 x 200 um" in registry.describe(chip)


def test_an_unknown_name_is_one_line_naming_the_choices():
    with pytest.raises(ValueError, match=r"unknown navigator 'warp'; choose one of route, mpc, rl") as info:
        registry.check("navigators", "warp")
    assert "\n" not in str(info.value)
    with pytest.raises(ValueError, match="unknown device 'replay'; choose one of keyboard, gamepad, touch, simulated"):
        registry.check("devices", "replay", "play")
    with pytest.raises(ValueError, match="unknown kind 'gizmos'"):
        registry.names("gizmos")


def test_register_adds_refuses_a_taken_name_replaces_on_request_and_checks_targets():
    try:
        entry = registry.register("laws", "always-half", "tests.registry.test_registry:half_alpha", "0.5 everywhere")
        assert registry.names("laws")[-1] == "always-half" and entry.source == "register()"
        assert registry.load("laws", "always-half") is half_alpha
        with pytest.raises(ValueError, match="registered already"):
            registry.register("laws", "always-half", "tests.registry.test_registry:half_alpha")
        registry.register("laws", "always-half", "tests.registry.test_registry:half_alpha", "again", replace=True)
        assert registry.describe(registry.entry("laws", "always-half")) == "again"
        from otgym.shared import ArbitrationConfig, alpha_for_mode

        assert float(alpha_for_mode("shared", 3.0, ArbitrationConfig(law="always-half"))) == 0.5
    finally:
        registry.unregister("laws", "always-half")
    assert "always-half" not in registry.names("laws")
    for name, target in (("two words", "m:a"), ("", "m:a"), ("a,b", "m:a"), ("ok", "no-colon"), ("ok", "m:")):
        with pytest.raises(ValueError, match="name must be|target must be"):
            registry.register("laws", name, target)


def half_alpha(distance_um, d1_um, d2_um):
    """A law for the registration test: 0.5 at every distance."""
    return 0.5 + 0.0 * distance_um


def _plugin_site(tmp_path: Path) -> Path:
    """A package installed the way pip leaves one (a .dist-info with entry_points.txt)
    that adds a task, a navigator and a chip, and one broken entry point."""
    site = tmp_path / "site"
    package = site / "mylab"
    package.mkdir(parents=True)
    (package / "__init__.py").write_text(
        textwrap.dedent(
            '''
            from pathlib import Path

            class Sorter:
                """Sort two kinds of cells into two outlets."""

            class Wanderer:
                """A navigator that wanders."""

            CHIP = Path(__file__).with_name("chips") / "bead-sorter.json"
            '''
        )
    )
    chips = package / "chips"
    chips.mkdir()
    (chips / "bead-sorter.json").write_text(
        '{"name": "bead-sorter", "description": "a sorting chip", "pixel_size_um": 1.0}'
    )
    info = site / "mylab-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: mylab\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(
        "[otgym.tasks]\nsort-beads = mylab:Sorter\n\n"
        "[otgym.navigators]\nwander = mylab:Wanderer\nroute = mylab:Wanderer\nbroken = mylab:Missing\n\n"
        "[otgym.chips]\nbead-sorter = mylab:CHIP\n"
    )
    return site


@pytest.mark.slow
def test_an_installed_package_adds_parts_through_entry_points(tmp_path):
    """``otgym list`` in a fresh process sees the package's task, navigator and chip,
    says where they come from, keeps otgym's own ``route``, and lists the broken entry
    with why it does not load instead of failing."""
    env = dict(os.environ, PYTHONPATH=f"{_plugin_site(tmp_path)}{os.pathsep}{ROOT}")

    def run(argv: list[str]) -> str:
        done = subprocess.run([sys.executable, *argv], env=env, capture_output=True, text=True, timeout=120)
        assert done.returncode == 0, done.stderr
        return done.stdout

    tasks = run(["-m", "otgym", "list", "tasks"])
    navigators, chips, _ = run(["-c", LIST_NAVIGATORS_AND_CHIPS]).split("--\n")
    assert "sort-beads" in tasks and "Sort two kinds of cells into two outlets." in tasks
    assert "from entry point mylab" in tasks
    assert navigators.splitlines()[0].startswith("route ") and "the paper's autonomy" in navigators
    assert "entry point mylab" in navigators
    assert "wander" in navigators and "does not load" in navigators and "broken" in navigators
    assert "bead-sorter" in chips and "a sorting chip" in chips


LIST_NAVIGATORS_AND_CHIPS = """
from otgym import registry
for kind in ("navigators", "chips"):
    for entry in registry.entries(kind):
        print(entry.name, registry.describe(entry), entry.source)
    print("--")
"""


def _name_lists(path: Path, names_by_kind: dict[str, set[str]]):
    """The literal tuples, lists, sets and dict keys in ``path`` that hold two or more
    registered names of one kind."""
    tree = ast.parse(path.read_text())
    for node in ast.walk(tree):
        if isinstance(node, ast.Tuple | ast.List | ast.Set):
            items = node.elts
        elif isinstance(node, ast.Dict):
            items = [key for key in node.keys if key is not None]
        else:
            continue
        words = {item.value for item in items if isinstance(item, ast.Constant) and isinstance(item.value, str)}
        for kind, names in names_by_kind.items():
            if len(words & names) >= 2:
                yield f"{path.relative_to(ROOT)}:{node.lineno}: {kind} {sorted(words & names)}"


def test_no_list_of_part_names_outside_the_registry():
    """A literal collection of two or more names of one kind (devices, navigators,
    laws, robots, tasks) anywhere in otgym but the registry is a second list that will
    drift from it."""
    names_by_kind = {kind: set(registry.names(kind)) for kind in registry.KINDS if kind != "chips"}
    found = [
        line
        for path in sorted((ROOT / "otgym").rglob("*.py"))
        if "registry" not in path.relative_to(ROOT / "otgym").parts
        for line in _name_lists(path, names_by_kind)
    ]
    assert not found, "\n".join(found)
