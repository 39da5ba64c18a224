"""MkDocs hook: text in docstrings that only looks like a cross-reference stays text.

Markdown reads ``W[i] [u_x, u_y, w_z / 2]`` or ``W[i][:, :2]`` (array indexing in a
docstring) as a reference-style link, and mkdocs-autorefs would then fail the strict
build for a target that was never meant. A real target is a dotted Python path or a
heading's anchor; an ``<autoref>`` whose identifier is neither is turned back into the
text it came from. Every other unresolved reference still fails ``mkdocs build --strict``.
"""

import html
import re

AUTOREF = re.compile(r"<autoref (?P<attrs>[^>]*)>(?P<title>.*?)</autoref>", flags=re.DOTALL)
IDENTIFIER = re.compile(r'identifier="(?P<id>[^"]*)"')
TARGET = re.compile(r"^[A-Za-z_][\w.\-]*$")


def _restore(match: re.Match) -> str:
    found = IDENTIFIER.search(match["attrs"])
    if found is None or TARGET.match(html.unescape(found["id"])):
        return match[0]
    return f"[{match['title']}][{found['id']}]"


def on_page_content(html_text: str, **_) -> str:
    return AUTOREF.sub(_restore, html_text)
