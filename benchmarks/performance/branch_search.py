"""What the search for the steady state a run from ambient reaches costs, solve by solve.

A diagnosis's evaluation of a friction law whose heat may rise with temperature (the glass step)
finds the state a run from ambient ends on by continuation in the friction heat
(gearfem.thermal.branches.lowest_steady_state): probes along the lowest branch, a start above
the fold when the branch ends, and a check from ambient. This script evaluates the built-in case
with the glass-transition law at the bench points, one glassy mu after another (the diagnosis's
full model, with the bench data's instruments), times every steady solve and prints, per rank
(each gear's thermal model runs on a rank of its own) and per kind of solve, how many converged
and failed, their seconds, and the most Newton iterations and the smallest line-search step any
converged solve took: the figures behind ``PROBE_EFFORT`` of gearfem.thermal.branches.

    mpirun -n 2 python benchmarks/performance/branch_search.py \
        --mu-glassy 0.10 0.12 0.13 0.14 0.16 0.2

With the structural cycles stored (GEARFEM_CACHE), 12 evaluations take about 3.5 min on 2 cores.

Purpose: performance (the branch search's steady solves, the probe effort's measurement).
Writes: no documentation block (prints its table).
"""

from __future__ import annotations

import argparse
import collections
import dataclasses
import time
import traceback
from importlib import resources
from pathlib import Path

import gearfem  # noqa: F401  (must precede dolfinx/petsc4py)

# isort: split

from mpi4py import MPI

from gearfem.config import load_case
from gearfem.core.errors import ConvergenceError
from gearfem.diagnose.data import read_csv
from gearfem.diagnose.forward import FullModel
from gearfem.thermal import newton, problem
from gearfem.thermal.branches import PROBE_EFFORT

BENCH = Path(str(resources.files("gearfem") / "data" / "testbench" / "thesis_testbench.csv"))
POINTS = ((1000.0, 8.0), (2000.0, 4.0))
#: The branch search's functions, innermost first: a solve is counted under the first of them on
#: its call stack.
KINDS = {
    "trace_lowest_branch": "probe on the lowest branch",
    "_lower_from_ambient": "check from ambient (and restore)",
    "_continued_lowest_state": "start above the fold, last solve",
    "steady_states": "branch report's starts",
    "_crossing": "branch report's crossings",
}


@dataclasses.dataclass
class Solve:
    kind: str
    converged: bool
    iterations: int
    smallest_step: float
    seconds: float


def instrument(log: list[Solve]) -> None:
    """Record every steady solve (its kind from the call stack, its outcome, iterations, the
    smallest line-search step accepted, its time)."""
    steady, try_step, accept = (
        problem.ThermalProblem.solve_steady,
        newton._ThermalSystem.try_step,
        newton._ThermalSystem.accept,
    )
    current = {"alpha": 1.0, "smallest": 1.0}

    def kind() -> str:
        names = [f.name for f in traceback.extract_stack()]
        return next((k for k in KINDS if k in names), "other")

    def timed_steady(self, *args, **kwargs):
        current["smallest"] = 1.0
        who, t0 = kind(), time.perf_counter()
        try:
            rec = steady(self, *args, **kwargs)
        except ConvergenceError as err:
            log.append(Solve(who, False, err.iteration or 0, 1.0, time.perf_counter() - t0))
            raise
        log.append(
            Solve(who, True, rec.newton_iterations, current["smallest"], time.perf_counter() - t0)
        )
        return rec

    def recorded_try(self, alpha):
        current["alpha"] = alpha
        return try_step(self, alpha)

    def recorded_accept(self):
        current["smallest"] = min(current["smallest"], current["alpha"])
        return accept(self)

    problem.ThermalProblem.solve_steady = timed_steady
    newton._ThermalSystem.try_step = recorded_try
    newton._ThermalSystem.accept = recorded_accept


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--mu-glassy", type=float, nargs="+", default=[0.10, 0.13, 0.16])
    args = p.parse_args()
    comm = MPI.COMM_WORLD
    log: list[Solve] = []
    instrument(log)
    data = read_csv(BENCH)
    quantities = tuple(dict.fromkeys(m.quantity for m in data.measurements))
    full = FullModel(load_case(None), comm, times_s=data.times, quantities=quantities)
    ambient = data.measurements[0].ambient_C
    full.evaluate(*POINTS[0], ambient, {})  # the cycles, forms and kept tables: not timed
    log.clear()
    t0 = time.perf_counter()
    for speed, torque in POINTS:
        for mu in args.mu_glassy:
            got = full.evaluate(speed, torque, ambient, {"friction_glass_transition": mu})
            if comm.rank == 0:
                cam = got[("camera_max", None)]
                print(f"{speed:6.0f} rpm {torque:4.1f} N m  mu_g {mu:.3f}: camera {cam:.3f} C")
    wall = time.perf_counter() - t0
    n = len(POINTS) * len(args.mu_glassy)
    for rank in range(comm.size):
        if comm.rank == rank:
            rows = collections.defaultdict(list)
            for s in log:
                rows[s.kind, s.converged].append(s)
            print(f"rank {rank}: {n} evaluations in {wall:.1f} s")
            print(
                "  kind                                 outcome  solves  seconds  max its  min step"
            )
            for (k, ok), ss in sorted(rows.items()):
                its = max(s.iterations for s in ss) if ok else "-"
                step = f"{min(s.smallest_step for s in ss):.3g}" if ok else "-"
                secs = sum(s.seconds for s in ss)
                label = KINDS.get(k, k)
                print(
                    f"  {label:36s} {'ok' if ok else 'failed':7s} {len(ss):7d} {secs:8.1f} "
                    f"{its!s:>8} {step:>9}"
                )
            print(f"  effort of a probe: {PROBE_EFFORT}", flush=True)
        comm.barrier()


if __name__ == "__main__":
    main()
