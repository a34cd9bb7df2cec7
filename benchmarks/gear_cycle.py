"""Gear meshing-cycle benchmark: DOFs, positions, Newton iterations, wall time and peak memory.

The structural cycle solve of a case (default: the built-in thesis case, 8 of 30 teeth per gear, P2
tetrahedra, 1000 rpm / 8 N m, μ = 0.5, 24 positions per pitch plus the periodicity check) is run
without the cycle cache, so the figures are those of a real cycle solve.

Usage:
    python benchmarks/gear_cycle.py                      # the cycle on 1 rank
    mpirun -n 2 python benchmarks/gear_cycle.py          # ... on 2 ranks
    python benchmarks/gear_cycle.py --ranks-both         # re-launch with mpirun -n 1 and -n 2, both
    rows
    python benchmarks/gear_cycle.py --refinement         # max contact pressure at the pitch point
    vs mesh size

Columns: P2 displacement DOFs; positions solved; Newton iterations (sum over positions, all Uzawa
passes); wall time of the mesh (build or cache load + DOLFINx import), of the model setup and of the
cycle solve (max over ranks); peak resident memory (``getrusage`` ru_maxrss, max over ranks and
summed).
``--refinement`` solves the single position with the pitch point in mid-contact at the case mesh
scaled by the factors given (flank, tip, root and tooth element sizes; layers with --scale-layers)
and
prints the largest contact pressure in the middle half of the face width and its change against
the next finer mesh: the mesh is fine enough when that change is below 5 %. The machine's 1-minute
load average is printed: timings on a shared machine are only as good as the load allows.
Target (issue 5): the whole cycle in under 10 minutes on 2 cores. The thesis's ANSYS model of the
full pair took about 30 hours.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from mpi4py import MPI

import gearfem  # noqa: F401  (must precede dolfinx/petsc4py)
from gearfem import pipeline
from gearfem.config import load_case
from gearfem.cycle import GearContactModel, solve_cycle


def parse_args(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(
        description=__doc__.splitlines()[0], formatter_class=argparse.ArgumentDefaultsHelpFormatter
    )
    p.add_argument(
        "case", nargs="?", default=None, help="case TOML (default: the built-in thesis case)"
    )
    p.add_argument("--torque-Nm", type=float, default=8.0, help="torque, N m")
    p.add_argument(
        "--positions-per-pitch", type=int, default=None, help="override [cycle] positions_per_pitch"
    )
    p.add_argument(
        "--ranks-both", action="store_true", help="run on 1 and on 2 ranks (re-launches itself)"
    )
    p.add_argument(
        "--refinement", action="store_true", help="pitch-point pressure vs mesh size instead"
    )
    p.add_argument(
        "--factors",
        type=float,
        nargs="+",
        default=[1.5, 1.0, 0.7],
        help="mesh size factors for --refinement (coarse to fine; 1 = the case mesh)",
    )
    p.add_argument(
        "--scale-layers",
        action="store_true",
        help="with --refinement: also scale the number of layers across the face width",
    )
    p.add_argument("--json", default=None, help="(internal) write the row to this file")
    return p.parse_args(argv)


def _memory(comm) -> tuple[float, float]:
    kb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return comm.allreduce(kb, op=MPI.MAX) / 1024.0, comm.allreduce(kb, op=MPI.SUM) / 1024.0


def _case(args):
    case = load_case(args.case).with_operating(torque_Nm=args.torque_Nm)
    if args.positions_per_pitch is not None:
        case = dataclasses.replace(
            case,
            cycle=dataclasses.replace(case.cycle, positions_per_pitch=args.positions_per_pitch),
        )
    return case


def cycle_row(args) -> dict:
    comm = MPI.COMM_WORLD
    case = _case(args)
    t0 = time.perf_counter()
    gm = pipeline.pair_mesh(case, comm)
    t1 = time.perf_counter()
    model = GearContactModel(gm, case.materials, case.contact, case.operating.torque_Nm, case.cycle)
    t2 = time.perf_counter()
    res = solve_cycle(model)
    t3 = time.perf_counter()
    mx, tot = _memory(comm)
    wall = [comm.allreduce(v, op=MPI.MAX) for v in (t1 - t0, t2 - t1, t3 - t2)]
    extra = 1 if res.periodicity is not None else 0
    return {
        "ranks": comm.size,
        "dofs": model.V.dofmap.index_map.size_global * 3,
        "positions": len(res.phi_rad) + extra,
        "newton": int(np.sum(res.newton_iterations)),
        "mesh_s": wall[0],
        "setup_s": wall[1],
        "cycle_s": wall[2],
        "mem_max_MB": mx,
        "mem_sum_MB": tot,
        "p_max_MPa": float(np.max(res.p_max_Pa)) / 1e6,
        "eps_eff": res.effective_contact_ratio(),
        "te_um": float(np.mean(res.te_m)) * 1e6,
    }


def print_rows(rows) -> None:
    print(
        f"{'ranks':>5} {'DOFs':>8} {'pos':>4} {'Newton':>6} {'mesh s':>7} {'setup s':>7} "
        f"{'cycle s':>8} "
        f"{'cycle min':>9} {'mem max MB':>10} {'mem sum MB':>10} {'p_max MPa':>9} {'eps_eff':>7} "
        f"{'TE um':>6}"
    )
    for r in rows:
        print(
            f"{r['ranks']:5d} {r['dofs']:8d} {r['positions']:4d} {r['newton']:6d} "
            f"{r['mesh_s']:7.1f} "
            f"{r['setup_s']:7.1f} {r['cycle_s']:8.1f} {r['cycle_s'] / 60:9.2f} "
            f"{r['mem_max_MB']:10.0f} "
            f"{r['mem_sum_MB']:10.0f} {r['p_max_MPa']:9.2f} {r['eps_eff']:7.3f} {r['te_um']:6.1f}"
        )


def refinement(args) -> None:
    comm = MPI.COMM_WORLD
    base = _case(args)
    rows = []
    for f in args.factors:
        m = base.mesh
        mesh = dataclasses.replace(
            m,
            size_flank_mm=m.size_flank_mm * f,
            size_tip_mm=m.size_tip_mm * f,
            size_root_mm=m.size_root_mm * f,
            size_tooth_mm=m.size_tooth_mm * f,
            layers=max(1, round(m.layers / f)) if args.scale_layers else m.layers,
        )
        case = dataclasses.replace(base, mesh=mesh)
        t0 = time.perf_counter()
        model = GearContactModel(
            pipeline.pair_mesh(case, comm),
            case.materials,
            case.contact,
            case.operating.torque_Nm,
            case.cycle,
        )
        # the mesh as built: the reference teeth touch at the pitch point (mid-contact)
        model.solve_position(0.0, f"pitch point (mesh factor {f:g})")
        pts = model.problem.last_points[0]
        zmid = 0.5 * case.geometry.face_width_mm * 1e-3
        p_all = max((float(p.pressure.max()) for p in pts if p.num_points), default=0.0)
        p_mid = max(
            (
                float(p.pressure[np.abs(p.x[:, 2] - zmid) <= 0.5 * zmid].max(initial=0.0))
                for p in pts
                if p.num_points
            ),
            default=0.0,
        )
        rows.append(
            {
                "factor": f,
                "flank_mm": mesh.size_flank_mm,
                "layers": mesh.layers,
                "dofs": model.V.dofmap.index_map.size_global * 3,
                "p_mid_MPa": comm.allreduce(p_mid, op=MPI.MAX) / 1e6,
                "p_max_MPa": comm.allreduce(p_all, op=MPI.MAX) / 1e6,
                "te_um": model.transmission_error_m() * 1e6,
                "wall_s": comm.allreduce(time.perf_counter() - t0, op=MPI.MAX),
            }
        )
    if comm.rank == 0:
        print(
            f"pitch-point position, {base.operating.torque_Nm:g} N m, mu = "
            f"{base.contact.friction_coefficient:g}, "
            f"{comm.size} rank(s)"
        )
        print(
            f"{'factor':>6} {'flank mm':>8} {'layers':>6} {'DOFs':>8} {'p_mid MPa':>9} "
            f"{'change':>7} "
            f"{'p_max MPa':>9} {'change':>7} {'TE um':>6} {'wall s':>7}"
        )
        for i, r in enumerate(rows):
            nxt = rows[i + 1] if i + 1 < len(rows) else None
            c1 = f"{(r['p_mid_MPa'] / nxt['p_mid_MPa'] - 1) * 100:+6.2f}%" if nxt else "      -"
            c2 = f"{(r['p_max_MPa'] / nxt['p_max_MPa'] - 1) * 100:+6.2f}%" if nxt else "      -"
            print(
                f"{r['factor']:6.2f} {r['flank_mm']:8.3f} {r['layers']:6d} {r['dofs']:8d} "
                f"{r['p_mid_MPa']:9.2f} "
                f"{c1:>7} {r['p_max_MPa']:9.2f} {c2:>7} {r['te_um']:6.1f} {r['wall_s']:7.1f}"
            )
        print("change: relative to the next finer mesh")


def main(argv=None) -> int:
    args = parse_args(argv)
    comm = MPI.COMM_WORLD
    load0 = os.getloadavg()[0]
    if args.ranks_both:
        mpirun = Path(sys.executable).with_name("mpirun")
        rows = []
        with tempfile.TemporaryDirectory() as tmp:
            for n in (1, 2):
                out = Path(tmp) / f"row{n}.json"
                cmd = [
                    str(mpirun) if mpirun.exists() else "mpirun",
                    "-n",
                    str(n),
                    sys.executable,
                    __file__,
                    "--torque-Nm",
                    str(args.torque_Nm),
                    "--json",
                    str(out),
                ]
                if args.case:
                    cmd.insert(4, args.case)
                if args.positions_per_pitch:
                    cmd += ["--positions-per-pitch", str(args.positions_per_pitch)]
                subprocess.run(cmd, check=True)
                rows.append(json.loads(out.read_text()))
        print_rows(rows)
    elif args.refinement:
        refinement(args)
    else:
        row = cycle_row(args)
        if comm.rank == 0:
            if args.json:
                Path(args.json).write_text(json.dumps(row))
            else:
                print_rows([row])
    if comm.rank == 0:
        print(
            f"load average (1 min): {load0:.2f} before, {os.getloadavg()[0]:.2f} after; "
            f"{os.cpu_count()} CPUs; target: whole cycle < 10 min on 2 cores"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
