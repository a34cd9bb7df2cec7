"""A rotationally periodic one-tooth thermal sector against the whole gear: the measurement
behind the plan of docs/refinement.md, "Where the thermal run's time goes" (stop 37).

A prototype, not the model: the steady heat problem of a 16-tooth gear with 40 W on the drive
flanks (the case where adiabatic cut faces are wrong), solved (1) on the whole gear, (2) on a
one-tooth sector with adiabatic cut faces and (3) on the same sector with its cut faces tied
(``periodic_cuts`` mesh; the DOFs of cut_end are slaves of those of cut_start turned by the
sector's angle; Newton on P^T F with P^T J P, 1 on the slaves' diagonal, dx = P y, serial LU).
Prints the monitored temperatures, DOFs, wall times and the largest difference to the whole
gear. One rank (the tie is serial here):

    python benchmarks/periodic_sector.py
"""

import dataclasses
import tempfile
import time

from mpi4py import MPI

import gearfem  # noqa: F401  (must precede dolfinx/petsc4py)

# isort: split
import numpy as np
from dolfinx import fem
from petsc4py import PETSc
from scipy.spatial import cKDTree

from gearfem.core.materials import Material
from gearfem.geometry import GearPairGeometry, MeshOptions, build_gear_mesh
from gearfem.geometry.placement import placement
from gearfem.instruments.scene import rotate_xy
from gearfem.thermal import (
    PrescribedSources,
    ThermalBoundary,
    ThermalDomain,
    ThermalOptions,
    ThermalProblem,
)
from gearfem.thermal.lumped import gear_radii
from gearfem.thermal.source_terms import prescribed_heat_sources

comm = MPI.COMM_SELF
CACHE = tempfile.mkdtemp(prefix="periodic_sector_meshes_")
COARSE = MeshOptions(
    size_flank_mm=0.3,
    size_tip_mm=0.3,
    size_root_mm=0.3,
    size_tooth_mm=0.8,
    size_body_mm=3.0,
    layers=2,
    refined_teeth=0,
)
g = GearPairGeometry(teeth_pinion=16, teeth_wheel=16, bore_radius_mm=8.0)


def problem(gm, prefix, degree=2):
    dom = ThermalDomain.from_gear_mesh(gm, "pinion", flux_flanks="drive")
    mat = Material()
    o = ThermalOptions(degree=degree, mode="steady")
    prof = gm.pair.profile("pinion")
    bnd = ThermalBoundary.from_options(o, mat, 1000.0, gear_radii(prof))
    src = prescribed_heat_sources(
        PrescribedSources(flank_heat_per_gear_W=40.0, flanks="drive"), dom, mat, 1000.0, prof.teeth
    )
    return ThermalProblem(dom, mat, src, bnd, o, petsc_options_prefix=prefix)


def main() -> None:
    out = {}
    full = build_gear_mesh(
        g, dataclasses.replace(COARSE, teeth_in_model=16), comm, cache_dir=CACHE, bodies=("pinion",)
    )
    t = time.perf_counter()
    with problem(full, "full_") as p:
        out["full"] = (p.solve_steady().temperatures_K, p.num_dofs, time.perf_counter() - t)

    opts1 = dataclasses.replace(COARSE, teeth_in_model=1, periodic_cuts=True)
    sec = build_gear_mesh(g, opts1, comm, cache_dir=CACHE, bodies=("pinion",))
    t = time.perf_counter()
    with problem(sec, "adi_") as p:
        out["adiabatic"] = (p.solve_steady().temperatures_K, p.num_dofs, time.perf_counter() - t)

    t = time.perf_counter()
    with problem(sec, "per_") as p:
        V = p.V
        dom = p.domain
        fdim = 2

        def dofs(kind):
            f = dom.facets((f"pinion_{kind}",))
            return fem.locate_dofs_topological(V, fdim, f)

        place = placement(sec.pair, opts1, "pinion")
        t0, t1 = place.sector_rad
        X = V.tabulate_dof_coordinates()
        ds_, de = dofs("cut_start"), dofs("cut_end")
        turned = rotate_xy(X[ds_], place.center_m, t1 - t0)
        dist, idx = cKDTree(X[de]).query(turned)
        assert dist.max() < 1e-10, dist.max()
        master, slave = ds_, de[idx]
        N = V.dofmap.index_map.size_global
        P = PETSc.Mat().createAIJ([N, N], nnz=1, comm=comm)
        is_slave = np.zeros(N, bool)
        is_slave[slave] = True
        m_of = np.arange(N)
        m_of[slave] = master
        for i in range(N):
            P.setValue(i, int(m_of[i]), 1.0)
        P.assemble()
        # steady Newton on the reduced system
        p.T.x.array[:] = p.initial_K
        for it in range(30):
            J, F = p.steady_system()
            r = F.duplicate()
            P.multTranspose(F, r)
            norm = r.norm()
            if it == 0:
                n0 = norm
            if norm < 1e-10 * n0:
                break
            A = J.PtAP(P)
            d = A.getDiagonal()
            d.array[is_slave] = 1.0
            A.setDiagonal(d)
            ksp = PETSc.KSP().create(comm)
            ksp.setOperators(A)
            ksp.setType("preonly")
            ksp.getPC().setType("lu")
            y = r.duplicate()
            ksp.solve(r, y)
            dx = r.duplicate()
            P.mult(y, dx)
            p.T.x.array[:] -= dx.array
            p.T.x.scatter_forward()
            ksp.destroy()
            A.destroy()
        print("periodic Newton its", it, "residual", norm / n0)
        p.steady_system()
        out["periodic"] = (p.temperatures_K(), p.num_dofs, time.perf_counter() - t)
        print("max |T_slave - T_master|", np.abs(p.T.x.array[slave] - p.T.x.array[master]).max())
    keys = (
        "max_surface",
        "mean_bulk",
        "flank_mean",
        "flank_max",
        "coast_flank_mean",
        "root_mean",
        "tip_mean",
    )
    for name, (T, n, w) in out.items():
        print(
            f"{name:10s} dofs {n:7d} {w:6.1f} s  "
            + "  ".join(f"{k} {T[k] - 273.15:.3f}" for k in keys)
        )
    for name in ("adiabatic", "periodic"):
        print(
            name, "max |diff| vs full:", max(abs(out[name][0][k] - out["full"][0][k]) for k in keys)
        )


if __name__ == "__main__":
    main()
