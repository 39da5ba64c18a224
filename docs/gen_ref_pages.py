"""Generate the API reference pages from the package tree, at build time.

mkdocs-gen-files runs this script on every ``mkdocs build``: one page per module of
``otgym`` (a package's page is its ``__init__``), each holding a mkdocstrings
directive, and ``reference/SUMMARY.md`` as the navigation that mkdocs-literate-nav
reads. Nothing lists module names by hand, so the reference follows whatever modules
exist.
"""

from pathlib import Path

import mkdocs_gen_files

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "otgym"

nav = mkdocs_gen_files.Nav()

for path in sorted(PACKAGE.rglob("*.py")):
    module_path = path.relative_to(ROOT).with_suffix("")
    parts = tuple(module_path.parts)
    if parts[-1] == "__main__" or any(part.startswith("_") and part != "__init__" for part in parts):
        continue
    doc_path = path.relative_to(ROOT).with_suffix(".md")
    if parts[-1] == "__init__":
        parts = parts[:-1]
        doc_path = doc_path.with_name("index.md")
    full_doc_path = Path("reference", doc_path)
    nav[parts] = doc_path.as_posix()
    with mkdocs_gen_files.open(full_doc_path, "w") as page:
        page.write(f"::: {'.'.join(parts)}\n")
    mkdocs_gen_files.set_edit_path(full_doc_path, path.relative_to(ROOT))

with mkdocs_gen_files.open("reference/SUMMARY.md", "w") as summary:
    summary.writelines(nav.build_literate_nav())
