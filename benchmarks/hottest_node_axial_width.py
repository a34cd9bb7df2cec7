"""The pinion's hottest node against the axial width of the flux reconstruction, at a layer level.

The structural layers study (docs/refinement.md) refines the layers across the face width and
shrinks the axial width of the flux reconstruction (``[sources] flux_smoothing_axial_mm``) with
them. This separates the two: for each ``LEVEL:WIDTH`` (LEVEL 0 = the built-in case's 2 layers,
k = the layers study's level k, 2 / 3 / 5 / 7 layers; WIDTH in mm) it runs the pinion's thermal
model of the built-in case on that level's cycle (cached by the study) with the width replaced,
and prints the hottest node (its radius and axial position), the flank mean and the bulk at the
end of the run, and the largest surface temperature in each eighth of the face width (where
across the face the peak sits).

    mpirun -n 2 python benchmarks/hottest_node_axial_width.py 3:1.5 0:0.4286 [--out DIR]
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from pathlib import Path

import numpy as np
from mpi4py import MPI

import gearfem  # noqa: F401  (must precede dolfinx/petsc4py)
from gearfem import pipeline
from gearfem.config import load_case
from gearfem.refinement import level_case


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("runs", nargs="+", help="LEVEL:WIDTH_mm, e.g. 3:1.5")
    p.add_argument("--factor", type=float, default=1.5, help="the layers study's factor")
    p.add_argument("--out", default="results/hottest_node_axial_width")
    args = p.parse_args()
    comm = MPI.COMM_WORLD
    case = load_case(None)
    for spec in args.runs:
        level, width = spec.split(":")
        level, width_mm = int(level), float(width)
        c = case if level == 0 else level_case(case, "structural_layers", args.factor**level)
        c = dataclasses.replace(
            c, sources=dataclasses.replace(c.sources, flux_smoothing_axial_mm=width_mm)
        )
        cyc, _, _ = pipeline.cycle(c, comm)
        t0 = time.perf_counter()
        out = Path(args.out) / f"level{level}_axial{width_mm:g}mm"
        summary, field = pipeline.thermal_field(
            c, out, comm, cyc, write_fields=False, steady=False, write_plot=False, record=True
        )
        temps = summary["final_temperatures_C"]
        if comm.rank == 0:
            surface = np.unique(field.faces)  # the boundary nodes
            xyz = field.nodes_m[surface]
            t_end = field.temperature_K[-1][surface] - 273.15
            hot = int(np.argmax(t_end))
            r_mm = 1e3 * float(np.hypot(*(xyz[hot, :2] - field.center_m[:2])))
            z = xyz[:, 2] - xyz[:, 2].min()
            width = float(z.max())
            bins = np.minimum((8 * z / width).astype(int), 7)
            per_bin = [float(t_end[bins == b].max()) for b in range(8)]
            print(
                f"{c.mesh.layers} layers, axial width {width_mm:g} mm: hottest node "
                f"{temps['max_surface']:.2f} C, flank mean {temps['flank_mean']:.2f} C, bulk "
                f"{temps['mean_bulk']:.2f} C, friction into the pinion "
                f"{summary['final_balance_W']['friction_W']:.3f} W "
                f"({time.perf_counter() - t0:.0f} s)",
                flush=True,
            )
            print(
                f"  hottest node at r = {r_mm:.3f} mm, z = {1e3 * z[hot]:.2f} of "
                f"{1e3 * width:.2f} mm; largest surface temperature per eighth of the face "
                f"width (C): {' '.join(f'{v:.1f}' for v in per_bin)}",
                flush=True,
            )


if __name__ == "__main__":
    main()
