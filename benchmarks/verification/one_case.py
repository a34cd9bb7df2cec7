"""What the verification scripts read from one case: the loads and pressures of its structural
cycle, and the fields of its thermal runs on that cycle, solved in a temporary directory that is
removed afterwards (the scripts quote numbers, they keep no run).

A script of this folder imports it by name (``python benchmarks/verification/x.py`` puts the
folder first on the path; ``tests/scripts.load_script`` does the same)."""

from __future__ import annotations

import contextlib
import dataclasses
import math
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

import numpy as np

import gearfem  # noqa: F401  (must precede dolfinx/petsc4py)
from gearfem import pipeline
from gearfem.config import Case
from gearfem.instruments.snapshot import FieldSnapshot


@dataclasses.dataclass(frozen=True)
class CycleLoads:
    """The quantities the tractions of a cycle set, at the case's speed."""

    largest_load_N: float  # the largest tooth-pair normal load over the positions
    mean_load_N: float  # the mean tooth-pair load over the positions where a pair is engaged
    effective_contact_ratio: float
    pitch_point_band_pressure_MPa: float  # NaN where no band holds the pitch point
    largest_pressure_MPa: float
    te_mean_um: float  # the mean transmission error
    largest_u_max_J_m3: float  # the largest cell's U_max of either gear (hysteresis)

    @classmethod
    def of(cls, cycle, speed_rpm: float) -> CycleLoads:
        """The quantities of a :class:`gearfem.cycle.result.CycleResult` run at ``speed_rpm``."""
        at = pipeline.CycleAtSpeed.of(cycle, speed_rpm)
        loads = np.array([v for v in cycle.tooth_load_N.values()])  # (teeth, positions)
        return cls(
            largest_load_N=float(loads.max()),
            mean_load_N=float(loads[loads > 0].mean()),
            effective_contact_ratio=at.effective_contact_ratio,
            pitch_point_band_pressure_MPa=at.pitch_point_band_pressure_MPa or math.nan,
            largest_pressure_MPa=at.max_contact_pressure_MPa,
            te_mean_um=at.transmission_error_um["mean"],
            largest_u_max_J_m3=max(float(np.max(f.u_max_J_m3)) for f in cycle.fields.values()),
        )


@contextlib.contextmanager
def scratch_directory(comm) -> Iterator[Path]:
    """A new temporary directory, the same on every rank, removed when the block is left (also on
    an error; collective)."""
    name = tempfile.mkdtemp(prefix="gearfem-verification-") if comm.rank == 0 else None
    out = Path(comm.bcast(name, root=0))
    try:
        yield out
    finally:
        comm.barrier()
        if comm.rank == 0:
            shutil.rmtree(out, ignore_errors=True)


def observed_fields(case: Case, comm, cycle, steady: bool = True) -> FieldSnapshot | None:
    """The fields' snapshot of the thermal runs of ``case`` on ``cycle`` (rank 0; None on the
    others), as :func:`gearfem.pipeline.observed_thermal` with ``steady``, run in a
    :func:`scratch_directory` (collective)."""
    with scratch_directory(comm) as out:
        _, _, snap = pipeline.observed_thermal(
            case, out, comm, cycle, write_fields=False, steady=steady, write_plot=False
        )
    return snap


def steady_case(case: Case) -> Case:
    """``case`` with its thermal run the steady state, no output times."""
    return dataclasses.replace(
        case, thermal=dataclasses.replace(case.thermal, mode="steady", output_times_s=())
    )
