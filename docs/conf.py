"""Sphinx configuration of the gearfem documentation site: ``./dev.sh docs`` builds it into
docs/_build/html.

The pages are the Markdown files of this folder (MyST), the demos of ``demos/`` (jupytext percent
scripts, converted to Markdown pages at build time and rendered, not executed) and the API
reference from the docstrings (autodoc and autosummary; importing gearfem imports DOLFINx).
tests/test_docs.py builds the site with warnings as errors and nitpicky references.
"""

from __future__ import annotations

import os
import re
import sys
import types
from importlib.metadata import version as _version
from pathlib import Path

import jupytext

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
GENERATED = DOCS / "_generated"

os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")
os.environ.setdefault("MPLBACKEND", "Agg")

# autosummary's recursion imports every submodule; gearfem/__main__.py would run the command line
# on Sphinx's own arguments. A stand-in marked as a mock is skipped instead.
_main = types.ModuleType("gearfem.__main__")
_main.__sphinx_mock__ = True  # type: ignore[attr-defined]
sys.modules.setdefault("gearfem.__main__", _main)

project = "gearfem"
author = "gearfem developers"
copyright = "gearfem developers (MIT licence)"
release = _version("gearfem")
version = release

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
]
source_suffix = {".md": "markdown", ".rst": "restructuredtext"}  # .rst: autosummary's stubs
root_doc = "index"
exclude_patterns = ["_build", "**/.*"]
myst_heading_anchors = 3

autosummary_generate = True
# every module's own members, whether or not its __all__ names them (the tables and the pages agree)
autodoc_default_options = {
    "members": True,
    "undoc-members": True,
    "ignore-module-all": True,
    "member-order": "bysource",
}
# The docstrings are plain text in the project's style (units in names, equations in Unicode,
# indented layouts), not reStructuredText: the API pages show them as written (see
# _docstring_as_written below) and the signatures without annotations, so that nothing in them is
# parsed into references that a plain-text docstring never meant.
autodoc_typehints = "none"

# Nitpicky: every reference in the pages and demos must resolve (to a page, a heading or an object
# of the API reference). The third-party libraries' inventories are not fetched (the build runs
# without network), so references to their types are not checked.
nitpicky = True
_THIRD_PARTY = (
    r"(numpy|np|npt|scipy|dolfinx|ufl|basix|petsc4py|PETSc|mpi4py|MPI|matplotlib|pyvista|gmsh"
    r"|tomllib|pathlib|collections|typing|dataclasses|argparse|logging|concurrent|enum|abc"
    r"|contextlib|importlib|io|os|threadpoolctl)(\..*)?"
)
nitpick_ignore_regex = [
    (r"py:.*", _THIRD_PARTY),
    (r"py:.*", r"(Path|Callable|Iterable|Iterator|Sequence|Mapping|Any|Self|NDArray|ArrayLike)"),
    (r"py:.*", r"(optional|default|array|ndarray|callable|float|int|str|bool|dict|list|tuple)"),
]

html_theme = "furo"
html_title = f"gearfem {release}"
html_static_path: list[str] = []


def _docstring_as_written(app, what, name, obj, options, lines: list[str]) -> None:
    """autodoc-process-docstring: a docstring becomes a literal block, shown as written."""
    if lines:
        lines[:] = ["::", "", *(f"    {line}" for line in lines), ""]


def setup(app) -> None:
    app.connect("autodoc-process-docstring", _docstring_as_written)


def _code_name(m: re.Match) -> str:
    name = m.group(1)
    return f"`{name.rsplit('.', 1)[-1] if m.group(0).count('~') else name}`"


def _demo_page(path: Path) -> str:
    """A demo (jupytext percent script) as a Markdown page: its Markdown cells as text, its code
    cells as Python blocks, its module docstring (parameters, outputs, how to run) first."""
    nb = jupytext.read(path, fmt="py:percent")
    parts = []
    title = None
    for cell in nb.cells:
        src = cell.source.strip("\n")
        if not src.strip():
            continue
        if cell.cell_type == "markdown":
            # reST roles of the docstring style (:class:`~gearfem.contact.ContactSurface`) as code
            src = re.sub(r":(?:func|class|meth|mod|data|attr):`~?([\w.]+)`", _code_name, src)
            if title is None and src.startswith("# "):
                title = src.splitlines()[0]
                src = "\n".join(src.splitlines()[1:]).strip("\n")
            parts.append(src)
        else:
            parts.append(f"```python\n{src}\n```")
    if title is None:
        doc = nb.cells[0].source.strip().strip('"').strip().splitlines()[0]
        title = f"# {doc.rstrip('.')}"
    run = f"*Source: `demos/{path.name}` (rendered, not executed).*"
    return "\n\n".join([title, run, *parts]) + "\n"


def _write_demos() -> None:
    out = GENERATED / "demos"
    out.mkdir(parents=True, exist_ok=True)
    names = []
    for path in sorted((ROOT / "demos").glob("*.py")):
        text = _demo_page(path)
        page = out / f"{path.stem}.md"
        if not page.exists() or page.read_text() != text:
            page.write_text(text)
        names.append(path.stem)
    for stale in out.glob("*.md"):
        if stale.stem not in names:
            stale.unlink()


_write_demos()
