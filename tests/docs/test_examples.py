"""Every Python example in README.md and docs/**/*.md runs.

Each ```python block is executed as it stands, in a fresh namespace, with a temporary
folder as the working directory, so an example that drifts from the API fails here
instead of in a reader's hands. A block that cannot run (it needs hardware or a
display) is preceded by the line ``<!-- no-test -->``; there may be at most
``MAX_UNTESTED`` of those, so that marking is an exception and not a way out. A block
preceded by ``<!-- tested-by: tests/PATH.py -->`` is run by that test file (through
``example_code``), which checks its results, so the run is not paid twice.
"""

from __future__ import annotations

import dataclasses
import importlib.util
import re
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
DOC_FILES = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
NO_TEST = "<!-- no-test -->"
TESTED_BY = re.compile(r"^<!-- tested-by: (?P<path>tests/\S+\.py) -->$")
MAX_UNTESTED = 3

OPENING = re.compile(r"^(?P<indent>[ \t]*)```python[ \t]*$", re.MULTILINE)
FENCE = re.compile(
    r"^(?P<indent>[ \t]*)```python[ \t]*\n(?P<body>.*?)^(?P=indent)```[ \t]*$",
    re.MULTILINE | re.DOTALL,
)

# The packages of the target layout that a branch may document before the code moves
# reach it. An example importing one of them is skipped only while the package does not
# exist in this tree; once it exists the example runs. Any other import error fails.
TARGET_LAYOUT = ("otgym.task", "otgym.human", "otgym.autonomy")
IMPORTS = re.compile(r"^\s*(?:from|import)\s+(otgym\.[a-z_]+)", re.MULTILINE)


@dataclasses.dataclass(frozen=True)
class Example:
    path: Path
    line: int
    code: str
    untested: bool
    tested_by: str | None = None

    @property
    def name(self) -> str:
        return f"{self.path.relative_to(ROOT).as_posix()}:{self.line}"


def examples() -> list[Example]:
    found = []
    for path in DOC_FILES:
        text = path.read_text(encoding="utf-8")
        for match in FENCE.finditer(text):
            before = text[: match.start()].rstrip().splitlines()
            line = text.count("\n", 0, match.start()) + 1
            code = textwrap.dedent(match["body"])
            marker = before[-1].strip() if before else ""
            tested_by = TESTED_BY.match(marker)
            found.append(Example(path, line, code, marker == NO_TEST, tested_by["path"] if tested_by else None))
    return found


EXAMPLES = examples()


def test_every_python_fence_is_parsed():
    """Each line that opens a ```python block starts an example: a fence the parser
    misreads would otherwise drop its example silently."""
    openings = sum(len(OPENING.findall(path.read_text(encoding="utf-8"))) for path in DOC_FILES)
    assert openings == len(EXAMPLES)
    readme = [example for example in EXAMPLES if example.path.name == "README.md" and example.path.parent == ROOT]
    assert len(readme) >= 2, "README.md should show a Python and a Gymnasium example"


def test_untested_examples_are_few():
    untested = [example.name for example in EXAMPLES if example.untested]
    assert len(untested) <= MAX_UNTESTED, f"{len(untested)} examples marked {NO_TEST}: {untested}"


def example_code(doc: str, contains: str) -> str:
    """The code of the one example in ``doc`` (a path below the repository) that
    contains ``contains`` and is marked tested-by: for the test file that runs it."""
    found = [e for e in EXAMPLES if e.path == ROOT / doc and e.tested_by and contains in e.code]
    assert len(found) == 1, f"{len(found)} tested-by examples in {doc} contain {contains!r}"
    return found[0].code


def test_every_example_tested_elsewhere_is_run_by_its_test():
    """A tested-by marker names an existing test file that calls ``example_code`` on
    the marked example's document, so a marker cannot hide an example from every test."""
    for example in [e for e in EXAMPLES if e.tested_by]:
        test_file = ROOT / example.tested_by
        assert test_file.is_file(), example.name
        doc = example.path.relative_to(ROOT).as_posix()
        assert f'example_code("{doc}"' in test_file.read_text(encoding="utf-8"), example.name


def _missing_target_packages(code: str) -> list[str]:
    return [name for name in IMPORTS.findall(code) if name in TARGET_LAYOUT and importlib.util.find_spec(name) is None]


@pytest.mark.slow
@pytest.mark.parametrize("example", [e for e in EXAMPLES if not e.untested and not e.tested_by], ids=lambda e: e.name)
def test_example_runs(example: Example, tmp_path, monkeypatch):
    missing = _missing_target_packages(example.code)
    if missing:
        pytest.skip(f"{', '.join(missing)} not in this tree yet")
    monkeypatch.chdir(tmp_path)
    namespace = {"__name__": "__docs_example__"}
    exec(compile(example.code, example.name, "exec"), namespace)
