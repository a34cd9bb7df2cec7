"""Contact verification tables of docs/contact.md, measured: patch test, sliding block, augmented
Lagrangian against penalty, 1 vs 2 ranks, Hertz with friction.

Every number in these tables comes from a solve in this script (no value is typed into the page):
with ``--docs docs/contact.md`` rank 0 replaces the page's blocks ``contact_patch``,
``contact_sliding``, ``contact_al``, ``contact_ranks`` and ``hertz_friction`` between their
``<!-- gearfem:begin/end NAME -->`` markers (``gearfem.core.doctables.replace_block``), so a change
of the contact code shows up as a changed table in the diff.

The cases (``gearfem.contact.verification``):

* patch test: two unit blocks in uniaxial compression through a non-matching interface (lower
  h = 0.25, upper h = 0.17), penalty ε = 100 Pa/m, E = 1 Pa, δ = 1 mm: p = δ/(H/E + 1/ε) at every
  point; P2 tetrahedra and Q2 hexahedra on 1 and 2 ranks, and the tetrahedra rotated rigidly by
  30° about (1, 2, 3) (frame invariance; solved to 1e-12 of the force norm);
* sliding block: the lower block clamped, the upper one pressed down 1 mm and sliding in +x at
  1 m/s, μ = 0.3 (Coulomb gross slip): |t_T| = μ p at every point, t_T ⟂ n, opposing the slip, and
  the reaction at the held top face equal to the force the interface transmits;
* augmented Lagrangian against penalty: the Hertz case (h = 10 mm unless noted) with the soft
  default penalty alone, a 100× stiffer penalty, and the AL at two tolerances;
* 1 vs 2 ranks: the Hertz case at h = 14 mm on ``COMM_SELF`` and on ``COMM_WORLD``;
* Hertz with friction μ = 0.3 (the upper body sliding in +x): the peak pressure error and the
  scatter of the pointwise pressure about the ellipse inside |x| < 0.8a.

Usage (2 ranks; started serially it re-launches itself with ``mpirun -n 2``):
    python benchmarks/verification/contact_verification.py                      # print the tables
    python benchmarks/verification/contact_verification.py --docs docs/contact.md
    python benchmarks/verification/contact_verification.py --only patch ranks   # a subset

Purpose: verification (patch test, sliding, augmented Lagrangian, ranks, friction on Hertz).
Writes: blocks ``contact_patch``, ``contact_sliding``, ``contact_al``, ``contact_ranks`` and
``hertz_friction`` of docs/contact.md (``--docs docs/contact.md``).
"""

from __future__ import annotations

import argparse
import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

from mpi4py import MPI

import gearfem  # noqa: F401  (must precede dolfinx/petsc4py)

# isort: split
import numpy as np

from gearfem.contact import ContactOptions
from gearfem.contact.output import summary
from gearfem.contact.rigid import RigidMotion
from gearfem.contact.verification import block_case, compare_hertz, hertz_case, hertz_pressure
from gearfem.core.doctables import markdown_table, replace_block

SECTIONS = ("patch", "sliding", "al", "ranks", "friction")
BLOCKS = {
    "patch": "contact_patch",
    "sliding": "contact_sliding",
    "al": "contact_al",
    "ranks": "contact_ranks",
    "friction": "hertz_friction",
}
HERTZ_SIZE_M = 0.01  # the default Hertz mesh (a/3.1)
HERTZ = ContactOptions(search_distance_rel=2.0)  # as in tests/test_contact.py and the benchmark


