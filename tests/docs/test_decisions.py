"""docs/decisions/ is one numbering series with a complete index: each record's number
is unique, its heading starts with it, and the index links every record once."""

import re
from pathlib import Path

DECISIONS = Path(__file__).resolve().parents[2] / "docs" / "decisions"


def test_each_number_once_heading_matches_and_the_index_lists_every_record():
    records = sorted(DECISIONS.glob("[0-9][0-9][0-9][0-9]-*.md"))
    numbers = [record.name[:4] for record in records]
    assert len(numbers) == len(set(numbers)), [n for n in numbers if numbers.count(n) > 1]
    for record in records:
        heading = record.read_text().splitlines()[0]
        assert re.match(rf"# {record.name[:4]}: \S", heading), (record.name, heading)
    linked = re.findall(r"\]\((\d{4}-[^)]+\.md)\)", (DECISIONS / "index.md").read_text())
    assert sorted(linked) == [record.name for record in records]
