"""MPI-safe output files: atomic JSON writes and output directories whose completion marker is
removed before a run starts (a failed run never leaves output that looks complete)."""

from __future__ import annotations

import dataclasses
import json
import os
from pathlib import Path
from typing import Any

import numpy as np
from mpi4py import MPI


def jsonable(obj: Any) -> Any:
    """``obj`` as plain JSON data: records (a ``to_json`` method) and dataclasses as objects, numpy
    arrays/scalars as lists/numbers, tuples as lists, paths as strings, dict keys as strings."""
    if hasattr(obj, "to_json") and not isinstance(obj, type):
        return obj.to_json()
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {f.name: jsonable(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
    if isinstance(obj, Path):
        return str(obj)
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    return obj


def write_json(path: Path, data: Any) -> None:
    """Write ``data`` (anything :func:`jsonable` converts) as JSON atomically: a temporary file in
    the same directory, then a rename (call on one rank; creates the directory)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    tmp.write_text(json.dumps(jsonable(data), indent=2) + "\n")
    os.replace(tmp, path)


def read_json(path: Path) -> Any:
    """The JSON data of ``path``."""
    return json.loads(Path(path).read_text())


def prepare_output(out_dir: str | Path, marker: str, comm: MPI.Comm) -> Path:
    """Create ``out_dir`` and remove its completion marker (collective): a run that fails now must
    not leave an old marker looking current. The marker is written last by the run."""
    out = Path(out_dir)
    if comm.rank == 0:
        out.mkdir(parents=True, exist_ok=True)
        (out / marker).unlink(missing_ok=True)
    comm.barrier()
    return out
