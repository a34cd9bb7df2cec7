"""Gear meshing-cycle benchmark: the cycle's wall time per torque with either contact solver, its
memory, and its agreement with a stored reference cycle.

The structural cycle of a case (default: the built-in thesis case, 8 of 30 teeth per gear, P2
tetrahedra, 8 N m, μ = 0.5, 12 positions per pitch plus the periodicity check) is solved without
the cycle cache, so the figures are those of a real cycle solve. With the condensed solver
(``[cycle] solver = "condensed"``) the first torque pays for the gears' condensation (MUMPS Schur
complements and their inverses), which a fresh compliance store receives; every further torque
takes the compliances from that store and pays only for the factorisations (for the volume field)
and the cycle itself.

Usage:
    python benchmarks/performance/gear_cycle.py  # the case's cycle on 1 rank
    mpirun -n 2 python benchmarks/performance/gear_cycle.py --torques 8 4
        # first torque, then a further one
    python benchmarks/performance/gear_cycle.py --ranks-both --torques 8 4
        # 1 and 2 ranks (re-launches)
    python benchmarks/performance/gear_cycle.py --ranks-both --torques 8 4 --write-docs
                                                             # ... and the table in docs/cycle.md
    mpirun -n 2 python benchmarks/performance/gear_cycle.py --solver full --save DIR
                                                             # the full solver's reference cycle
    python benchmarks/performance/gear_cycle.py --compare DIR_FULL DIR_CONDENSED [--write-docs]
                                                             # agreement of two stored cycles
    python benchmarks/performance/gear_cycle.py --refinement  # pitch-point pressure vs mesh size
    mpirun -n 2 python benchmarks/performance/gear_cycle.py --refinement --factors 1.5 1 0.7 0.5 \
        --write-docs
                                                             # ... and its table in docs/cycle.md

Columns: ranks; solver; torque; P2 DOFs; condensed DOFs (both gears); positions solved; Newton
iterations; wall time (max over ranks) of the mesh (cache load and DOLFINx import), of the model
set-up (spaces, stiffness, contact surfaces; with the condensed solver the factorisations and the
condensation or the store), of the cycle solve, and their sum; the CPU time of the cycle solve
(process time of the busiest rank: on a loaded machine it shows what a quiet one would take on 1
rank; MPICH ranks poll while they wait, so on 2 ranks it includes waiting); with the condensed
solver, rank 0's time in contact states (residual and tangent, incl. waiting for the other ranks'
points) and in Newton directions (of which forming and solving the active-set systems), and the
LU factorisations against the directions (the rest reuse the last LU); whether the
compliances came from the store; the dense compliance blocks held on rank 0 (MB); peak resident
memory (max over ranks, and summed); the mean transmission error and the effective contact ratio.
The machine has 2 cores shared with other developers: the 1-minute load average before and after
each run is printed beside the figures, which are only as good as the load allows.

Purpose: performance (the meshing cycle's time and memory), with the cycle's solver agreement
and the pitch-point pressure under contact-zone refinement as checks.
Writes: blocks ``cycle_benchmark``, ``cycle_solver_agreement`` and ``cycle_refinement`` of
docs/cycle.md (``--write-docs``).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import resource
import shutil
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
from gearfem.core.doctables import markdown_table, replace_block
from gearfem.cycle import GearContactModel, solve_cycle
from gearfem.cycle.cache import compliance_store, load, save

DOCS = Path(__file__).resolve().parents[2] / "docs" / "cycle.md"


def parse_args(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(
        description=__doc__.splitlines()[0], formatter_class=argparse.ArgumentDefaultsHelpFormatter
    )
    p.add_argument(
        "case", nargs="?", default=None, help="case TOML (default: the built-in thesis case)"
    )
    p.add_argument(
        "--torques",
        type=float,
        nargs="+",
        default=[8.0],
        help="torques, N m, solved one after the other (the first fills the compliance store)",
    )
    p.add_argument(
        "--solver", choices=("condensed", "full"), default=None, help="override [cycle] solver"
    )
    p.add_argument(
        "--positions-per-pitch", type=int, default=None, help="override [cycle] positions_per_pitch"
    )
    p.add_argument(
        "--store",
        default=None,
        help="compliance store directory (default: a fresh temporary one, so the first torque "
        "condenses)",
    )
    p.add_argument(
        "--ranks-both", action="store_true", help="run on 1 and on 2 ranks (re-launches itself)"
    )
    p.add_argument(
        "--save", default=None, help="store the (first torque's) cycle in this directory"
    )
    p.add_argument(
        "--compare",
        nargs=2,
        default=None,
        metavar=("REFERENCE", "OTHER"),
        help="compare two stored cycles (e.g. full and condensed) instead of solving",
    )
    p.add_argument(
        "--write-docs",
        action="store_true",
        help="write the table into docs/cycle.md (rank 0; with --refinement its own block)",
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
    p.add_argument("--json", default=None, help="(internal) write the rows to this file")
    return p.parse_args(argv)


def _memory(comm) -> tuple[float, float]:
    kb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return comm.allreduce(kb, op=MPI.MAX) / 1024.0, comm.allreduce(kb, op=MPI.SUM) / 1024.0


def _case(args, torque: float):
    case = load_case(args.case).with_operating(torque_Nm=torque)
    cyc = case.cycle
    if args.positions_per_pitch is not None:
        cyc = dataclasses.replace(cyc, positions_per_pitch=args.positions_per_pitch)
    if args.solver is not None:
        cyc = dataclasses.replace(cyc, solver=args.solver)
    return dataclasses.replace(case, cycle=cyc)


def cycle_rows(args) -> list[dict]:
    """One row per torque (collective)."""
    comm = MPI.COMM_WORLD
    tmp = None
    if args.store is not None:
        root = Path(args.store)
    else:
        tmp = tempfile.mkdtemp(prefix="gearfem-bench-store-") if comm.rank == 0 else None
        root = Path(comm.bcast(tmp, root=0))
    rows = []
    try:
        for i, torque in enumerate(args.torques):
            case = _case(args, torque)
            store = compliance_store(case.geometry, case.mesh, case.materials, root)
            load0 = os.getloadavg()[0]
            comm.barrier()
            t0 = time.perf_counter()
            gm = pipeline.pair_mesh(case, comm)
            t1 = time.perf_counter()
            model = GearContactModel(
                gm, case.materials, case.contact, torque, case.cycle, compliance_store=store
            )
            t2, c2 = time.perf_counter(), time.process_time()
            res = solve_cycle(model)
            t3, c3 = time.perf_counter(), time.process_time()
            mx, tot = _memory(comm)
            wall = [comm.allreduce(v, op=MPI.MAX) for v in (t1 - t0, t2 - t1, t3 - t2, t3 - t0)]
            info = res.info
            condensed = case.cycle.solver == "condensed"
            rows.append(
                {
                    "ranks": comm.size,
                    "solver": case.cycle.solver,
                    "torque_Nm": torque,
                    "dofs": info["dofs"],
                    "condensed_dofs": sum(info["condensed_dofs"].values()) if condensed else 0,
                    "positions": len(res.phi_rad) + (res.periodicity is not None),
                    "newton": int(np.sum(res.newton_iterations)),
                    "mesh_s": wall[0],
                    "setup_s": wall[1],
                    "cycle_s": wall[2],
                    "cycle_cpu_s": comm.allreduce(c3 - c2, op=MPI.MAX),
                    "total_s": wall[3],
                    "from_store": bool(condensed and all(info["compliance_from_store"].values())),
                    "condensation_s": info.get("condensation_s", 0.0),
                    "factorization_s": info.get("factorization_s", 0.0),
                    # the condensed Newton's parts (rank 0: it does the dense algebra)
                    "state_s": info.get("state_s", 0.0),
                    "direction_s": info.get("direction_s", 0.0),
                    "dense_solve_s": info.get("dense_solve_s", 0.0),
                    "lu": info.get("dense_factorizations", 0),
                    "directions": info.get("newton_directions", 0),
                    "compliance_MB": info.get("compliance_MB_root", 0.0),
                    "mem_max_MB": mx,
                    "mem_sum_MB": tot,
                    "te_um": float(np.mean(res.te_m)) * 1e6,
                    "eps_eff": res.effective_contact_ratio(),
                    "load_before": load0,
                    "load_after": os.getloadavg()[0],
                }
            )
            if i == 0 and args.save and comm.rank == 0:
                save(res, args.save)
            del model
    finally:
        if tmp is not None and comm.rank == 0:
            shutil.rmtree(tmp, ignore_errors=True)
    return rows


HEADERS = (
    "ranks",
    "solver",
    "torque",
    "DOFs",
    "condensed DOFs",
    "positions",
    "Newton",
    "mesh (s)",
    "set-up (s)",
    "cycle (s)",
    "cycle CPU (s)",
    "contact states / directions (dense solves) (s)",
    "LU / directions",
    "total (s)",
    "compliance",
    "C on rank 0 (MB)",
    "memory max / sum (MB)",
    "TE mean (µm)",
    "ε_eff",
    "load avg",
)


def table_rows(rows) -> list[list]:
    out = []
    for r in rows:
        if r["solver"] != "condensed":
            comp = "–"
        elif r["from_store"]:
            comp = "stored"
        else:
            comp = f"computed ({r['condensation_s']:.1f} s)"
        out.append(
            [
                r["ranks"],
                r["solver"],
                f"{r['torque_Nm']:g} N m",
                f"{r['dofs']:,}",
                f"{r['condensed_dofs']:,}" if r["condensed_dofs"] else "–",
                r["positions"],
                r["newton"],
                f"{r['mesh_s']:.1f}",
                f"{r['setup_s']:.1f}",
                f"{r['cycle_s']:.1f}",
                f"{r['cycle_cpu_s']:.1f}",
                f"{r['state_s']:.0f} / {r['direction_s']:.0f} ({r['dense_solve_s']:.0f})"
                if r["directions"]
                else "–",
                f"{r['lu']} / {r['directions']}" if r["directions"] else "–",
                f"**{r['total_s']:.1f}**",
                comp,
                f"{r['compliance_MB']:.0f}" if r["compliance_MB"] else "–",
                f"{r['mem_max_MB']:.0f} / {r['mem_sum_MB']:.0f}",
                f"{r['te_um']:.2f}",
                f"{r['eps_eff']:.3f}",
                f"{r['load_before']:.1f}–{r['load_after']:.1f}",
            ]
        )
    return out


def _relative(a: np.ndarray, b: np.ndarray) -> float:
    """Largest difference relative to the largest value of the reference."""
    scale = float(np.max(np.abs(a), initial=0.0))
    return float(np.max(np.abs(b - a), initial=0.0)) / scale if scale > 0 else 0.0


def compare(reference: str, other: str) -> list[list]:
    """Agreement of two stored cycles: (quantity, reference, other, difference) rows."""
    a, b = load(reference), load(other)
    total = sum(np.asarray(v) for v in a.tooth_load_N.values())
    load_dev = max(
        float(np.max(np.abs(b.tooth_load_N[k] - a.tooth_load_N[k]) / total)) for k in a.tooth_load_N
    )
    rows = [
        [
            "transmission error (every position)",
            f"{np.mean(a.te_m) * 1e6:.3f} µm mean",
            f"{np.mean(b.te_m) * 1e6:.3f} µm mean",
            f"{_relative(a.te_m, b.te_m):.1e}",
        ],
        [
            "normal load per tooth (every position and tooth, of the total)",
            f"{float(np.mean(total)):.1f} N total",
            "",
            f"{load_dev:.1e}",
        ],
        [
            "pitch-point pressure (middle half of the face)",
            f"{a.p_max_mid_Pa[0] / 1e6:.3f} MPa",
            f"{b.p_max_mid_Pa[0] / 1e6:.3f} MPa",
            f"{abs(b.p_max_mid_Pa[0] / a.p_max_mid_Pa[0] - 1):.1e}",
        ],
        [
            "friction power (every position)",
            f"{a.mean_friction_power_W_per_rad_s():.4f} W per rad/s mean",
            f"{b.mean_friction_power_W_per_rad_s():.4f} W per rad/s mean",
            f"{_relative(a.friction_power_W_per_rad_s, b.friction_power_W_per_rad_s):.1e}",
        ],
    ]
    for g in ("pinion", "wheel"):
        ua, ub = a.fields[g].u_max_J_m3, b.fields[g].u_max_J_m3
        rows.append(
            [
                f"U_max field, {g} (every cell of the sector)",
                f"{ua.max() / 1e3:.2f} kJ/m³ max",
                f"{ub.max() / 1e3:.2f} kJ/m³ max",
                f"{_relative(ua, ub):.1e}",
            ]
        )
    rows.append(
        [
            "effective contact ratio",
            f"{a.effective_contact_ratio():.3f}",
            f"{b.effective_contact_ratio():.3f}",
            "identical"
            if a.effective_contact_ratio() == b.effective_contact_ratio()
            else "differs",
        ]
    )
    rows.append(
        [
            "Newton iterations (sum)",
            f"{int(np.sum(a.newton_iterations))}",
            f"{int(np.sum(b.newton_iterations))}",
            "",
        ]
    )
    rows.append(
        ["cycle wall time", f"{np.sum(a.wall_time_s):.0f} s", f"{np.sum(b.wall_time_s):.0f} s", ""]
    )
    return rows


def refinement(args) -> None:
    comm = MPI.COMM_WORLD
    base = _case(args, args.torques[0])
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
    if comm.rank == 0 and args.write_docs:
        replace_block(DOCS, "cycle_refinement", refinement_markdown(args, base, rows, comm.size))
    if comm.rank == 0:
        print(
            f"pitch-point position, {base.operating.torque_Nm:g} N m, mu = "
            f"{base.contact.friction_coefficient:g}, {base.cycle.solver} solver, "
            f"{comm.size} rank(s)"
        )
        print(
            f"{'factor':>6} {'flank mm':>8} {'layers':>6} {'DOFs':>8} {'p_mid MPa':>9} "
            f"{'change':>7} {'p_max MPa':>9} {'change':>7} {'TE um':>6} {'wall s':>7}"
        )
        for i, r in enumerate(rows):
            nxt = rows[i + 1] if i + 1 < len(rows) else None
            c1 = f"{_change(r, nxt, 'p_mid_MPa'):+6.2f}%" if nxt else "      -"
            c2 = f"{_change(r, nxt, 'p_max_MPa'):+6.2f}%" if nxt else "      -"
            print(
                f"{r['factor']:6.2f} {r['flank_mm']:8.3f} {r['layers']:6d} {r['dofs']:8d} "
                f"{r['p_mid_MPa']:9.2f} {c1:>7} {r['p_max_MPa']:9.2f} {c2:>7} {r['te_um']:6.1f} "
                f"{r['wall_s']:7.1f}"
            )
        print("change: relative to the next finer mesh")


def _change(row: dict, finer: dict, key: str) -> float:
    """Relative change (%) of ``row[key]`` to the next finer mesh's."""
    return (row[key] / finer[key] - 1.0) * 100.0


