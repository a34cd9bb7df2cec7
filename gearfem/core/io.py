"""MPI-safe output files: atomic JSON writes and output directories whose completion marker is
removed before a run starts (a failed run never leaves output that looks complete)."""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import numpy as np
from mpi4py import MPI


def jsonable(obj: Any) -> Any:
    """``obj`` with numpy arrays/scalars as lists/numbers and dict keys as strings."""
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    return obj


def write_json_atomic(path: Path, data: dict[str, Any]) -> None:
    """Write JSON via a temporary file and rename (call on one rank)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    tmp.write_text(json.dumps(data, indent=2) + "\n")
    os.replace(tmp, path)


def write_json(path: Path, data: dict[str, Any]) -> None:
    """Write JSON (numpy arrays and scalars, paths allowed) atomically: temporary file, rename (one
    rank)."""
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    tmp.write_text(json.dumps(data, indent=2, default=_default))
    os.replace(tmp, path)


def read_json(path: Path) -> Any:
    """The JSON data of ``path``."""
    return json.loads(Path(path).read_text())


def _default(obj):
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(type(obj))


def prepare_output(out_dir: str | Path, marker: str, comm: MPI.Comm) -> Path:
    """Create ``out_dir`` and remove its completion marker (collective): a run that fails now must
    not leave an old marker looking current. The marker is written last by the run."""
    out = Path(out_dir)
    if comm.rank == 0:
        out.mkdir(parents=True, exist_ok=True)
        (out / marker).unlink(missing_ok=True)
    comm.barrier()
    return out
