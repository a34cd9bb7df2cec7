"""Versions and run metadata: what ``gearfem info`` prints and what is stored next to every
result."""

from __future__ import annotations

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
