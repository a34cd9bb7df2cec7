"""Hertz line contact of two elastic cylinders: finite element contact pressure against Hertz.

Two equal half-cylinders (radius R = 1 m, axis z) made of the same linear elastic material are
pressed together along their common generator in plane strain: the upper body's flat face is moved
down by the compression, the lower body's flat face is clamped, u_z = 0 on the front and back faces
of the slab. Both bodies are meshed separately (non-matching curved P2 tetrahedral meshes) and
coupled only by the contact interface of ``gearfem.contact`` (two-pass Gauss-point-to-surface with
segmentation; penalty or augmented Lagrangian; optional Coulomb friction in gross slip).

Hertz (Johnson, Contact Mechanics, §4.2) for the force per length P' that the FE model transmits:
half-width a = sqrt(4 P' R* / (π E*)), peak pressure p0 = 2 P' / (π a), pressure
p(x) = p0 sqrt(1 − x²/a²), with 1/R* = 2/R and 1/E* = 2 (1 − ν²)/E. With friction and elastically
similar bodies the shear traction does not change the pressure (Johnson §7.1), so the same
ellipse is the reference; the shear traction is then q = μ p.

Parameters (command-line options, defaults in brackets):
    --contact-size H       element size near the contact line, m [0.01, about a/3 at the default
    load]
    --compression D        downward displacement of the upper body's flat face, m [0.004: a ≈ 0.031
    m]
    --method M             contact enforcement: penalty | augmented_lagrangian
    [augmented_lagrangian]
    --penalty-factor F     penalty ε = F · E / h per slave facet (h: facet size), dimensionless [1]
    --friction MU          Coulomb friction coefficient, dimensionless [0]
    --sliding-speed V      speed of the upper body in +x that sets the slip direction (gross slip;
                           only the direction matters when V ≫ 1e-5 m/s), m/s [1]
    --youngs-modulus E     Young's modulus of both bodies, Pa [1]
    --poissons-ratio NU    Poisson's ratio of both bodies, dimensionless [0.3]
    --layers L             element layers through the slab thickness [1]
    --thickness T          slab thickness (z), m [2 H]
    --out DIR              output directory [results/demos/hertz_contact]

Outputs (in DIR; rank 0 writes the files, everything is computed on all ranks):
    hertz_pressure.png     FE pressure at the contact integration points (both passes) against the
                           Hertz ellipse, nondimensional (x/a, p/p0), with the pointwise error
    hertz_pressure.csv     the points: pass, slave surface, undeformed and current position, gap,
                           pressure, traction, master normal, integration weight, and the Hertz
                           pressure at the same undeformed x
    hertz_contact.bp/      DOLFINx VTX facet fields contact_pressure and contact_traction (ParaView)
    summary.json           DOFs, ranks, Hertz and FE values and errors, Newton/Uzawa iterations,
                           factorizations, wall times, versions; written last (marks a complete run)

Run:
    python demos/hertz_contact.py
    mpirun -n 2 python demos/hertz_contact.py --out results/demos/hertz_contact_np2
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import json
import os
import shutil
import sys
import time
from pathlib import Path

import numpy as np
from mpi4py import MPI

import gearfem  # noqa: F401  (must precede dolfinx/petsc4py)
from gearfem.contact import ContactOptions, RigidMotion
from gearfem.contact.output import gather_points, summary, write_vtx
from gearfem.contact.verification import compare_hertz, hertz_case, hertz_pressure
from gearfem.core.provenance import versions

RADIUS_M = 1.0  # both cylinders (hertz_case geometry)
_METHOD_NAMES = {"penalty": "penalty", "augmented_lagrangian": "augmented Lagrangian"}


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(
        description=__doc__.splitlines()[0], formatter_class=argparse.ArgumentDefaultsHelpFormatter
    )
    p.add_argument(
        "--contact-size", type=float, default=0.01, help="element size near the contact, m"
    )
    p.add_argument(
        "--compression", type=float, default=0.004, help="displacement of the upper flat face, m"
    )
    p.add_argument(
        "--method", default="augmented_lagrangian", choices=("penalty", "augmented_lagrangian")
    )
    p.add_argument("--penalty-factor", type=float, default=1.0, help="ε h / E, dimensionless")
    p.add_argument("--friction", type=float, default=0.0, help="Coulomb coefficient μ")
    p.add_argument("--sliding-speed", type=float, default=1.0, help="upper body speed in +x, m/s")
    p.add_argument("--youngs-modulus", type=float, default=1.0, help="E of both bodies, Pa")
    p.add_argument("--poissons-ratio", type=float, default=0.3, help="ν of both bodies")
    p.add_argument("--layers", type=int, default=1, help="element layers through the thickness")
    p.add_argument("--thickness", type=float, default=None, help="slab thickness, m (default 2 H)")
    p.add_argument(
        "--out", type=Path, default=Path("results/demos/hertz_contact"), help="output directory"
    )
    return p.parse_args(argv)


def plot_pressure(path: Path, table, cmp, info: dict) -> None:
    """FE pressure at the integration points against Hertz (rank 0 only: no MPI in here)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    a, p0 = cmp.a_analytic_m, cmp.p0_analytic_Pa
    xa = table.x_reference[:, 0] / a  # Hertz's theory is small-strain: positions before deformation
    view = np.abs(xa) <= 1.5
    fig, (ax, ax_err) = plt.subplots(
        2, 1, figsize=(7.2, 6.6), sharex=True, height_ratios=(3, 1.25), constrained_layout=True
    )
    s = np.linspace(-1.5, 1.5, 1201)
    ax.plot(
        s,
        hertz_pressure(s, 1.0, 1.0),
        color="black",
        lw=1.6,
        label=r"Hertz $p_0\sqrt{1-x^2/a^2}$",
        zorder=3,
    )
    styles = [dict(marker="o", color="tab:blue"), dict(marker="^", color="tab:orange")]
    for k, name in enumerate(table.slaves):
        sel = view & (table.pass_index == k)
        ax.scatter(
            xa[sel],
            table.pressure[sel] / p0,
            s=11,
            alpha=0.55,
            lw=0,
            label=f"FE, slave: {name}",
            zorder=2,
            **styles[k],
        )
        err = (table.pressure[sel] - hertz_pressure(table.x_reference[sel, 0], a, p0)) / p0
        ax_err.scatter(xa[sel], 100.0 * err, s=9, alpha=0.55, lw=0, **styles[k])
    mu = info["friction_coefficient"]
    if mu > 0.0:
        q = np.linalg.norm(table.shear, axis=1)
        ax.scatter(
            xa[view], q[view] / p0, s=6, color="tab:green", alpha=0.5, lw=0, label=r"FE shear $|q|$"
        )
        ax.plot(
            s,
            mu * hertz_pressure(s, 1.0, 1.0),
            color="tab:green",
            lw=1.2,
            ls="--",
            label=r"$\mu\,p$ (Hertz)",
        )
    ax.axhline(0.0, color="0.6", lw=0.6)
    for v in (-1.0, 1.0):
        ax.axvline(v, color="0.6", lw=0.6, ls=":")
        ax_err.axvline(v, color="0.6", lw=0.6, ls=":")
    ax_err.axhline(0.0, color="0.6", lw=0.6)
    ax.set_xlim(-1.5, 1.5)
    ax.set_ylim(-0.05, 1.2)
    ax.set_ylabel(r"contact pressure $p / p_0$")
    ax_err.set_xlabel(r"position across the contact (undeformed) $x / a$")
    ax_err.set_ylabel(r"$(p - p_{\rm Hertz}) / p_0$  [%]")
    top = ax.secondary_xaxis("top", functions=(lambda u: u * a * 1e3, lambda v: v / (a * 1e3)))
    top.set_xlabel("x [mm]")
    right = ax.secondary_yaxis("right", functions=(lambda u: u * p0, lambda v: v / p0))
    right.set_ylabel("p [Pa]")
    ranks = f"{info['ranks']} rank{'s' if info['ranks'] > 1 else ''}"
    ax.set_title(
        f"Hertz line contact, {info['dofs']:,} DOFs on {ranks}: "
        f"$p_0$ {100 * cmp.p0_error:+.2f} %, $a$ {100 * cmp.a_error:+.2f} %",
        fontsize=10.5,
    )
    txt = (
        f"R = {RADIUS_M:g} m (both), E = {info['youngs_modulus_Pa']:g} Pa, ν = "
        f"{info['poissons_ratio']:g}\n"
        f"P' = {cmp.force_per_length_N_m:.4g} N/m → a = {a * 1e3:.3f} mm, $p_0$ = {p0:.4g} Pa\n"
        f"h = {info['contact_size_m'] * 1e3:g} mm = a/{a / info['contact_size_m']:.1f}, "
        f"{_METHOD_NAMES[info['method']]}, μ = {mu:g}\n"
        f"a from pressure moments; ellipse fit: {100 * (cmp.a_fit_m / a - 1):+.2f} %\n"
        f"x: undeformed position of the integration points"
    )
    ax.text(
        0.015,
        0.975,
        txt,
        transform=ax.transAxes,
        va="top",
        ha="left",
        fontsize=8,
        bbox=dict(boxstyle="round", fc="white", ec="0.8", alpha=0.9),
    )
    ax.legend(loc="upper right", fontsize=8, framealpha=0.9)
    tmp = path.with_name(f".{path.stem}.tmp{os.getpid()}{path.suffix}")
    fig.savefig(tmp, dpi=150)
    plt.close(fig)
    os.replace(tmp, path)


