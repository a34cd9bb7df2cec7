"""A rotationally periodic one-tooth thermal sector against the whole gear: the verification of
the tie behind ``[thermal_mesh] periodic_cuts`` (docs/thermal.md).

The heat problem of a 16-tooth gear with 40 W on the drive flanks (the case where adiabatic cut
faces are wrong), steady and after 600 s of heating, solved (1) on the whole gear, (2) on a
one-tooth sector with adiabatic cut faces and (3) on the same sector with its cut faces tied
(``periodic_cuts`` mesh, :mod:`gearfem.thermal.periodic`). Prints the monitored temperatures,
DOFs, unknowns, wall times and the largest difference to the whole gear (the test
``test_periodic_one_tooth_sector_equals_full_gear_for_drive_flank_heating`` asserts the ratio):

    python benchmarks/verification/periodic_sector.py
    mpirun -n 2 python benchmarks/verification/periodic_sector.py
    python benchmarks/verification/periodic_sector.py --element hex   # the all-hexahedral meshes

Purpose: verification (the periodic one-tooth sector against the whole gear).
Writes: no documentation block (prints; docs/thermal.md quotes it).
"""

import argparse
import dataclasses
import tempfile
import time

from mpi4py import MPI

import gearfem  # noqa: F401  (must precede dolfinx/petsc4py)

# isort: split

from gearfem.core.materials import Material
from gearfem.geometry import GearPairGeometry, MeshOptions, build_gear_mesh
from gearfem.thermal import (
    PrescribedSources,
    ThermalBoundary,
    ThermalDomain,
    ThermalOptions,
    ThermalProblem,
)
from gearfem.thermal.lumped import gear_radii
from gearfem.thermal.source_terms import prescribed_heat_sources

comm = MPI.COMM_WORLD
CACHE = comm.bcast(tempfile.mkdtemp(prefix="periodic_sector_meshes_") if comm.rank == 0 else None)
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


def problem(gm, prefix, periodic, **opts):
    dom = ThermalDomain.from_gear_mesh(gm, "pinion", flux_flanks="drive")
    if not periodic:
        dom = dataclasses.replace(dom, periodic=None)
    mat = Material()
    o = ThermalOptions(degree=2, **opts)
    prof = gm.pair.profile("pinion")
    bnd = ThermalBoundary.from_options(o, mat, 1000.0, gear_radii(prof))
    src = prescribed_heat_sources(
        PrescribedSources(flank_heat_per_gear_W=40.0, flanks="drive"), dom, mat, 1000.0, prof.teeth
    )
    return ThermalProblem(dom, mat, src, bnd, o, petsc_options_prefix=prefix)


KEYS = (
    "max_surface",
    "mean_bulk",
    "flank_mean",
    "flank_max",
    "coast_flank_mean",
    "root_mean",
    "tip_mean",
)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--element", choices=("tet", "hex"), default="tet")
    coarse = dataclasses.replace(COARSE, element=p.parse_args().element)
    full = build_gear_mesh(
        g, dataclasses.replace(coarse, teeth_in_model=16), comm, cache_dir=CACHE, bodies=("pinion",)
    )
    opts1 = dataclasses.replace(coarse, teeth_in_model=1, periodic_cuts=True)
    sec = build_gear_mesh(g, opts1, comm, cache_dir=CACHE, bodies=("pinion",))
    for mode in ("steady", "transient"):
        out = {}
        opts = {"mode": "steady"} if mode == "steady" else {"duration_s": 600.0}
        for name, gm, tied in (
            ("full", full, False),
            ("adiabatic", sec, False),
            ("periodic", sec, True),
        ):
            t = time.perf_counter()
            with problem(gm, f"{name}_{mode}_", tied, **opts) as p:
                rec = p.solve_steady() if mode == "steady" else p.integrate()[-1]
                out[name] = (rec.temperatures_K, p.num_dofs, p.num_unknowns)
            out[name] += (time.perf_counter() - t,)
        if comm.rank:
            continue
        print(f"{mode} ({comm.size} rank(s)), C:")
        for name, (T, n, u, w) in out.items():
            print(
                f"  {name:10s} dofs {n:6d} unknowns {u:6d} {w:6.1f} s  "
                + "  ".join(f"{k} {T[k] - 273.15:.3f}" for k in KEYS)
            )
        for name in ("adiabatic", "periodic"):
            d = max(abs(out[name][0][k] - out["full"][0][k]) for k in KEYS)
            print(f"  {name} max |difference| to the whole gear: {d:.3f} K")


if __name__ == "__main__":
    main()
