"""Versions and run metadata: what ``gearfem info`` prints and what is stored next to every
result."""

from __future__ import annotations

import ast
import functools
import hashlib
import platform
import subprocess
from pathlib import Path
from typing import Any


def git_hash(path: Path | None = None) -> str | None:
    """Commit of the gearfem source tree (with ``-dirty`` when modified), None outside a
    checkout."""
    root = Path(path or Path(__file__).resolve().parent.parent)
    try:
        out = subprocess.run(
            ["git", "-C", str(root), "describe", "--always", "--dirty", "--abbrev=12"],
            capture_output=True,
            text=True,
            timeout=10,
            check=False,
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout.strip() or None if out.returncode == 0 else None


def versions(comm=None) -> dict[str, Any]:
    """Versions of gearfem and the stack below it, plus the MPI size of ``comm`` (default WORLD)."""
    import basix
    import dolfinx
    import ffcx
    import gmsh
    import numpy
    import scipy
    import ufl
    from mpi4py import MPI
    from petsc4py import PETSc

    import gearfem

    comm = comm or MPI.COMM_WORLD
    petsc_version = ".".join(map(str, PETSc.Sys.getVersion()))
    info: dict[str, Any] = {
        "gearfem": gearfem.__version__,
        "gearfem_git": git_hash(),
        "python": platform.python_version(),
        "dolfinx": dolfinx.__version__,
        "dolfinx_git": getattr(dolfinx, "git_commit_hash", None),
        "basix": basix.__version__,
        "ffcx": ffcx.__version__,
        "ufl": ufl.__version__,
        "petsc": petsc_version,
        "petsc_scalar_type": numpy.dtype(PETSc.ScalarType).name,
        "petsc_int_bytes": numpy.dtype(PETSc.IntType).itemsize,
        "gmsh": gmsh.__version__,
        "numpy": numpy.__version__,
        "scipy": scipy.__version__,
        "mpi_library": MPI.Get_library_version().splitlines()[0].strip(),
        "mpi_size": comm.size,
        "platform": platform.platform(),
    }
    try:
        import dolfinx_solver

        info["dolfinx_solver_wheel"] = dolfinx_solver.__version__
    except ImportError:
        info["dolfinx_solver_wheel"] = None
    try:
        import pyvista

        info["pyvista"] = pyvista.__version__
    except ImportError:
        info["pyvista"] = None
    return info


def format_versions(info: dict[str, Any]) -> str:
    width = max(len(k) for k in info)
    return "\n".join(f"{k:<{width}}  {v}" for k, v in info.items())


def source_files(*modules: str) -> dict[str, Path]:
    """The gearfem ``modules`` and every gearfem module they import, transitively (read statically
    from the files, so it does not depend on what happens to be imported), with their files."""
    package = Path(__file__).resolve().parent.parent  # .../gearfem

    def path_of(name: str) -> Path | None:
        if name == "gearfem":
            return package / "__init__.py"
        rel = Path(*name.split(".")[1:])
        for cand in (package / rel.with_suffix(".py"), package / rel / "__init__.py"):
            if cand.is_file():
                return cand
        return None

    seen: dict[str, Path] = {}
    todo = list(modules)
    while todo:
        name = todo.pop()
        if name in seen or not (name == "gearfem" or name.startswith("gearfem.")):
            continue
        path = path_of(name)
        if path is None:
            continue
        seen[name] = path
        todo.extend(_module_facts(path)[0])
    return seen


@functools.cache
def _module_facts(path: Path) -> tuple[tuple[str, ...], str]:
    """What a module imports (the names :func:`source_files` follows) and its code without
    docstrings (:func:`_code_of`), from one parse of the file, once per process (as
    :func:`source_hash`: the code a process runs is the code it imported)."""
    tree = ast.parse(path.read_text())
    imports: list[str] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            imports.append(node.module)
            imports.extend(f"{node.module}.{a.name}" for a in node.names)  # submodules
        elif isinstance(node, ast.Import):
            imports.extend(a.name for a in node.names)
    return tuple(imports), _code_of_tree(tree)


@functools.cache
def source_hash(*modules: str, length: int = 16) -> str:
    """Hash of the sources of :func:`source_files` of ``modules``. A cache whose content those
    modules compute is keyed by it: an edit anywhere in the code that computes it invalidates the
    cache, and edits elsewhere do not. Computed once per process (the code a process runs is the
    code it imported; every cache key of a study would otherwise re-read the sources)."""
    seen = source_files(*modules)
    h = hashlib.sha256()
    for name in sorted(seen):
        h.update(name.encode())
        h.update(seen[name].read_bytes())
    return h.hexdigest()[:length]


def _code_of(path: Path) -> str:
    """The code of the module at ``path`` without its docstrings and comments."""
    return _code_of_tree(ast.parse(path.read_text()))


def _code_of_tree(tree: ast.Module) -> str:
    """The module's code without its docstrings and comments (``ast.dump`` of its tree): what
    the module computes, not how it is explained. Changes ``tree``."""
    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        if (
            isinstance(body, list)
            and body
            and isinstance(body[0], ast.Expr)
            and isinstance(body[0].value, ast.Constant)
            and isinstance(body[0].value.value, str)
        ):
            body[0] = ast.Pass()
    return ast.dump(tree, include_attributes=False)


@functools.cache
def code_hash(*modules: str, length: int = 12) -> str:
    """Hash of the code of :func:`source_files` of ``modules`` with docstrings and comments left
    out: what a published result depends on. A figure quoted in the documentation records it
    (:class:`gearfem.core.doctables.Provenance`), so that a change of the code that computed the
    figure shows as a stale claim, while a reworded docstring does not."""
    seen = source_files(*modules)
    h = hashlib.sha256()
    for name in sorted(seen):
        h.update(name.encode())
        h.update(_module_facts(seen[name])[1].encode())
    return h.hexdigest()[:length]