def refinement_markdown(args, base, rows: list[dict], ranks: int) -> str:
    """The --refinement rows as the docs/cycle.md table (block ``cycle_refinement``)."""
    table = []
    for i, r in enumerate(rows):
        nxt = rows[i + 1] if i + 1 < len(rows) else None
        change = f"{_change(r, nxt, 'p_mid_MPa'):+.2f} %" if nxt else "–"
        label = f"{r['factor']:g}" + (" (the case)" if r["factor"] == 1.0 else "")
        table.append(
            (
                label,
                f"{r['flank_mm']:.3g} mm",
                r["layers"],
                f"{r['dofs']:,}",
                f"{r['p_mid_MPa']:.2f} MPa",
                change,
                f"{r['p_max_MPa']:.1f} MPa",
                f"{r['te_um']:.2f} µm",
                f"{r['wall_s']:.0f} s",
            )
        )
    head = (
        "mesh factor",
        "flank element",
        "layers",
        "P2 DOFs",
        "pitch-point pressure (mid face)",
        "change to next finer",
        "largest pressure",
        "TE",
        "wall",
    )
    cmd = (
        "mpirun -n 2 python benchmarks/performance/gear_cycle.py --refinement --write-docs "
        "--factors " + " ".join(f"{f:g}" for f in args.factors)
    )
    return (
        f"Pitch-point position of case '{base.name}', {base.operating.torque_Nm:g} N m, μ = "
        f"{base.contact.friction_coefficient:g}, {base.cycle.solver} solver; the case mesh's "
        "flank, tip, root and tooth element sizes scaled by the factor.\n\n"
        + markdown_table(head, table)
        + f"\n\n`{cmd}`: {ranks} ranks, 1-minute load average {os.getloadavg()[0]:.1f} at the end."
    )


