"""Shared test set-up, safe under ``mpirun -n 2``.

* Every rank runs the same tests; only rank 0 reports to the terminal. Other ranks write their
  report to ``$TMPDIR/gearfem-pytest-rank<r>.log`` (mpirun still fails when any rank fails), and
  each failure at once to stderr with its traceback (rank 0 may be left waiting for that rank).
* Tests that compare serial and parallel results compute on ``MPI.COMM_SELF`` and on
  ``MPI.COMM_WORLD`` inside one run (fixture ``comms``), so 1 vs 2 ranks is checked by the single
  ``mpirun -n 2 pytest -m mpi`` invocation.
* Off-screen plotting and a matplotlib backend without a display.
* The longest test modules are collected first (:data:`LONGEST_MODULES`, the quick tier's
  :data:`LONGEST_QUICK_MODULES`): dev.sh hands whole
  modules to its two pytest-xdist workers in collection order (``--dist loadfile
  --no-loadscope-reorder``), and a long module started last is a tail that only one core works on.
"""

from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")
os.environ.setdefault("MPLBACKEND", "Agg")

import pytest
from mpi4py import MPI

import gearfem  # noqa: F401  (orders dolfinx_solver first)

ROOT = Path(__file__).resolve().parent.parent


def pytest_configure(config: pytest.Config) -> None:
    rank = MPI.COMM_WORLD.rank
    if rank > 0:
        log = Path(tempfile.gettempdir()) / f"gearfem-pytest-rank{rank}.log"
        stream = open(log, "w")  # noqa: SIM115 - lives as long as the session
        sys.stdout = stream
        reporter = config.pluginmanager.get_plugin("terminalreporter")
        if reporter is not None:
            reporter._tw = type(reporter._tw)(stream)  # type: ignore[attr-defined]


#: Test modules by their serial time in the full tier (measured on a fresh clone: 267, 230, 185,
#: 81 and 81 s of 1,104 s), longest first. The rest follow in their usual order; only the order
#: depends on this list. xdist gives each worker one module to start (then the next in line when a
#: worker has two tests left): the two diagnosis modules start apart, the friction one first, so
#: that the classic one finds the coarse case's 8 N m cycle in the cache that the friction
#: surrogate computed, instead of computing it at the same time on the other worker.
LONGEST_MODULES = (
    "test_diagnose_friction.py",
    "test_cycle.py",
    "test_diagnose.py",
    "test_instruments.py",
    "test_material_chain.py",
    "test_contact.py",
)
#: The same for the quick tier (``-m "not slow ..."``; measured with an empty FFCx cache: 30, 25,
#: 17, 13, 11 and 10 s of 132 s), where the full tier's longest modules are nearly empty and the
#: thermal verification, collected late, was a tail on one worker.
LONGEST_QUICK_MODULES = (
    "test_thermal_verification.py",
    "test_instruments.py",
    "test_diagnose.py",
    "test_gear_mesh.py",
    "test_friction.py",
    "test_thermal_outputs.py",
)


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Longest modules first (:data:`LONGEST_MODULES`, in the quick tier
    :data:`LONGEST_QUICK_MODULES`), the others after them in their order."""
    quick = "not slow" in (config.getoption("markexpr") or "")
    rank = {name: i for i, name in enumerate(LONGEST_QUICK_MODULES if quick else LONGEST_MODULES)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))  # stable: order within kept


def pytest_runtest_logreport(report: pytest.TestReport) -> None:
    """A failure on a rank > 0 is written to stderr at once, with its traceback: that rank's
    terminal report goes to its log file and is printed only at the end of its session, which
    never comes when rank 0 then waits in a collective the failed rank has left (mpirun stops at
    dev.sh's GEARFEM_MPI_TEST_TIMEOUT, and the failure would be lost)."""
    rank = MPI.COMM_WORLD.rank
    if rank > 0 and report.failed:
        sys.__stderr__.write(
            f"\n[rank {rank}] FAILED {report.nodeid} ({report.when}):\n{report.longreprtext}\n"
        )
        sys.__stderr__.flush()


@pytest.fixture
def comm() -> MPI.Comm:
    return MPI.COMM_WORLD


@pytest.fixture
def comms() -> tuple[MPI.Comm, MPI.Comm]:
    """(serial, world): compute with both and compare to check 1 vs N ranks in one run."""
    return MPI.COMM_SELF, MPI.COMM_WORLD


@pytest.fixture
def distinct_comms() -> tuple[MPI.Comm, ...]:
    """The communicators a 1-vs-N-ranks test computes with, each once: (serial, world) under
    mpirun, (serial,) on one rank, where the world is the serial one (a test that loops over
    them then compares its first and last results)."""
    return (MPI.COMM_SELF, MPI.COMM_WORLD) if MPI.COMM_WORLD.size > 1 else (MPI.COMM_SELF,)


@pytest.fixture
def tmp_out(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A temporary directory shared by all ranks (rank 0 creates it and broadcasts the name)."""
    comm = MPI.COMM_WORLD
    path = str(tmp_path_factory.mktemp("out")) if comm.rank == 0 else None
    return Path(comm.bcast(path, root=0))
