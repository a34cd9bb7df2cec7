"""gearfem: thermomechanical finite element model of polymer spur gear pairs.

Data path (one package per stage): ``geometry`` -> ``contact``/``cycle`` -> ``sources`` ->
``thermal`` -> ``diagnose``; ``pipeline`` joins them, ``cli`` is the ``gearfem`` command.

Importing gearfem imports the DOLFINx stack in the right order: the PyPI binary wheel
``dolfinx-solver-real`` must be imported before ``dolfinx``/``petsc4py`` (it orders MPI ahead of the
compiled bindings); conda, Spack and container installs have DOLFINx without it.
"""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError
from importlib.metadata import version as _dist_version

from gearfem.core.errors import MissingDependencyError

try:
    __version__ = _dist_version("gearfem")
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0.1.0+src"

MIN_DOLFINX = (0, 10)

_INSTALL_HINT = (
    "Install DOLFINx >= 0.10 with one of: "
    "`pip install 'gearfem[fenics]'` (PyPI wheel dolfinx-solver-real, Python >= 3.12), "
    "`conda install -c conda-forge fenics-dolfinx mpich`, "
    "or use the container recipe container/Dockerfile (ghcr.io/fenics/dolfinx/dolfinx:v0.11.0). "
    "The README's `./dev.sh run` sets all of this up."
)

try:  # must come first when present: orders mpi4py.MPI ahead of the DOLFINx/PETSc bindings
    import dolfinx_solver  # noqa: F401
except ImportError:
    pass

try:
    import dolfinx as _dolfinx
except ImportError as _err:  # pragma: no cover - exercised in a subprocess test
    raise MissingDependencyError(
        f"gearfem needs DOLFINx, which is not importable ({_err}). {_INSTALL_HINT}"
    ) from _err


def _version_tuple(text: str) -> tuple[int, ...]:
    parts = []
    for piece in text.split(".")[:3]:
        digits = "".join(ch for ch in piece if ch.isdigit())
        if not digits:
            break
        parts.append(int(digits))
    return tuple(parts)


if _version_tuple(getattr(_dolfinx, "__version__", "0")) < MIN_DOLFINX:
    raise MissingDependencyError(
        f"gearfem needs DOLFINx >= {'.'.join(map(str, MIN_DOLFINX))}, found "
        f"{getattr(_dolfinx, '__version__', 'unknown')} at {getattr(_dolfinx, '__file__', '?')}. "
        f"{_INSTALL_HINT}"
    )

__all__ = ["MIN_DOLFINX", "__version__"]
