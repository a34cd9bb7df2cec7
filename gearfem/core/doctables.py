"""Tables of measured figures written into the documentation by the script that measures them.

A table in ``docs/*.md`` that reports measured numbers is not typed by hand: the benchmark or study
that measures it replaces a marked block of the page, so a regression shows up as a changed table
in the diff. A block looks like this in the Markdown source::

    <!-- gearfem:begin hertz_refinement -->
    | h (mm) | p0 error | ... |
    |---|---|---|
    <!-- gearfem:end hertz_refinement -->

and :func:`replace_block` rewrites what lies between the two markers (the markers stay, so the
page can be regenerated any number of times). :func:`markdown_table` formats rows.
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterable, Sequence
from pathlib import Path

from gearfem.core.errors import ParameterError

_NAME = re.compile(r"^[A-Za-z0-9_.-]+$")


def _markers(name: str) -> tuple[str, str]:
    if not _NAME.match(name):
        raise ParameterError("block name", name, "letters, digits, '_', '.', '-'")
    return f"<!-- gearfem:begin {name} -->", f"<!-- gearfem:end {name} -->"


def markdown_table(headers: Sequence[str], rows: Iterable[Sequence[object]]) -> str:
    """A Markdown table: ``headers`` and one line per row (cells formatted with ``str``)."""
    head = "| " + " | ".join(headers) + " |"
    rule = "|" + "|".join("---" for _ in headers) + "|"
    body = []
    for row in rows:
        cells = [str(c) for c in row]
        if len(cells) != len(headers):
            raise ValueError(f"row {cells} has {len(cells)} cells, the table {len(headers)}")
        body.append("| " + " | ".join(cells) + " |")
    return "\n".join([head, rule, *body])


def replace_block(path: str | Path, name: str, text: str) -> Path:
    """Replace the block ``name`` of the Markdown file ``path`` with ``text`` (atomic write).

    Raises :class:`ParameterError` when the file lacks the block's begin/end markers (a script
    never appends a table to a page that does not ask for it) or has them more than once.
    """
    path = Path(path)
    begin, end = _markers(name)
    src = path.read_text()
    if src.count(begin) != 1 or src.count(end) != 1 or src.index(begin) > src.index(end):
        raise ParameterError(
            "documentation block",
            f"{path}:{name}",
            f"one '{begin}' line followed by one '{end}' line in the page",
        )
    head, rest = src.split(begin, 1)
    _, tail = rest.split(end, 1)
    new = f"{head}{begin}\n{text.strip()}\n{end}{tail}"
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    tmp.write_text(new)
    os.replace(tmp, path)
    return path


def read_block(path: str | Path, name: str) -> str:
    """The current text of block ``name`` of ``path`` (between the markers, stripped)."""
    begin, end = _markers(name)
    src = Path(path).read_text()
    if begin not in src or end not in src:
        raise ParameterError("documentation block", f"{path}:{name}", "present in the page")
    return src.split(begin, 1)[1].split(end, 1)[0].strip()
