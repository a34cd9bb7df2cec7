"""The hottest node against the hottest point of the field, on the thermal-mesh study's levels.

The built-in case reports the hottest *node* of the pinion's surface. On quadratic elements the
field between the nodes can be hotter: at the flank foot the temperature across the face width
has a peak about 2 mm wide (the cycle's flux alternates by 2-4 % between the two triangle rows of
every structural layer on the resolution built in until c30c95c), which the case's thermal layers
(3.2 mm) sample with nodes 1.6 mm apart. This runs the pinion's thermal model (the case's cycle,
cached) on the three levels of the thermal-mesh study (factor 1.5, the case in the middle) for
each setting of the flux reconstruction asked for (evaluation and axial width), and prints per
level the hottest node, the hottest point of the quadratic field
(:meth:`gearfem.instruments.snapshot.BodyField.hottest_point`) and where it is, and the
convergence of both (gearfem.core.gci, formal order 3).

    mpirun -n 2 python benchmarks/verification/hottest_point.py \
        [--out results/hottest_point] [--docs]
        [--settings reference_facets:1.5 continuous:3.234 ...]

Settings by default: the case's, continuous, continuous with an axial width of one facet row's
spacing (3.234 mm). Each about 8 min on 2 cores (the pinion's levels: 83k / 195k / 538k DOFs).
``--docs`` replaces the block ``hottest_point`` of docs/reconstruction.md.

Purpose: verification (the hottest node against the field's maximum under thermal refinement).
Writes: block ``hottest_point`` of docs/reconstruction.md (``--docs``).
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import time
from pathlib import Path

from mpi4py import MPI

import gearfem  # noqa: F401  (must precede dolfinx/petsc4py)
from gearfem import pipeline
from gearfem.config import load_case
from gearfem.core.doctables import markdown_table, replace_block
from gearfem.core.gci import convergence, representative_size
from gearfem.core.materials import ZERO_CELSIUS_K
from gearfem.refinement import level_case

ROOT = Path(__file__).resolve().parents[2]
DOC = ROOT / "docs" / "reconstruction.md"
FACTOR = 1.5
LEVEL_FACTORS = (1.0 / FACTOR, 1.0, FACTOR)  # coarse, the case, fine


def _setting(text: str) -> tuple[str, float]:
    evaluation, width = text.split(":")
    return evaluation, float(width)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument(
        "--settings",
        nargs="+",
        type=_setting,
        default=[("reference_facets", 1.5), ("continuous", 1.5), ("continuous", 3.234)],
        help="EVALUATION:AXIAL_WIDTH_MM of the flux reconstruction",
    )
    p.add_argument("--out", default="results/hottest_point")
    p.add_argument("--docs", action="store_true")
    args = p.parse_args()
    comm = MPI.COMM_WORLD
    case = load_case(None)
    cyc, _, _ = pipeline.cycle(case, comm)
    t0 = time.perf_counter()
    rows = []
    for evaluation, width in args.settings:
        src = dataclasses.replace(
            case.sources, flux_evaluation=evaluation, flux_smoothing_axial_mm=width
        )
        nodes, points, sizes, where = [], [], [], []
        for factor in LEVEL_FACTORS:
            c = dataclasses.replace(case, sources=src)
            c = c if factor == 1.0 else level_case(c, "thermal_mesh", factor)
            out = Path(args.out) / f"{evaluation}_{width:g}mm_x{factor:.3f}"
            summary, field = pipeline.thermal_field(
                c, out, comm, cycle_result=cyc, write_fields=False, write_plot=False,
                record=True, branch_search=False,
            )  # fmt: skip
            if comm.rank == 0:
                t_point, x = field.hottest_point(len(field.temperature_K) - 1)
                rel = x - field.center_m
                nodes.append(summary["final_temperatures_C"]["max_surface"])
                points.append(t_point - ZERO_CELSIUS_K)
                sizes.append(representative_size(summary["dofs"]))
                where.append(f"r {math.hypot(rel[0], rel[1]) * 1e3:.3f}, z {rel[2] * 1e3:.2f}")
        if comm.rank == 0:
            for name, values in (("hottest node", nodes), ("hottest point", points)):
                conv = convergence(values, sizes, formal_order=3.0)
                rows.append(
                    [
                        f"{evaluation}, {width:g} mm",
                        name,
                        " / ".join(f"{v:.2f}" for v in values),
                        f"{conv.observed_order:.2f}{'' if conv.asymptotic else ' *'}",
                        f"{conv.u_num_at(1):.2f}",
                        " / ".join(where) if name == "hottest point" else "",
                    ]
                )
            print(rows[-2], rows[-1], flush=True)
    if comm.rank == 0:
        table = markdown_table(
            (
                "flux reconstruction",
                "quantity",
                "coarse / case / fine, C",
                "order",
                "u_num case, K",
                "hottest point (mm)",
            ),
            rows,
        )
        text = (
            f"The pinion's thermal model on the thermal-mesh study's levels (factor {FACTOR:g}, "
            "the case in the middle; the case's cycle), at the end of the run.\n\n"
            f"{table}\n\n\\* not in the asymptotic range: Fs = 3 and the order clipped.\n\n"
            f"`mpirun -n {comm.size} python benchmarks/verification/hottest_point.py --docs`: "
            f"{time.perf_counter() - t0:.0f} s on {comm.size} ranks, load average "
            f"{os.getloadavg()[0]:.1f}."
        )
        print(text, flush=True)
        if args.docs:
            replace_block(DOC, "hottest_point", text)


if __name__ == "__main__":
    main()
