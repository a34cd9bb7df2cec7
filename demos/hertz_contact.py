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

# %% [markdown]
# # Hertz line contact, step by step
#
# This demo shows the contact API of gearfem on the classic verification problem: two elastic
# half-cylinders of radius R pressed together in plane strain. The steps are those of any
# two-body contact problem in gearfem:
#
# 1. a mesh with named volumes and facets (gmsh through ``gearfem.contact.verification``),
# 2. a quadratic vector function space and Dirichlet conditions (plain DOLFINx),
# 3. one :class:`~gearfem.contact.ContactSurface` per body (the facets that may touch),
# 4. a :class:`~gearfem.contact.ContactInterface` between them (penalty or augmented Lagrangian,
#    Coulomb friction),
# 5. a :class:`~gearfem.contact.ContactProblem` (elasticity + contact, Newton), solved,
# 6. the result compared with Hertz (Johnson, *Contact Mechanics*, §4.2):
#
# $$ a = \sqrt{\frac{4 P' R^*}{\pi E^*}}, \qquad p_0 = \frac{2 P'}{\pi a}, \qquad
#    p(x) = p_0 \sqrt{1 - x^2/a^2}, \qquad \frac{1}{R^*} = \frac{2}{R},\quad
#    \frac{1}{E^*} = \frac{2 (1 - \nu^2)}{E}. $$
#
# The contact traction on the slave surface is $t = p\,(n_m - \mu \hat s)$ with
# $p = \langle \lambda - \varepsilon g \rangle$ (gap $g$, penalty $\varepsilon$, multiplier
# $\lambda$ updated by Uzawa steps in the augmented Lagrangian method).

# %%
from __future__ import annotations

import argparse
import dataclasses
import json
import os
import shutil
import sys
import time
from pathlib import Path

import gearfem  # noqa: F401  (must precede dolfinx/petsc4py with the PyPI wheel)

# isort: split
import dolfinx
from dolfinx import fem
from mpi4py import MPI

from gearfem.contact import (
    ContactInterface,
    ContactOptions,
    ContactProblem,
    ContactSurface,
    RigidMotion,
    fixed_mask,
)
from gearfem.contact.output import gather_points, summary, write_vtx
from gearfem.contact.plots import plot_hertz_pressure, write_hertz_csv
from gearfem.contact.verification import ContactCase, compare_hertz, hertz_cylinders
from gearfem.core.provenance import versions