def _relaunch(args) -> list[dict]:
    mpirun = Path(sys.executable).with_name("mpirun")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for n in (1, 2):
            out = Path(tmp) / f"rows{n}.json"
            cmd = [str(mpirun) if mpirun.exists() else "mpirun", "-n", str(n), sys.executable]
            cmd += [__file__, "--json", str(out), "--torques", *map(str, args.torques)]
            if args.case:
                cmd.append(args.case)
            if args.solver:
                cmd += ["--solver", args.solver]
            if args.positions_per_pitch:
                cmd += ["--positions-per-pitch", str(args.positions_per_pitch)]
            subprocess.run(cmd, check=True)
            rows += json.loads(out.read_text())
    return rows


def main(argv=None) -> int:
    args = parse_args(argv)
    comm = MPI.COMM_WORLD
    if args.compare:
        rows = compare(*args.compare)
        if comm.rank == 0:
            table = markdown_table(("quantity", "reference", "other", "difference"), rows)
            print(table)
            if args.write_docs:
                replace_block(DOCS, "cycle_solver_agreement", table)
        return 0
    if args.refinement:
        refinement(args)
        return 0
    rows = _relaunch(args) if args.ranks_both else cycle_rows(args)
    if comm.rank == 0:
        if args.json:
            Path(args.json).write_text(json.dumps(rows))
            return 0
        table = markdown_table(HEADERS, table_rows(rows))
        print(table)
        print(f"{os.cpu_count()} CPUs; targets: first torque <= 60 s, further torques <= 20 s")
        if args.write_docs:
            replace_block(DOCS, "cycle_benchmark", table)
    return 0


if __name__ == "__main__":
    sys.exit(main())
