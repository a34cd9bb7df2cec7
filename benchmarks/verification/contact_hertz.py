"""Hertz line contact benchmark: DOFs, iterations, factorizations, wall time and peak memory.

Two equal elastic half-cylinders (R = 1 m, E = 1 Pa, ν = 0.3) pressed together by 4 mm
(`gearfem.contact.verification.hertz_case`, augmented Lagrangian with the default contact options),
meshed as a 3D slab: ``--layers`` element layers of quadratic tetrahedra through the thickness, each
layer twice the contact element size thick (as in the 1-layer plane-strain slab; the solution does
not
vary along z, and the thicker layers keep the far-field cells, 0.2 m wide, from being flat).
Default:
contact size 0.0115 m (a/2.7), 3 layers, 0.069 m thick: 101 808 P2 displacement DOFs.

Usage:
    python benchmarks/verification/contact_hertz.py                   # the 3D case on 1 rank
    mpirun -n 2 python benchmarks/verification/contact_hertz.py       # ... on 2 ranks
    python benchmarks/verification/contact_hertz.py --ranks-both
        # re-launch with mpirun -n 1 and -n 2,
                                                         # both tables
    python benchmarks/verification/contact_hertz.py --refinement  # p0 and a errors vs contact size
    python benchmarks/verification/contact_hertz.py --refinement --docs docs/contact.md
    python benchmarks/verification/contact_hertz.py --ranks-both --docs docs/contact.md

With ``--docs PAGE`` the measured table replaces the page's block ``hertz_refinement``
(``--refinement``) or ``hertz_timing`` (``--ranks-both``) between its ``<!-- gearfem:begin/end -->``
markers (``gearfem.core.doctables.replace_block``): the page's numbers are this script's output.

Columns: DOFs; Newton iterations (all Uzawa steps); Uzawa (augmented Lagrangian) iterations; MUMPS
factorizations; linear (GMRES) solves; wall time of the mesh build, of the problem setup (spaces,
elastic matrices, contact surfaces) and of the contact solve (max over ranks), the CPU time of the
solve (process time of the busiest rank, all its threads; MPICH ranks poll while they wait, so on
2 ranks it includes waiting); peak resident memory
(``getrusage`` ru_maxrss, max over ranks and summed); errors of the peak pressure p0 and of the
half-width a (pressure moments over the undeformed positions) against Hertz for the force the
model carries. The machine's 1-minute load average before and after is printed: timings on a shared
machine are only as good as the load allows.

Purpose: verification (the contact solve against Hertz, under refinement) and its timing.
Writes: blocks ``hertz_refinement`` and ``hertz_timing`` of docs/contact.md
(``--docs docs/contact.md``).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from mpi4py import MPI

import gearfem  # noqa: F401  (must precede dolfinx/petsc4py)
from gearfem.contact import ContactOptions
from gearfem.contact.verification import compare_hertz, hertz_case, peak_pressure_bound
from gearfem.core.doctables import markdown_table, replace_block

REFINEMENT_SIZES = (0.014, 0.01, 0.007, 0.005)


def parse_args(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(
        description=__doc__.splitlines()[0], formatter_class=argparse.ArgumentDefaultsHelpFormatter
    )
    p.add_argument(
        "--contact-size", type=float, default=0.0115, help="element size near the contact, m"
    )
    p.add_argument(
        "--layers", type=int, default=None, help="element layers (default 3; 1 with --refinement)"
    )
    p.add_argument(
        "--thickness",
        type=float,
        default=None,
        help="slab thickness, m (default 2 · layers · size)",
    )
    p.add_argument(
        "--method", default="augmented_lagrangian", choices=("penalty", "augmented_lagrangian")
    )
    p.add_argument(
        "--max-krylov-its",
        type=int,
        default=ContactOptions.max_krylov_its,
        help="GMRES iterations on reused factors before refactoring",
    )
    p.add_argument(
        "--refactor-krylov-its",
        type=int,
        default=ContactOptions.refactor_krylov_its,
        help="GMRES iterations above which the factors are replaced at the next solve",
    )
    p.add_argument("--refinement", action="store_true", help="convergence table over --sizes")
    p.add_argument(
        "--sizes", type=float, nargs="+", default=list(REFINEMENT_SIZES), help="contact sizes, m"
    )
    p.add_argument("--ranks-both", action="store_true", help="run on 1 and on 2 ranks (via mpirun)")
    p.add_argument(
        "--json", type=Path, default=None, help="also write the results as JSON (rank 0)"
    )
    p.add_argument(
        "--docs",
        type=Path,
        default=None,
        help="Markdown page whose hertz_refinement / hertz_timing block to replace (rank 0)",
    )
    return p.parse_args(argv)


def _options(args) -> ContactOptions:
    return ContactOptions(
        method=args.method,
        search_distance_rel=2.0,
        max_krylov_its=args.max_krylov_its,
        refactor_krylov_its=args.refactor_krylov_its,
    )


def run_case(
    comm: MPI.Comm,
    options: ContactOptions,
    contact_size: float,
    layers: int,
    thickness: float | None,
) -> dict:
    """Build, solve and compare one Hertz case (collective); the same dict on every rank."""
    t = thickness if thickness is not None else 2.0 * layers * contact_size
    case = hertz_case(comm, options, contact_size=contact_size, layers=layers, thickness_m=t)
    cpu0 = time.process_time()
    rep = case.problem.solve(f"hertz h={contact_size}")
    cpu = time.process_time() - cpu0
    cmp = compare_hertz(case)
    rss_mib = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # Linux: KiB
    tmax = lambda v: comm.allreduce(v, op=MPI.MAX)
    return {
        "ranks": comm.size,
        "contact_size_m": contact_size,
        "layers": layers,
        "thickness_m": t,
        "dofs": case.num_dofs(),
        "a_over_h": cmp.a_analytic_m / contact_size,
        "newton": rep.newton_iterations,
        "uzawa": rep.uzawa_iterations,
        "factorizations": case.problem.factorizations,
        "linear_solves": rep.linear_solves,
        "mesh_s": tmax(case.timings_s["mesh"]),
        "setup_s": tmax(case.timings_s["setup"]),
        "solve_s": tmax(rep.wall_time_s),
        "solve_cpu_s": tmax(cpu),
        "rss_max_MiB": comm.allreduce(rss_mib, op=MPI.MAX),
        "rss_sum_MiB": comm.allreduce(rss_mib, op=MPI.SUM),
        "max_penetration_m": rep.max_penetration_m,
        "p0_error": cmp.p0_error,
        "a_error": cmp.a_error,
        "a_fit_error": cmp.a_fit_m / cmp.a_analytic_m - 1.0,
        "a_current_error": cmp.a_current_m / cmp.a_analytic_m - 1.0,
        "p0_bound": peak_pressure_bound(contact_size, cmp.a_analytic_m),
        "force_per_length_N_m": cmp.force_per_length_N_m,
    }


def format_timing(rows: list[dict]) -> str:
    head = (
        f"{'ranks':>5} {'DOFs':>8} {'Newton':>6} {'Uzawa':>5} {'fact.':>5} {'solves':>6} "
        f"{'mesh s':>7} "
        f"{'setup s':>7} {'solve s':>7} {'CPU s':>6} {'RSS max MiB':>11} {'RSS sum MiB':>11} "
        f"{'p0 err':>7} {'a err':>7}"
    )
    lines = [head, "-" * len(head)]
    for r in rows:
        lines.append(
            f"{r['ranks']:>5} {r['dofs']:>8} {r['newton']:>6} {r['uzawa']:>5} "
            f"{r['factorizations']:>5} "
            f"{r['linear_solves']:>6} {r['mesh_s']:>7.1f} {r['setup_s']:>7.1f} "
            f"{r['solve_s']:>7.1f} "
            f"{r['solve_cpu_s']:>6.1f} {r['rss_max_MiB']:>11.0f} {r['rss_sum_MiB']:>11.0f} "
            f"{100 * r['p0_error']:>+6.2f}% {100 * r['a_error']:>+6.2f}%"
        )
    return "\n".join(lines)


def format_refinement(rows: list[dict]) -> str:
    head = (
        f"{'ranks':>5} {'h mm':>6} {'a/h':>5} {'DOFs':>8} {'Newton':>6} {'Uzawa':>5} "
        f"{'p0 err':>8} {'order':>5} "
        f"{'a err':>8} {'order':>5} {'a fit':>8} {'a cur.':>8} {'solve s':>7}"
    )
    lines = [head, "-" * len(head)]
    prev = None
    for r in rows:
        if prev is not None and prev["ranks"] != r["ranks"]:
            prev = None  # orders within one run only

        def order(key):
            if prev is None or r[key] == 0 or prev[key] == 0 or prev[key] * r[key] < 0:
                return f"{'':>5}"
            ratio = math.log(abs(prev[key] / r[key]))
            return f"{ratio / math.log(prev['contact_size_m'] / r['contact_size_m']):>5.2f}"

        lines.append(
            f"{r['ranks']:>5} {1e3 * r['contact_size_m']:>6.1f} {r['a_over_h']:>5.2f} "
            f"{r['dofs']:>8} {r['newton']:>6} "
            f"{r['uzawa']:>5} {100 * r['p0_error']:>+7.2f}% {order('p0_error')} "
            f"{100 * r['a_error']:>+7.2f}% "
            f"{order('a_error')} {100 * r['a_fit_error']:>+7.2f}% "
            f"{100 * r['a_current_error']:>+7.2f}% "
            f"{r['solve_s']:>7.1f}"
        )
        prev = r
    return "\n".join(lines)


def _pct(v: float) -> str:
    return f"{100 * v:+.2f} %".replace("-", "−")


def _order(prev: dict | None, r: dict, key: str) -> str:
    """Observed order of |r[key]| between two refinement levels ('' when undefined)."""
    if prev is None or r[key] == 0 or prev[key] == 0 or prev[key] * r[key] < 0:
        return ""
    ratio = prev["contact_size_m"] / r["contact_size_m"]
    return f"{math.log(abs(prev[key] / r[key])) / math.log(ratio):.1f}"


def refinement_markdown(rows: list[dict], loads: list[float]) -> str:
    """The refinement table for docs/contact.md (block ``hertz_refinement``)."""
    body, prev = [], None
    for r in rows:
        body.append(
            [
                f"{1e3 * r['contact_size_m']:g}",
                f"{r['a_over_h']:.1f}",
                f"{r['dofs']:,}".replace(",", " "),
                r["newton"],
                r["uzawa"],
                _pct(r["p0_error"]),
                f"{100 * r['p0_bound']:.2f} %",
                _pct(r["a_error"]),
                _order(prev, r, "a_error"),
                _pct(r["a_fit_error"]),
                _pct(r["a_current_error"]),
            ]
        )
        prev = r
    head = [
        "h (mm)",
        "a/h",
        "DOFs",
        "Newton",
        "Uzawa",
        "p0 error",
        "bound (h/a)²/12",
        "a error",
        "a order",
        "a (ellipse fit)",
        "a from current x",
    ]
    ranks = rows[0]["ranks"] if rows else 1
    return (
        f"{markdown_table(head, body)}\n\n"
        "`python benchmarks/verification/contact_hertz.py --refinement` "
        f"({rows[0]['layers'] if rows else 1} layer, {ranks} rank{'s' if ranks > 1 else ''}, "
        f"load average {loads[0]:.1f} before, {loads[-1]:.1f} after)"
    )


def timing_markdown(rows: list[dict], loads: dict[int, list[float]]) -> str:
    """The 1 and 2 rank timing table for docs/contact.md (block ``hertz_timing``)."""
    body = []
    for r in rows:
        la = loads.get(r["ranks"], [float("nan")] * 2)
        body.append(
            [
                r["ranks"],
                f"{la[0]:.1f}–{la[-1]:.1f}",
                f"{r['dofs']:,}".replace(",", " "),
                r["newton"],
                r["uzawa"],
                r["factorizations"],
                r["linear_solves"],
                f"{r['mesh_s']:.1f}",
                f"{r['setup_s']:.1f}",
                f"{r['solve_s']:.1f}",
                f"{r['solve_cpu_s']:.1f}",
                f"{r['rss_max_MiB']:.0f} / {r['rss_sum_MiB']:.0f}",
                _pct(r["p0_error"]),
                _pct(r["a_error"]),
            ]
        )
    head = [
        "ranks",
        "load average",
        "DOFs",
        "Newton",
        "Uzawa",
        "factorizations",
        "linear solves",
        "mesh (s)",
        "setup (s)",
        "solve wall (s)",
        "solve CPU (s)",
        "peak RSS max / sum (MiB)",
        "p0 error",
        "a error",
    ]
    r0 = rows[0] if rows else {"layers": 3, "contact_size_m": 0.0115}
    return (
        f"{markdown_table(head, body)}\n\n"
        "`python benchmarks/verification/contact_hertz.py --ranks-both` "
        f"({r0['layers']} layers, h = {1e3 * r0['contact_size_m']:g} mm; load average before "
        "and after each run)"
    )


def _mpirun() -> str:
    local = Path(sys.executable).with_name("mpirun")
    found = str(local) if local.is_file() else shutil.which("mpirun")
    if found is None:
        sys.exit("--ranks-both needs mpirun (next to the Python interpreter or on PATH)")
    return found


def ranks_both(args, argv: list[str]) -> int:
    """Re-launch this script with mpirun -n 1 and -n 2; print both outputs and a combined table."""
    passthrough, skip = [], False
    for a in argv:  # the children measure; this process writes the page
        if skip:
            skip = False
        elif a == "--docs":
            skip = True
        elif a != "--ranks-both" and not a.startswith("--docs="):
            passthrough.append(a)
    rows, loads = [], {}
    with tempfile.TemporaryDirectory() as tmp:
        for n in (1, 2):
            out = Path(tmp) / f"np{n}.json"
            cmd = [
                _mpirun(),
                "-n",
                str(n),
                sys.executable,
                str(Path(__file__).resolve()),
                *passthrough,
                "--json",
                str(out),
            ]
            print(f"$ {' '.join(cmd)}", flush=True)
            proc = subprocess.run(cmd, check=False)
            if proc.returncode != 0:
                print(
                    f"run on {n} rank(s) failed with exit code {proc.returncode}", file=sys.stderr
                )
                return proc.returncode
            data = json.loads(out.read_text())
            rows += data["rows"]
            loads[n] = data["load_average"]
    print("\n1 and 2 ranks:")
    print(format_refinement(rows) if args.refinement else format_timing(rows))
    if args.docs is not None and not args.refinement:
        replace_block(args.docs, "hertz_timing", timing_markdown(rows, loads))
        print(f"wrote block hertz_timing of {args.docs}")
    if args.json:
        args.json.write_text(json.dumps({"rows": rows}, indent=2) + "\n")
    return 0


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    args = parse_args(argv)
    if args.ranks_both:
        if MPI.COMM_WORLD.size > 1:
            sys.exit("--ranks-both launches mpirun itself: run it serially")
        return ranks_both(args, argv)
    comm = MPI.COMM_WORLD
    options = _options(args)
    load0 = os.getloadavg()[0]
    rows = []
    if args.refinement:
        layers = args.layers or 1
        for h in args.sizes:
            rows.append(run_case(comm, options, h, layers, args.thickness))
            if comm.rank == 0:
                print(
                    f"  h = {h} m: {rows[-1]['dofs']} DOFs, solve {rows[-1]['solve_s']:.1f} s",
                    flush=True,
                )
    else:
        rows.append(run_case(comm, options, args.contact_size, args.layers or 3, args.thickness))
    load1 = os.getloadavg()[0]
    if comm.rank == 0:
        r = rows[-1]
        print(
            f"Hertz line contact, {'refinement' if args.refinement else '3D slab'}: "
            f"{r['layers']} layer(s), "
            f"{comm.size} rank(s), {args.method}; load average {load0:.2f} before, {load1:.2f} "
            f"after"
        )
        print(format_refinement(rows) if args.refinement else format_timing(rows))
        if args.docs is not None and args.refinement:
            replace_block(args.docs, "hertz_refinement", refinement_markdown(rows, [load0, load1]))
            print(f"wrote block hertz_refinement of {args.docs}")
        if args.json:
            args.json.write_text(
                json.dumps({"rows": rows, "load_average": [load0, load1]}, indent=2) + "\n"
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