def write_csv(path: Path, table, cmp) -> None:
    """The integration points with the Hertz pressure at the same (undeformed) x (rank 0 only)."""
    a, p0 = cmp.a_analytic_m, cmp.p0_analytic_Pa
    ph = hertz_pressure(table.x_reference[:, 0], a, p0)
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    with open(tmp, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(
            [
                "pass",
                "slave_surface",
                "x_ref_m",
                "y_ref_m",
                "z_ref_m",
                "x_m",
                "y_m",
                "z_m",
                "x_ref_over_a",
                "gap_m",
                "pressure_Pa",
                "p_over_p0",
                "p_hertz_Pa",
                "traction_x_Pa",
                "traction_y_Pa",
                "traction_z_Pa",
                "normal_x",
                "normal_y",
                "normal_z",
                "weight_m2",
            ]
        )
        for i in range(table.num_points):
            k = int(table.pass_index[i])
            w.writerow(
                [
                    k,
                    table.slaves[k],
                    *(f"{v:.10e}" for v in table.x_reference[i]),
                    *(f"{v:.10e}" for v in table.x[i]),
                    f"{table.x_reference[i, 0] / a:.6f}",
                    f"{table.gap[i]:.6e}",
                    f"{table.pressure[i]:.10e}",
                    f"{table.pressure[i] / p0:.6f}",
                    f"{ph[i]:.10e}",
                    *(f"{v:.10e}" for v in table.traction[i]),
                    *(f"{v:.8f}" for v in table.normal[i]),
                    f"{table.weight[i]:.10e}",
                ]
            )
    os.replace(tmp, path)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    comm = MPI.COMM_WORLD
    rank = comm.rank
    out = args.out
    if rank == 0:
        out.mkdir(parents=True, exist_ok=True)
        (out / "summary.json").unlink(
            missing_ok=True
        )  # a stale marker must not survive a failed run
    comm.barrier()

    # --- problem: mesh, spaces, contact interface (all collective) -------------------------------
    t0 = time.perf_counter()
    options = ContactOptions(
        method=args.method,
        penalty_factor=args.penalty_factor,
        friction_coefficient=args.friction,
        search_distance_rel=2.0,
    )  # curved surfaces: search two facet sizes deep
    case = hertz_case(
        comm,
        options,
        contact_size=args.contact_size,
        compression_m=args.compression,
        radius=RADIUS_M,
        youngs_modulus_Pa=args.youngs_modulus,
        poissons_ratio=args.poissons_ratio,
        layers=args.layers,
        thickness_m=args.thickness,
    )
    problem = case.problem
    if args.friction > 0.0:  # gross slip: the upper body slides in +x (kinematic slip direction)
        problem.set_motion("upper", RigidMotion(velocity_m_s=(args.sliding_speed, 0.0, 0.0)))
    t_build = time.perf_counter() - t0

    # --- solve --------------------------------------------------------------------------------
    report = problem.solve("hertz")
    t_solve = report.wall_time_s

    # --- compare with Hertz, gather the points (collective) ---------------------------------------
    cmp = compare_hertz(case, radius=RADIUS_M)
    table = gather_points(problem)
    totals = summary(problem)
    pen_tol = (
        problem.interfaces[0].penetration_tolerance()
        if args.method == "augmented_lagrangian"
        else None
    )
    vtx_tmp = out / f".hertz_contact.bp.tmp{comm.bcast(os.getpid(), root=0)}"
    write_vtx(problem, vtx_tmp)
    ver = versions(comm)
    comm.barrier()

    # --- files (rank 0) -----------------------------------------------------------------------
    info = dict(
        dofs=case.num_dofs(),
        ranks=comm.size,
        contact_size_m=args.contact_size,
        youngs_modulus_Pa=args.youngs_modulus,
        poissons_ratio=args.poissons_ratio,
        method=args.method,
        friction_coefficient=args.friction,
    )
    if rank == 0:
        vtx = out / "hertz_contact.bp"
        if vtx.exists():
            shutil.rmtree(vtx)
        os.replace(vtx_tmp, vtx)
        png, csv_path = out / "hertz_pressure.png", out / "hertz_pressure.csv"
        plot_pressure(png, table, cmp, info)
        write_csv(csv_path, table, cmp)
        result = {
            "case": {
                "radius_m": RADIUS_M,
                "compression_m": args.compression,
                "layers": args.layers,
                "thickness_m": case.thickness_m,
                "contact_size_m": args.contact_size,
                "youngs_modulus_Pa": args.youngs_modulus,
                "poissons_ratio": args.poissons_ratio,
            },
            "contact_options": dataclasses.asdict(options),
            "sliding_speed_m_s": args.sliding_speed if args.friction > 0.0 else 0.0,
            "dofs": case.num_dofs(),
            "ranks": comm.size,
            "force_per_length_N_m": cmp.force_per_length_N_m,
            "hertz": {"a_m": cmp.a_analytic_m, "p0_Pa": cmp.p0_analytic_Pa},
            "fe": {
                "a_moments_m": cmp.a_fe_m,
                "a_fit_m": cmp.a_fit_m,
                "p0_Pa": cmp.p0_fe_Pa,
                "a_moments_current_positions_m": cmp.a_current_m,
            },
            "errors": {
                "p0": cmp.p0_error,
                "a_moments": cmp.a_error,
                "a_fit": cmp.a_fit_m / cmp.a_analytic_m - 1.0,
            },
            "a_over_h": cmp.a_analytic_m / args.contact_size,
            "solver": {
                "newton_iterations": report.newton_iterations,
                "uzawa_iterations": report.uzawa_iterations,
                "linear_solves": report.linear_solves,
                "factorizations": problem.factorizations,
                "residual_norm_N": report.residual_norm,
                "max_penetration_m": report.max_penetration_m,
                "constraint_penetration_m": report.constraint_penetration_m,
                "penetration_tolerance_m": pen_tol,
            },
            "contact": dataclasses.asdict(totals),
            "wall_time_s": {"build": t_build, "solve": t_solve, "total": time.perf_counter() - t0},
            "versions": ver,
        }
        tmp = out / f".summary.json.tmp{os.getpid()}"
        tmp.write_text(json.dumps(result, indent=2) + "\n")
        os.replace(tmp, out / "summary.json")  # last: marks a complete run
        print(
            f"Hertz line contact, {case.num_dofs()} DOFs on {comm.size} "
            f"rank{'s' if comm.size > 1 else ''}: "
            f"P' = {cmp.force_per_length_N_m:.5g} N/m, a = {cmp.a_analytic_m:.5g} m, "
            f"p0 = {cmp.p0_analytic_Pa:.5g} Pa"
        )
        print(
            f"  p0 error {100 * cmp.p0_error:+.2f} %, a error {100 * cmp.a_error:+.2f} % "
            f"(moments), "
            f"{100 * (cmp.a_fit_m / cmp.a_analytic_m - 1):+.2f} % (ellipse fit)"
        )
        print(
            f"  {report.newton_iterations} Newton, {report.uzawa_iterations} Uzawa iterations, "
            f"{problem.factorizations} factorizations; build {t_build:.1f} s, solve {t_solve:.1f} s"
        )
        print(f"wrote {png}, {csv_path}, {vtx}, {out / 'summary.json'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
