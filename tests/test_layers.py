"""The package layers and the absence of import cycles, checked in-process: the
import-linter contracts of pyproject.toml (``lint-imports`` runs the same), and a
cycle search over grimp's graph of every module (function-level imports included)."""

import textwrap
from pathlib import Path

import grimp
import pytest
from importlinter import api  # noqa: F401 (configures import-linter's adapters)
from importlinter.application import use_cases

ROOT = Path(__file__).resolve().parents[1]


def module_cycles(graph) -> list[list[str]]:
    """Every group of modules that import each other in a cycle (the strongly
    connected components of more than one module, Tarjan's algorithm), sorted."""
    index, low, stack, on_stack, groups = {}, {}, [], set(), []
    for root in sorted(graph.modules):
        if root in index:
            continue
        work = [(root, iter(sorted(graph.find_modules_directly_imported_by(root))))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            module, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph.find_modules_directly_imported_by(child)))))
                elif child in on_stack:
                    low[module] = min(low[module], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[module])
            if low[module] == index[module]:
                group = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    group.append(member)
                    if member == module:
                        break
                if len(group) > 1:
                    groups.append(sorted(group))
    return sorted(groups)


def contract_kept(config: Path, contract_id: str) -> bool:
    """Whether import-linter finds contract ``contract_id`` of ``config`` kept (its
    report, with the imports that break it, is printed: pytest shows it on failure)."""
    return use_cases.lint_imports(str(config), limit_to_contracts=(contract_id,), cache_dir=None, no_logo=True)


@pytest.mark.parametrize("contract_id", ["layers", "studies", "acyclic"])
def test_the_layer_and_cycle_contracts_hold(contract_id):
    assert contract_kept(ROOT / "pyproject.toml", contract_id)


def test_no_import_cycle_between_modules():
    cycles = module_cycles(grimp.build_graph("otgym", cache_dir=None))
    assert not cycles, f"modules that import each other in a cycle: {cycles}"


def make_probe(folder: Path, broken: bool) -> Path:
    """A throwaway package ``layerprobe`` (a high and a low subpackage) in ``folder``,
    and a pyproject.toml with otgym's two kinds of contract over it. ``high.b``
    imports ``low.a``; with ``broken``, ``low.a`` also imports ``high.b`` inside a
    function: a layer broken and a cycle."""
    package = folder / "layerprobe"
    for each in (package, package / "low", package / "high"):
        each.mkdir()
        (each / "__init__.py").write_text("")
    (package / "high" / "b.py").write_text("from layerprobe.low import a\n")
    (package / "low" / "a.py").write_text(
        "def late():\n    from layerprobe.high import b\n\n    return b\n" if broken else ""
    )
    config = folder / "pyproject.toml"
    config.write_text(
        textwrap.dedent(
            """\
            [tool.importlinter]
            root_package = "layerprobe"

            [[tool.importlinter.contracts]]
            id = "layers"
            name = "layers"
            type = "layers"
            containers = ["layerprobe"]
            layers = ["high", "low"]
            exhaustive = true

            [[tool.importlinter.contracts]]
            id = "acyclic"
            name = "acyclic"
            type = "acyclic_siblings"
            ancestors = ["layerprobe"]
            """
        )
    )
    return config


@pytest.mark.parametrize("broken", [False, True])
def test_the_checks_catch_an_upward_import_and_a_cycle(tmp_path, monkeypatch, broken):
    """Both checks pass on a package that keeps the rules and fail on one that breaks
    them (so the tests above can fail)."""
    config = make_probe(tmp_path, broken)
    monkeypatch.syspath_prepend(str(tmp_path))
    assert contract_kept(config, "layers") is not broken
    assert contract_kept(config, "acyclic") is not broken
    cycles = module_cycles(grimp.build_graph("layerprobe", cache_dir=None))
    assert cycles == ([["layerprobe.high.b", "layerprobe.low.a"]] if broken else [])


MAX_MODULE_LINES = 500
"""The bound on a module of otgym (docs/contributing.md: modules with one job, none over 500 lines)."""


def test_no_module_of_otgym_is_over_500_lines():
    sizes = {
        path.relative_to(ROOT).as_posix(): len(path.read_text().splitlines()) for path in (ROOT / "otgym").rglob("*.py")
    }
    assert len(sizes) > 100, sorted(sizes)  # the package was found
    assert {path: lines for path, lines in sizes.items() if lines > MAX_MODULE_LINES} == {}
