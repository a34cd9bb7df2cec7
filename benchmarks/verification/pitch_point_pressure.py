"""The pitch-point pressure under structural refinement: the largest pointwise pressure against
the band's Hertz-profile peak 2 w / (π a) (gearfem.cycle.measures).

For each structural refinement kind given (``structural_layers``, ``structural_mesh``, ``tip``,
``positions``) and each factor, the built-in case's level (gearfem.refinement.level_case) is
read from the cycle cache; a level whose cycle is not cached is solved only with ``--solve``
(the 10-layer cycle takes 35 min and 15 GB), else skipped and said so. Beside the two measures:
Hertz's peak of the band's load on the local involute radii and the band's load per length.

    mpirun -n 2 python benchmarks/verification/pitch_point_pressure.py [--kind structural_layers]
        [--layers 2 3 5 7 10] [--factors 1 1.5 2.25] [--solve] [--docs]

``--docs`` replaces the block ``pitch_point_pressure_<kind>`` of docs/reconstruction.md. A few
seconds a
cached level (the cycle's contact history is read from the cache).

Purpose: verification (the two pressure measures under structural refinement).
Writes: blocks ``pitch_point_pressure_<kind>`` of docs/reconstruction.md (``--docs``).
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np
from mpi4py import MPI

import gearfem  # noqa: F401  (must precede dolfinx/petsc4py)
from gearfem import pipeline
from gearfem.config import load_case
from gearfem.core.doctables import markdown_table, replace_block
from gearfem.core.gci import convergence
from gearfem.cycle.measures import (
    hertz_peak_pressure_Pa,
    pitch_point_band_pressure_Pa,
    pitch_point_bands,
)
from gearfem.refinement import level_case

DOC = Path(__file__).resolve().parents[2] / "docs" / "reconstruction.md"
#: the docs/reconstruction.md block of each kind
BLOCKS = {
    "structural_layers": "pitch_point_pressure_structural_layers",
    "structural_mesh": "pitch_point_pressure_structural_mesh",
    "tip": "pitch_point_pressure_tip",
    "positions": "pitch_point_pressure_positions",
}


def _measures(cyc) -> tuple[float, float, float, float, float]:
    """Pointwise maximum; the band pressure (the mean of the slices' peaks), the largest slice
    peak and Hertz's peak of the slices' mean load (MPa); the slices' mean load (N/mm)."""
    h, bands = cyc.history, pitch_point_bands(cyc)
    peaks = hertz_peak_pressure_Pa(h)[bands]
    hertz = np.mean(2 * h.load_per_length_N_m[bands] / (math.pi * h.hertz_half_width_m[bands]))
    return (
        cyc.p_max_mid_Pa[0] / 1e6,
        pitch_point_band_pressure_Pa(cyc) / 1e6,
        float(np.max(peaks)) / 1e6,
        float(hertz) / 1e6,
        float(np.mean(h.load_per_length_N_m[bands])) / 1e3,
    )


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--kind", default="structural_layers", choices=tuple(BLOCKS))
    p.add_argument("--layers", nargs="+", type=int, default=[2, 3, 5, 7, 10])
    p.add_argument("--factors", nargs="+", type=float, default=[1.0, 1.5, 2.25])
    p.add_argument("--solve", action="store_true", help="solve the levels not cached")
    p.add_argument("--docs", action="store_true")
    args = p.parse_args()
    comm = MPI.COMM_WORLD
    base = load_case(None)
    if args.kind == "structural_layers":
        factors = [n / base.mesh.layers for n in args.layers]
    else:
        factors = args.factors
    rows, series, sizes, skipped = [], [], [], []
    for f in factors:
        case = base if f == 1.0 else level_case(base, args.kind, f)
        if not (pipeline.case_cycle_dir(case) / "cycle.json").is_file() and not args.solve:
            skipped.append(f"{f:g}")
            continue
        cyc, _, _ = pipeline.cycle(case, comm)
        point, band, slice_max, hertz, w = _measures(cyc)
        setting = {
            "structural_layers": f"{case.mesh.layers} layers",
            "structural_mesh": f"flank {case.mesh.size_flank_mm:.4g} mm",
            "tip": f"tip {case.mesh.size_tip_mm:.4g} mm",
            "positions": f"{case.cycle.positions_per_pitch} positions",
        }[args.kind]
        rows.append(
            [
                setting,
                str(int(cyc.info["dofs"])),
                f"{point:.2f}",
                f"{band:.2f}",
                f"{slice_max:.2f}",
                f"{hertz:.2f}",
                f"{w:.2f}",
            ]
        )
        series.append((point, band, slice_max))
        sizes.append(1.0 / f)
    if comm.rank != 0:
        return
    header = (
        "level",
        "structural DOFs",
        "largest pointwise pressure, MPa",
        "band pressure: mean of the slices' 2w/(πa), MPa",
        "largest slice's 2w/(πa), MPa",
        "Hertz on the slices' loads (mean), MPa",
        "slices' mean load, N/mm",
    )
    text = markdown_table(header, rows)
    if len(series) >= 3:
        fits = []
        for j, name in enumerate(("pointwise", "band pressure", "largest slice")):
            c = convergence([s[j] for s in series], sizes)
            u = c.u_num_at(len(series) - 1)  # the coarsest level: the case
            fits.append(
                f"{name}: order {c.observed_order:.2f}"
                f"{'' if c.asymptotic else ' (not asymptotic)'}, u_num of the case {u:.2f} MPa"
            )
        text += "\n\nFit through all levels (gearfem.core.gci): " + "; ".join(fits) + "."
    if skipped:
        text += f"\n\nNot cached, skipped (factors): {', '.join(skipped)}."
    levels = (
        f" --layers {' '.join(map(str, args.layers))}"
        if args.kind == "structural_layers"
        else f" --factors {' '.join(f'{f:g}' for f in args.factors)}"
    )
    text += (
        f"\n\nThe built-in case's pitch point (first position; pinion's bands in the middle half "
        f"of the face width), {args.kind} levels; `mpirun -n {comm.size} python "
        f"benchmarks/verification/pitch_point_pressure.py --kind {args.kind}{levels} --docs`."
    )
    print(text, flush=True)
    if args.docs:
        replace_block(DOC, BLOCKS[args.kind], text)


if __name__ == "__main__":
    main()