def parse_args(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--docs", type=Path, default=None, help="Markdown page whose blocks to replace")
    p.add_argument("--only", nargs="+", choices=SECTIONS, default=list(SECTIONS))
    return p.parse_args(argv)


def _e(v: float, digits: int = 1) -> str:
    """Signed scientific notation with a real minus sign."""
    return f"{v:+.{digits}e}".replace("-", "−")


def _pct(v: float, digits: int = 2) -> str:
    return f"{100 * v:+.{digits}f} %".replace("-", "−")


# ------------------------------------------------------------------------------------------------
# patch test
# ------------------------------------------------------------------------------------------------

PATCH_DELTA_M, PATCH_E_PA, PATCH_EPS_PA_M, PATCH_HEIGHT_M = 1e-3, 1.0, 100.0, 1.0


def patch_row(comm: MPI.Comm, hexahedra: bool, angle_rad: float = 0.0) -> list:
    p_exact = PATCH_DELTA_M / (PATCH_HEIGHT_M / PATCH_E_PA + 1.0 / PATCH_EPS_PA_M)
    opts = ContactOptions(method="penalty", penalty_Pa_m=PATCH_EPS_PA_M)
    if angle_rad:
        opts = ContactOptions(
            method="penalty", penalty_Pa_m=PATCH_EPS_PA_M, newton_rtol=1e-12, newton_atol_N=0.0
        )
    case = block_case(
        comm,
        opts,
        compression_m=PATCH_DELTA_M,
        youngs_modulus_Pa=PATCH_E_PA,
        hexahedra=hexahedra,
        motion_angle_rad=angle_rad,
    )
    rep = case.problem.solve("patch")
    prob = case.problem
    on = [pts.pressure[pts.pressure > 0.0] for pts in prob.last_points[0]]
    dev = max((float(np.abs(p / p_exact - 1.0).max(initial=0.0)) for p in on), default=0.0)
    dev = comm.allreduce(dev, op=MPI.MAX)
    s = summary(prob)
    axis_z = prob.motions["lower"].R[:, 2]  # the lower block's (rotated) z axis
    fz = float(np.dot(s.normal_force_N, axis_z))
    mesh = "Q2 hexahedra (hex27)" if hexahedra else "P2 tetrahedra (tet10)"
    if angle_rad:
        mesh += f", rotated {math.degrees(angle_rad):.0f}° about (1, 2, 3)"
    return [
        mesh,
        comm.size,
        f"{case.num_dofs():,}".replace(",", " "),
        s.num_points_in_contact,
        f"{dev:.1e}",
        _e(fz / -p_exact - 1.0),
        _e(s.contact_area_m2 - 1.0),
        rep.newton_iterations,
    ]


def patch_table() -> str:
    world = MPI.COMM_WORLD
    rows = [
        patch_row(MPI.COMM_SELF, False),
        patch_row(world, False),
        patch_row(MPI.COMM_SELF, True),
        patch_row(world, True),
        patch_row(MPI.COMM_SELF, False, math.radians(30.0)),
    ]
    head = [
        "mesh",
        "ranks",
        "DOFs",
        "points in contact",
        "max \\|p/p_exact − 1\\|",
        "F_z / F_exact − 1",
        "contact area − 1 m²",
        "Newton",
    ]
    return markdown_table(head, rows)


# ------------------------------------------------------------------------------------------------
# sliding block
# ------------------------------------------------------------------------------------------------


def sliding_table() -> str:
    from dolfinx import fem

    mu = 0.3
    opts = ContactOptions(method="penalty", penalty_Pa_m=100.0, friction_coefficient=mu)
    comm = MPI.COMM_WORLD
    case = block_case(
        comm, opts, compression_m=1e-3, upper_velocity_m_s=(1.0, 0.0, 0.0), clamped=True
    )
    prob = case.problem
    rep = prob.solve("sliding")
    dev_mu = dev_n = 0.0
    worst_align = 1.0
    total_t = total_p = 0.0
    for ps, pts in zip(prob.interfaces[0].passes, prob.last_points[0]):
        on = pts.pressure > 0
        if not on.any():
            continue
        tt = (pts.traction - pts.pressure[:, None] * pts.normal)[on]
        mag = np.linalg.norm(tt, axis=1)
        dev_mu = max(dev_mu, float(np.abs(mag / (mu * pts.pressure[on]) - 1.0).max()))
        dev_n = max(dev_n, float((np.abs(np.einsum("pd,pd->p", tt, pts.normal[on])) / mag).max()))
        sign = -1.0 if ps.slave.body == "upper" else 1.0  # the slave's slip relative to the master
        worst_align = min(worst_align, float((sign * tt[:, 0] / mag).min()))
        total_t += float(np.sum(pts.dA[on] * mag))
        total_p += float(np.sum(pts.dA[on] * pts.pressure[on]))
    dev_mu = comm.allreduce(dev_mu, op=MPI.MAX)
    dev_n = comm.allreduce(dev_n, op=MPI.MAX)
    worst_align = comm.allreduce(worst_align, op=MPI.MIN)
    total_t = comm.allreduce(total_t, op=MPI.SUM)
    total_p = comm.allreduce(total_p, op=MPI.SUM)
    s = summary(prob)
    # equilibrium of the upper block, held only at its top: K u on the Dirichlet rows there
    V, md = prob.V, case.mesh_data
    top = md.facet_tags.find(md.physical_groups["upper_zmax"].tag)
    f = prob.K_full.createVecLeft()
    prob.K_full.mult(prob.u.x.petsc_vec, f)
    arr, n_owned = f.getArray(), V.dofmap.index_map.size_local * 3
    reaction = np.zeros(3)
    for c in range(3):
        dofs = fem.locate_dofs_topological(V.sub(c), 2, top)
        reaction[c] = arr[dofs[dofs < n_owned]].sum()
    f.destroy()
    reaction = comm.allreduce(reaction, op=MPI.SUM)
    on_lower = np.array(s.normal_force_N) + np.array(s.tangential_force_N)
    rows = [
        ["max over points of \\| \\|t_T\\| / (μ p) − 1 \\|", f"{dev_mu:.1e}", "0 (regularisation)"],
        ["max over points of \\|t_T · n\\| / \\|t_T\\|", f"{dev_n:.1e}", "0"],
        [
            "min over points of −t_T · ŝ / \\|t_T\\| (opposes the slip direction ŝ)",
            f"{worst_align:.12f}",
            "1",
        ],
        [
            "∫\\|t_T\\| dA / (μ ∫p dA) − 1",
            _e(total_t / (mu * total_p) - 1.0),
            "0",
        ],
        [
            "\\|reaction at the held top − force through the interface\\| / \\|force\\|",
            f"{np.linalg.norm(reaction - on_lower) / np.linalg.norm(on_lower):.1e}",
            "0",
        ],
        ["Newton iterations, ranks", f"{rep.newton_iterations}, {comm.size}", ""],
    ]
    return markdown_table(["quantity", "measured", "exact"], rows)


# ------------------------------------------------------------------------------------------------
# augmented Lagrangian against penalty
# ------------------------------------------------------------------------------------------------


def al_row(label: str, opts: ContactOptions, h: float) -> list:
    case = hertz_case(MPI.COMM_WORLD, opts, contact_size=h)
    rep = case.problem.solve(label)
    r = compare_hertz(case)
    return [
        label,
        f"{1e3 * h:g}",
        f"{r.force_per_length_N_m:.5e}",
        f"{rep.max_penetration_m:.1e}",
        rep.uzawa_iterations if opts.method == "augmented_lagrangian" else "–",
        rep.newton_iterations,
        _pct(r.p0_error),
        _pct(r.a_error),
    ]


def al_table() -> str:
    h = HERTZ_SIZE_M
    rows = [
        al_row(
            "penalty, factor 1 (ε = E/h)",
            ContactOptions(method="penalty", search_distance_rel=2.0),
            h,
        ),
        al_row(
            "penalty, factor 100",
            ContactOptions(method="penalty", penalty_factor=100.0, search_distance_rel=2.0),
            h,
        ),
        al_row("AL, tolerance 1 % h (default)", HERTZ, h),
        al_row(
            "AL, tolerance 0.1 % h",
            ContactOptions(search_distance_rel=2.0, penetration_tolerance_rel=1e-3),
            h,
        ),
        al_row(
            "AL, tolerance 0.1 % h",
            ContactOptions(search_distance_rel=2.0, penetration_tolerance_rel=1e-3),
            0.007,
        ),
    ]
    head = [
        "enforcement",
        "h (mm)",
        "P' (N/m)",
        "max penetration (m)",
        "Uzawa",
        "Newton",
        "p0 error",
        "a error",
    ]
    return markdown_table(head, rows)


# ------------------------------------------------------------------------------------------------
# 1 vs 2 ranks
# ------------------------------------------------------------------------------------------------


def ranks_table() -> str:
    out = []
    for comm in (MPI.COMM_SELF, MPI.COMM_WORLD):
        case = hertz_case(comm, HERTZ, contact_size=0.014)
        rep = case.problem.solve("hertz ranks")
        r = compare_hertz(case)
        out.append((comm.size, r, rep, case.problem.factorizations))
    (n1, r1, rep1, f1), (n2, r2, rep2, f2) = out

    def rel(a: float, b: float) -> str:
        return f"{abs(b / a - 1.0):.0e}"

    P1, P2 = r1.force_per_length_N_m, r2.force_per_length_N_m
    rows = [
        ["P' (N/m)", f"{P1:.10e}", f"{P2:.10e}", rel(P1, P2)],
        ["p0 (Pa)", f"{r1.p0_fe_Pa:.10e}", f"{r2.p0_fe_Pa:.10e}", rel(r1.p0_fe_Pa, r2.p0_fe_Pa)],
        ["a (m)", f"{r1.a_fe_m:.10e}", f"{r2.a_fe_m:.10e}", rel(r1.a_fe_m, r2.a_fe_m)],
        ["Newton iterations", rep1.newton_iterations, rep2.newton_iterations, ""],
        ["Uzawa iterations", rep1.uzawa_iterations, rep2.uzawa_iterations, ""],
        ["factorizations", f1, f2, ""],
    ]
    return markdown_table(
        ["Hertz, h = 14 mm", f"{n1} rank", f"{n2} ranks", "relative difference"], rows
    )


# ------------------------------------------------------------------------------------------------
# Hertz with friction
# ------------------------------------------------------------------------------------------------


def friction_row(h: float, mu: float) -> list:
    opts = ContactOptions(search_distance_rel=2.0, friction_coefficient=mu)
    case = hertz_case(MPI.COMM_WORLD, opts, contact_size=h)
    case.problem.set_motion("upper", RigidMotion(velocity_m_s=(1.0, 0.0, 0.0)))
    rep = case.problem.solve(f"hertz friction h={h}")
    r = compare_hertz(case)
    dev = (r.p_Pa - hertz_pressure(r.x_m, r.a_analytic_m, r.p0_analytic_Pa)) / r.p0_analytic_Pa
    inner = np.abs(r.x_m) < 0.8 * r.a_analytic_m
    return [
        f"{1e3 * h:g}",
        f"{mu:g}",
        rep.newton_iterations,
        rep.uzawa_iterations,
        _pct(r.p0_error),
        _pct(r.a_error),
        f"{100 * dev[inner].std():.1f} %",
        f"{100 * np.abs(dev[inner]).max():.1f} %",
    ]


def friction_table() -> str:
    rows = [friction_row(h, 0.3) for h in (0.014, 0.01, 0.007)]
    rows.append(friction_row(0.01, 0.1))
    head = [
        "h (mm)",
        "μ",
        "Newton",
        "Uzawa",
        "p0 error",
        "a error",
        "scatter (std, \\|x\\| < 0.8a)",
        "max \\|p − p_Hertz\\|/p0 (\\|x\\| < 0.8a)",
    ]
    return markdown_table(head, rows)


TABLES = {
    "patch": patch_table,
    "sliding": sliding_table,
    "al": al_table,
    "ranks": ranks_table,
    "friction": friction_table,
}


def _relaunch(argv: list[str]) -> int:
    local = Path(sys.executable).with_name("mpirun")
    mpirun = str(local) if local.is_file() else shutil.which("mpirun")
    if mpirun is None:
        sys.exit("this benchmark runs on 2 ranks and needs mpirun (next to Python or on PATH)")
    cmd = [mpirun, "-n", "2", sys.executable, str(Path(__file__).resolve()), *argv]
    print(f"$ {' '.join(cmd)}", flush=True)
    return subprocess.run(cmd, check=False).returncode


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    args = parse_args(argv)
    comm = MPI.COMM_WORLD
    if comm.size == 1:
        return _relaunch(argv)
    if comm.size != 2:
        sys.exit(f"run on 2 ranks (the 1 vs 2 ranks rows), not {comm.size}")
    for name in args.only:
        load0 = os.getloadavg()[0]
        table = TABLES[name]()
        load1 = os.getloadavg()[0]
        if comm.rank == 0:
            cmd = f"python benchmarks/verification/contact_verification.py --only {name}"
            text = f"{table}\n\n`{cmd}` (load average {load0:.1f} before, {load1:.1f} after)"
            print(f"\n{BLOCKS[name]}:\n{text}", flush=True)
            if args.docs is not None:
                replace_block(args.docs, BLOCKS[name], text)
        comm.barrier()
    if comm.rank == 0 and args.docs is not None:
        print(f"\nwrote blocks {', '.join(BLOCKS[n] for n in args.only)} of {args.docs}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
