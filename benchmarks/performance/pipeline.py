"""End-to-end benchmark: per-stage wall time and memory of one operating point, then one more speed.

Runs the whole chain (:func:`gearfem.pipeline.run`) for a case (default: the built-in thesis case,
1000 rpm / 8 N m, 8000 s) with an empty cycle cache, then the same torque at a second speed (the
cycle is now a cache hit: only the thermal stage and baselines run). Prints the stage wall times
(mesh + cycle, thermal incl. the steady-state solve, total), the P2 displacement and temperature
DOFs, and the peak resident memory (max over ranks and summed).

Usage:
    mpirun -n 2 python benchmarks/performance/pipeline.py  # the target configuration (2 cores)
    python benchmarks/performance/pipeline.py tests/cases/coarse.toml  # any case
    options: --second-speed-rpm N (default 2000), --out DIR (default: a temporary directory)

Targets (issue 7): one full operating point in under 15 minutes on 2 cores; each extra speed at a
cached torque in under 2 minutes. The machine's load average is printed: on a shared machine the
timings are only as good as the load allows.

Purpose: performance (one operating point end to end, then a cached torque).
Writes: no documentation block (prints its figures).
"""

from __future__ import annotations

import argparse
import os
import resource
import sys
import tempfile
import time
from pathlib import Path

from mpi4py import MPI

import gearfem  # noqa: F401  (must precede dolfinx/petsc4py)
from gearfem import pipeline
from gearfem.config import load_case


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("case", nargs="?", default=None)
    p.add_argument("--second-speed-rpm", type=float, default=2000.0)
    p.add_argument("--out", default=None)
    args = p.parse_args(argv)
    comm = MPI.COMM_WORLD
    load0 = os.getloadavg()[0]
    tmp = tempfile.mkdtemp(prefix="gearfem_bench_") if comm.rank == 0 else None
    tmp = Path(comm.bcast(tmp, root=0))
    out = Path(args.out) if args.out else tmp
    case = load_case(args.case)
    rows = []
    for label, c in (
        ("first point (cycle computed)", case),
        (
            f"{args.second_speed_rpm:g} rpm (cycle cached)",
            case.with_operating(speed_rpm=args.second_speed_rpm),
        ),
    ):
        t0 = time.perf_counter()
        s = pipeline.run(c, out / label.split()[0], comm, cache_dir=tmp / "cache", progress=False)
        wall = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
        kb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        rows.append(
            (
                label,
                s,
                wall,
                comm.allreduce(kb, op=MPI.MAX) / 1024,
                comm.allreduce(kb, op=MPI.SUM) / 1024,
            )
        )
    if comm.rank == 0:
        print(f"case: {case.name}; {comm.size} rank(s); {os.cpu_count()} CPUs")
        print(
            f"{'run':32} {'cycle s':>8} {'thermal s':>9} {'total s':>8} {'total min':>9} "
            f"{'T DOFs':>7} "
            f"{'mem max MB':>10} {'mem sum MB':>10} {'T_max C':>8}"
        )
        for label, s, wall, mx, tot in rows:
            w = s.wall_time_s
            print(
                f"{label:32} {w.get('cycle_s', 0.0):8.1f} {w['thermal_s']:9.1f} {wall:8.1f} "
                f"{wall / 60:9.2f} "
                f"{s['thermal']['dofs']:7d} {mx:10.0f} {tot:10.0f} "
                f"{s['headline']['max_surface_temperature_C']:8.1f}"
            )
        cyc = rows[0][1].get("cycle", {})
        if cyc:
            print(
                f"cycle: {cyc['positions']} positions, {cyc['info'].get('dofs', '?')} "
                f"displacement DOFs, "
                f"{cyc['newton_iterations']} Newton iterations, cycle "
                f"{cyc['cycle_wall_time_s']:.0f} s, "
                f"effective contact ratio {cyc['effective_contact_ratio']:.3f}, "
                f"max pressure {cyc['max_contact_pressure_MPa']:.1f} MPa"
            )
        print(
            f"load average (1 min): {load0:.2f} before, {os.getloadavg()[0]:.2f} after. Targets: "
            f"first point "
            "< 15 min, extra speed < 2 min on 2 cores"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
