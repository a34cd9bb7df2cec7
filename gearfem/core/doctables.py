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

A block that quotes a result of a model (the built-in case's headline, the bench verdict) starts
with a provenance line (:class:`Provenance`) naming what the result was computed with: the
resolution key of the case and the code hash of the modules that compute it
(:func:`gearfem.core.provenance.code_hash`), the commit and the date::

    <!-- gearfem:provenance resolution=203abad67d018cb6 code=gearfem.pipeline@1f2e3d4c5b6a
         commit=4a453cc date=2026-11-28 -->

so that a check (:func:`gearfem.claims.stale_claims`, run by the test suite) can tell a figure
that no longer belongs to the model the repository ships.
"""

from __future__ import annotations

import dataclasses
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


_PROVENANCE = re.compile(r"<!-- gearfem:provenance (?P<fields>[^>]*?) -->")
_BLOCK = re.compile(
    r"<!-- gearfem:begin (?P<name>[A-Za-z0-9_.-]+) -->\n"
    r"(?P<text>.*?)<!-- gearfem:end (?P=name) -->",
    re.DOTALL,
)


@dataclasses.dataclass(frozen=True)
class Provenance:
    """What a quoted result was computed with.

    Attributes:
        resolution: Resolution key of the case (:func:`gearfem.uncertainty.resolution_key`), or
            None for a result that has no discretisation of the built-in case behind it.
        code: Code hash per root module (``{"gearfem.pipeline": "1f2e..."}``,
            :func:`gearfem.core.provenance.code_hash` of the module and what it imports).
        commit: The commit the computation ran at (``git describe``), or None.
        date: The date it ran (ISO).
    """

    resolution: str | None
    code: dict[str, str]
    commit: str | None = None
    date: str | None = None

    def line(self) -> str:
        fields = []
        if self.resolution is not None:
            fields.append(f"resolution={self.resolution}")
        if self.code:
            fields.append("code=" + ",".join(f"{m}@{h}" for m, h in sorted(self.code.items())))
        if self.commit:
            fields.append(f"commit={self.commit}")
        if self.date:
            fields.append(f"date={self.date}")
        return f"<!-- gearfem:provenance {' '.join(fields)} -->"

    @classmethod
    def parse(cls, text: str) -> Provenance | None:
        """The provenance line of a block's text (None when it has none)."""
        m = _PROVENANCE.search(text)
        if m is None:
            return None
        fields = dict(f.split("=", 1) for f in m.group("fields").split() if "=" in f)
        code = {}
        for item in filter(None, fields.get("code", "").split(",")):
            module, _, digest = item.partition("@")
            code[module] = digest
        return cls(fields.get("resolution"), code, fields.get("commit"), fields.get("date"))


def blocks(path: str | Path) -> dict[str, str]:
    """Every generated block of a Markdown page: name -> text (stripped)."""
    return {m["name"]: m["text"].strip() for m in _BLOCK.finditer(Path(path).read_text())}


def replace_block(
    path: str | Path, name: str, text: str, provenance: Provenance | None = None
) -> Path:
    """Replace the block ``name`` of the Markdown file ``path`` with ``text`` (atomic write),
    headed by the ``provenance`` line when given.

    Raises :class:`ParameterError` when the file lacks the block's begin/end markers (a script
    never appends a table to a page that does not ask for it) or has them more than once.
    """
    if provenance is not None:
        text = f"{provenance.line()}\n{text.strip()}"
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
