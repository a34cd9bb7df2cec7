"""Graded element layers across the face width: the flank foot's contact next to the side faces,
and what it does to the hottest surface temperature.

The built-in case's hottest surface temperature sits at the pinion's flank foot (r = 28.63 mm),
where the mate's tip round enters, in the middle of the face width. Across the structural layers
it rose by 1.45 K from 2 to 10 equal layers in steps no power law fits (docs/refinement.md,
"Beyond 7 layers"). This solves the case at the layer settings asked for (``LAYERS`` or
``LAYERS:GRADING``, :class:`gearfem.geometry.options.MeshOptions` ``layer_grading``; the rest of
the case as built in) and prints, per setting:

* the layers' thickness at the side faces and in the middle, the structural DOFs and the cycle's
  time (cached cycles: "cached");
* the pinion's drive-flank friction flux as the cycle delivers it (revolution average, before any
  reconstruction; W/m² per rad/s of the pinion) in the band ``--band-radius-mm`` ±
  ``--band-halfwidth-mm`` (the hottest point's radius), per facet row across the face width: the
  two rows next to the side face z = 0, the mean of the rows in the middle half, and the first
  row's relief (its flux over the middle's);
* with the thermal runs a study level makes (:func:`gearfem.refinement.solve_level`: both gears,
  the camera): the field's surface maximum and where it is, the hottest node, ``camera_max``, the
  flank mean and the friction power.

    mpirun -n 2 python benchmarks/graded_layers.py [--settings 2 4 4:8 4:30] [--no-thermal]
        [--out results/graded_layers] [--docs]

About 7 min per 4-layer cycle and 6 min per setting's thermal runs on 2 cores. ``--docs``
replaces the block ``graded_layers`` of docs/refinement.md.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import time
from pathlib import Path

import numpy as np
from mpi4py import MPI

import gearfem  # noqa: F401  (must precede dolfinx/petsc4py)
from gearfem import pipeline
from gearfem.config import load_case
from gearfem.core.doctables import markdown_table, replace_block
from gearfem.geometry.extrude import layer_planes
from gearfem.refinement import solve_level

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "refinement.md"
BLOCK = "graded_layers"
#: The thermal quantities shown (:func:`gearfem.pipeline.reported_quantities`).
SHOWN = ("max_surface_field", "max_surface", "camera_max", "flank_mean", "friction_power_W")


def _setting(text: str) -> tuple[int, float | None]:
    layers, _, grading = text.partition(":")
    return int(layers), float(grading) if grading else None


def band_rows(fields, radius_m: float, halfwidth_m: float, face_width_m: float):
    """The drive flank's flux in the band ``radius_m ± halfwidth_m`` of the reference tooth per
    facet row (facets with the same centroid z): (row z from the front side face, area-weighted
    mean flux per row)."""
    rel = fields.facet_points_m - fields.center_m
    r = np.hypot(rel[:, 0], rel[:, 1])
    band = (fields.facet_kind == "drive_flank") & (np.abs(r - radius_m) <= halfwidth_m)
    if not np.any(band):
        raise SystemExit(f"no drive-flank facet within {halfwidth_m} m of r = {radius_m} m")
    q = fields.generated_flux_W_m2_per_rad_s[band]
    a = fields.facet_area_m2[band]
    z = np.round(rel[band, 2] / face_width_m, 9)  # rows: the same centroid z to round-off
    rows = np.unique(z)
    flux = np.array([np.sum(q[z == zz] * a[z == zz]) / np.sum(a[z == zz]) for zz in rows])
    return rows * face_width_m, flux


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument(
        "--settings",
        nargs="+",
        type=_setting,
        default=[(2, None), (4, None), (4, 8.0), (4, 30.0)],
        help="LAYERS or LAYERS:GRADING ([mesh] layers and layer_grading)",
    )
    p.add_argument("--band-radius-mm", type=float, default=28.634)
    p.add_argument("--band-halfwidth-mm", type=float, default=0.06)
    p.add_argument("--no-thermal", action="store_true", help="the cycles' flux only")
    p.add_argument("--out", default="results/graded_layers")
    p.add_argument("--docs", action="store_true")
    args = p.parse_args()
    comm = MPI.COMM_WORLD
    base = load_case(None)
    b_m = base.geometry.face_width_mm * 1e-3
    t0 = time.perf_counter()
    rows = []
    for layers, grading in args.settings:
        mesh = dataclasses.replace(base.mesh, layers=layers, layer_grading=grading)
        case = dataclasses.replace(base, mesh=mesh, thermal_mesh=base.thermal_mesh_options)
        label = f"{layers} " + (
            "equal" if case.mesh.layer_grading is None else f"graded {grading:g}"
        )
        t = np.diff(layer_planes(base.geometry.face_width_mm, layers, 1, case.mesh.layer_grading))
        tc = time.perf_counter()
        cyc, _, cached = pipeline.cycle(case, comm)
        t_cycle = time.perf_counter() - tc
        z, flux = band_rows(
            cyc.fields["pinion"], args.band_radius_mm * 1e-3, args.band_halfwidth_mm * 1e-3, b_m
        )
        middle = (z > 0.25 * b_m) & (z < 0.75 * b_m)
        mid = float(np.mean(flux[middle]))
        row = [
            label,
            f"{t[0]:.2f} / {t[len(t) // 2]:.2f}",
            str(int(cyc.info["dofs"])),
            "cached" if cached else f"{t_cycle:.0f}",
            " / ".join(f"{v:.0f}" for v in flux[:2]),
            f"{mid:.0f}",
            f"{flux[0] / mid:.3f}",
        ]
        if not args.no_thermal:
            out = Path(args.out) / f"layers{layers}_{'equal' if grading is None else grading}"
            solved = solve_level(case, out, comm, cyc)  # as each level of a study
            q = solved.quantities
            where = ""
            if comm.rank == 0:
                field = solved.snapshot.bodies[case.thermal.body]
                _, x = field.hottest_point(solved.snapshot.label_index("end"))
                rel = x - field.center_m
                where = f"r {math.hypot(rel[0], rel[1]) * 1e3:.3f}, z {rel[2] * 1e3:.2f}"
            row += [f"{q[name][0]:.5g}" for name in SHOWN] + [where]
        rows.append(row)
        if comm.rank == 0:
            print(row, flush=True)
    if comm.rank == 0:
        text = report(rows, args, comm.size, time.perf_counter() - t0)
        print(text, flush=True)
        if args.docs:
            replace_block(DOC, BLOCK, text)


def report(rows: list, args, size: int, wall_s: float) -> str:
    head = [
        "layers",
        "thickness at the side faces / in the middle, mm",
        "structural DOFs",
        "cycle s",
        "flank-foot band: first two rows from z = 0",
        "middle half's rows (mean)",
        "first row / middle",
    ]
    if not args.no_thermal:
        head += [*SHOWN, "hottest point (mm)"]
    settings = " ".join(f"{n}" if g is None else f"{n}:{g:g}" for n, g in args.settings)
    command = (
        f"`mpirun -n {size} python benchmarks/graded_layers.py --settings {settings}"
        + (" --no-thermal" if args.no_thermal else "")
        + " --docs`"
    )
    return (
        "The built-in case at these structural layers (equal, or graded towards the side faces by "
        "`[mesh] layer_grading`; everything else as built in). Flux: the pinion's drive flank "
        f"at r = {args.band_radius_mm:g} ± {args.band_halfwidth_mm:g} mm as the cycle delivers "
        "it (revolution average per facet row, W/m² per rad/s); temperatures in C at the end "
        "of the run.\n\n"
        f"{markdown_table(head, rows)}\n\n{command}: {wall_s:.0f} s on {size} ranks, load "
        f"average {os.getloadavg()[0]:.1f}."
    )


if __name__ == "__main__":
    main()
