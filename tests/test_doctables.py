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
