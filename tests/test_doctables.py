"""Generated documentation blocks: replaced between their markers, refused without them."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from gearfem.core.doctables import markdown_table, read_block, replace_block
from gearfem.core.errors import ParameterError

PAGE = """# Page

Text before.

<!-- gearfem:begin demo -->
| old |
|---|
<!-- gearfem:end demo -->

Text after.
"""


def test_block_is_replaced_and_the_rest_kept(tmp_path):
    page = tmp_path / "page.md"
    page.write_text(PAGE)
    table = markdown_table(["h (mm)", "p0 error (%)"], [(14, "+0.58"), (10, "+0.25")])
    replace_block(page, "demo", table)
    replace_block(page, "demo", table)  # idempotent: markers stay
    text = page.read_text()
    assert text.startswith("# Page\n\nText before.\n\n")
    assert text.endswith("\n\nText after.\n")
    assert read_block(page, "demo") == table
    assert "| 14 | +0.58 |" in table and table.count("\n") == 3


def test_missing_or_doubled_markers_are_refused(tmp_path):
    page = tmp_path / "page.md"
    page.write_text("no markers here\n")
    with pytest.raises(ParameterError, match="demo"):
        replace_block(page, "demo", "x")
    page.write_text(PAGE + PAGE)
    with pytest.raises(ParameterError, match="one '<!-- gearfem:begin demo -->'"):
        replace_block(page, "demo", "x")


def test_row_length_checked():
    with pytest.raises(ValueError, match="2 cells"):
        markdown_table(["a"], [(1, 2)])


#: Marked blocks whose writer does not exist yet, by page and block name (none: every block has
#: its script). A name listed here must still be a marked, non-empty block of that page; remove it
#: once its script lands (a listed block that has a writer passes either way).
PENDING_WRITERS: set[tuple[str, str]] = set()


def _marked_pages(root: Path) -> list[Path]:
    return [root / "README.md", *sorted((root / "docs").glob("*.md"))]


def test_every_documentation_block_has_a_script_that_writes_it():
    """Each marked block in README.md and docs/*.md is non-empty and named in a script of
    benchmarks/ (or gearfem/, demos/) that writes it (one that calls ``replace_block``; a module
    that only reads or lists blocks is no writer): a table whose generator was removed or renamed
    fails here instead of silently going stale. Blocks in :data:`PENDING_WRITERS` are exempt from
    the writer check only."""
    root = Path(__file__).resolve().parent.parent
    sources = "\n".join(
        text
        for d in ("benchmarks", "gearfem", "demos")
        for p in sorted((root / d).rglob("*.py"))
        if "replace_block" in (text := p.read_text())
    )
    marker = re.compile(r"^<!-- gearfem:begin ([A-Za-z0-9_.-]+) -->$", re.M)
    names = []
    for page in _marked_pages(root):
        for name in marker.findall(page.read_text()):
            names.append(name)
            assert read_block(page, name), f"{page.name}: block {name} is empty"
            if (page.name, name) not in PENDING_WRITERS:
                assert f'"{name}"' in sources, f"{page.name}: no script writes block {name}"
    assert "hertz_refinement" in names and "calculix_hertz" in names
    pending = set(PENDING_WRITERS)
    found = {
        (page.name, name)
        for page in _marked_pages(root)
        for name in marker.findall(page.read_text())
    }
    assert pending <= found, f"listed but not marked in their page: {sorted(pending - found)}"


def _cells(line: str) -> int:
    """Cells of a Markdown table line: pipes inside code spans and escaped pipes do not count."""
    line = re.sub(r"`[^`]*`", "", line).replace("\\|", "")
    return line.strip().strip("|").count("|") + 1


def test_every_table_in_the_docs_has_a_cell_per_column():
    """A table row with more or fewer cells than its header (a '|' in a cell, say '|E|') is not
    rendered as a table, or loses the cells beyond the header: every table of README.md and docs/
    keeps its header's count on the delimiter row and on each row."""
    root = Path(__file__).resolve().parent.parent
    bad = []
    for page in [root / "README.md", *sorted((root / "docs").glob("*.md"))]:
        lines = page.read_text().splitlines()
        for i in range(1, len(lines)):
            if not re.fullmatch(r"\|(\s*:?-+:?\s*\|)+", lines[i].strip()):
                continue
            n = _cells(lines[i - 1])
            j = i
            while j < len(lines) and lines[j].lstrip().startswith("|"):
                if _cells(lines[j]) != n:
                    bad.append(f"{page.name}:{j + 1}: {_cells(lines[j])} cells, header {n}")
                j += 1
    assert not bad, "\n".join(bad)