RADIUS_M = 1.0  # both cylinders


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


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    comm = MPI.COMM_WORLD
    rank = comm.rank
    out = args.out
    if rank == 0:
        out.mkdir(parents=True, exist_ok=True)
        (out / "summary.json").unlink(missing_ok=True)  # a stale marker must not survive a failure
    comm.barrier()
    t0 = time.perf_counter()

    # %% [markdown]
    # ## 1. Mesh
    # Two half-discs of radius R extruded over the slab thickness, meshed separately (curved P2
    # tetrahedra, non-matching at the contact), graded to ``contact_size`` near the contact line.
    # Named groups: volumes ``upper``/``lower``; facets ``{body}_flat``, ``{body}_curved``,
    # ``{body}_front``, ``{body}_back``.

    # %%
    thickness = args.thickness if args.thickness is not None else 2.0 * args.contact_size
    md = hertz_cylinders(
        comm,
        radius=RADIUS_M,
        thickness=thickness,
        contact_size=args.contact_size,
        far_size=0.2,
        refine_half_width=0.12 * RADIUS_M,
        layers=args.layers,
    )
    t_mesh = time.perf_counter() - t0

    # %% [markdown]
    # ## 2. Function space and supports
    # Quadratic Lagrange displacements. Plane strain: $u_z = 0$ on the front and back faces; the
    # lower flat face is clamped in the plane, the upper one moves down by the compression.

    # %%
    V = fem.functionspace(md.mesh, ("Lagrange", 2, (3,)))

    def component_bc(group: str, component: int, value: float):
        facets = md.facet_tags.find(md.physical_groups[group].tag)
        dofs = fem.locate_dofs_topological(V.sub(component), 2, facets)
        return fem.dirichletbc(dolfinx.default_scalar_type(value), dofs, V.sub(component))

    bcs = []
    for body in ("upper", "lower"):
        bcs += [component_bc(f"{body}_front", 2, 0.0), component_bc(f"{body}_back", 2, 0.0)]
    bcs += [component_bc("lower_flat", c, 0.0) for c in range(2)]
    bcs += [component_bc("upper_flat", 0, 0.0), component_bc("upper_flat", 1, -args.compression)]
    mask = fixed_mask(V, bcs)  # contact never acts on Dirichlet dofs

    # %% [markdown]
    # ## 3. Contact surfaces and interface
    # Each body's candidate contact facets; the interface pairs them (two-pass: each surface is
    # slave once), with the penalty $\varepsilon = F\,E/h$ per slave facet.

    # %%
    options = ContactOptions(
        method=args.method,
        penalty_factor=args.penalty_factor,
        friction_coefficient=args.friction,
        search_distance_rel=2.0,  # curved surfaces: search two facet sizes deep
    )

    def surface(group: str, body: str) -> ContactSurface:
        facets = md.facet_tags.find(md.physical_groups[group].tag)
        return ContactSurface(V, facets, body, mask, name=group)

    E, nu = args.youngs_modulus, args.poissons_ratio
    interface = ContactInterface(
        surface("lower_curved", "lower"),
        surface("upper_curved", "upper"),
        options,
        {"lower": E, "upper": E},
    )

    # %% [markdown]
    # ## 4. Contact problem
    # Linear elasticity (Lamé μ, λ) plus the contact residual, solved by Newton (and Uzawa passes
    # for the augmented Lagrangian). With friction the upper body slides in +x (gross slip): the
    # slip direction comes from the bodies' rigid velocities.

    # %%
    lame_mu, lame_lambda = E / (2 * (1 + nu)), E * nu / ((1 + nu) * (1 - 2 * nu))
    motions = {"lower": RigidMotion(), "upper": RigidMotion()}
    if args.friction > 0.0:
        motions["upper"] = RigidMotion(velocity_m_s=(args.sliding_speed, 0.0, 0.0))
    problem = ContactProblem(
        V,
        lame_mu,
        lame_lambda,
        bcs,
        [interface],
        motions,
        options,
        petsc_options_prefix="gearfem_hertz_",
    )
    case = ContactCase(problem, md, E, nu, thickness_m=thickness)
    t_build = time.perf_counter() - t0
    report = problem.solve("hertz")
    t_solve = report.wall_time_s

    # %% [markdown]
    # ## 5. Compare with Hertz
    # The force per length $P'$ the FE model carries sets Hertz's $a$ and $p_0$; the FE half-width
    # comes from the pressure moments $a = 2\sqrt{\int x^2 p\,dA / \int p\,dA}$ (exact for the
    # ellipse), positions taken in the undeformed configuration as in Hertz's theory.

    # %%
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

    # %% [markdown]
    # ## 6. Files
    # The picture and the table come from library helpers (:mod:`gearfem.contact.plots`);
    # ``summary.json`` is written last.

    # %%
    info = dict(
        dofs=case.num_dofs(),
        ranks=comm.size,
        contact_size_m=args.contact_size,
        youngs_modulus_Pa=args.youngs_modulus,
        poissons_ratio=args.poissons_ratio,
        method=args.method,
        friction_coefficient=args.friction,
        radius_m=RADIUS_M,
    )
    if rank == 0:
        vtx = out / "hertz_contact.bp"
        if vtx.exists():
            shutil.rmtree(vtx)
        os.replace(vtx_tmp, vtx)
        png, csv_path = out / "hertz_pressure.png", out / "hertz_pressure.csv"
        plot_hertz_pressure(png, table, cmp, info)
        write_hertz_csv(csv_path, table, cmp)
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
            "wall_time_s": {
                "mesh": t_mesh,
                "build": t_build,
                "solve": t_solve,
                "total": time.perf_counter() - t0,
            },
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
