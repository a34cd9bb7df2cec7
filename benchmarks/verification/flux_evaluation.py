"""Does the continuous evaluation of the flux reconstruction make the hottest node converge?

Since ec2dbaf (2026-11-26) the built-in case is evaluated continuously with an axial width of
3.234 mm: run now, it compares that resolution with itself unless ``--axial-width-mm`` differs.
What follows is the question as it stood on the resolution built in before ec2dbaf.

The built-in case's hottest node (a maximum over the drive flank's nodes, at the flank foot) had
no converging order under thermal-mesh refinement (284.2 / 284.9 / 285.7 C on 83k / 195k / 538k
DOFs per gear, as of 3287272, 2026-11-26: u_num 13.2 K) nor across the structural layers
(9.3 K). The
reconstruction is evaluated per structural facet (``[sources] flux_evaluation =
"reference_facets"``): piecewise constant on facets whose rows are 3.2 mm apart across the face
width, steps that a finer thermal mesh resolves. This runs the built-in case's refinement studies
(the shipped design: :data:`gearfem.uncertainty.BUILTIN_CASE_LEVEL` and ``BUILTIN_LEVELS``) with
``flux_evaluation = "continuous"`` (the reconstruction's kernel evaluated at each thermal facet's
own sample points) and prints each beside the filed study of the default
(gearfem/data/uncertainty/<key>/<kind>.json).

    mpirun -n 2 python benchmarks/verification/flux_evaluation.py \
        [--kinds thermal_mesh structural_layers]
        [--axial-width-mm W] [--out results/flux_evaluation] [--reuse] [--docs] [--stage]

Any kind of :data:`gearfem.uncertainty.BUILTIN_LEVELS`. Thermal mesh about 25 min on 2 cores
(the case's cycle cached, else 2 min more); structural layers about 45 min with its cycles
computed (2 / 3 / 5 / 7 layers: 106 / 198 / 476 / 1045 s); structural mesh, positions and tip
each two more cycles and three thermal runs.
The studies are not filed for the built-in case (the evaluation is part of the resolution key).
``--reuse``: read a complete study from OUT/<kind>/refinement.json instead of running it.
``--axial-width-mm``: the case's ``[sources] flux_smoothing_axial_mm`` for these studies (default
the built-in case's; the layers study keeps it, as :func:`gearfem.refinement.level_case` does
for the continuous evaluation).
``--docs``: replace the kind's block of docs/reconstruction.md (:data:`BLOCKS`). ``--stage``: copy
each study's refinement.json and plot to benchmarks/studies/<resolution key>/<kind>/, from where
``uncertainty_builtin.py --file-only --out benchmarks/studies/<key> --kinds ...`` files them once
the built-in case is that resolution (the script checks the key).

Purpose: verification (refinement studies with the flux reconstruction evaluated either way).
Writes: blocks ``flux_evaluation_<kind>`` of docs/reconstruction.md (``--docs``).
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import shutil
import time
from pathlib import Path

from mpi4py import MPI

import gearfem  # noqa: F401  (must precede dolfinx/petsc4py)
from gearfem.config import load_case
from gearfem.core.doctables import markdown_table, read_block, replace_block
from gearfem.core.io import read_json
from gearfem.refinement import RefinementStudy, markdown, refinement_study
from gearfem.uncertainty import (
    BUILTIN_CASE_LEVEL,
    BUILTIN_LEVELS,
    resolution_key,
    stored_studies,
)

ROOT = Path(__file__).resolve().parents[2]
DOC = ROOT / "docs" / "reconstruction.md"
STAGE = ROOT / "benchmarks" / "studies"
#: The docs/reconstruction.md block of each kind (``--docs`` requires it to be in the page).
BLOCKS = {
    "thermal_mesh": "flux_evaluation_thermal_mesh",
    "structural_mesh": "flux_evaluation_structural_mesh",
    "structural_layers": "flux_evaluation_structural_layers",
    "positions": "flux_evaluation_positions",
    "tip": "flux_evaluation_tip",
}
#: The quantities compared (the headline's and the flank's).
SHOWN = ("max_surface", "flank_mean", "camera_max", "mean_bulk", "tip_max", "root_max")


def comparison(
    study: RefinementStudy, filed, where: str, width_mm: float, wall: float | None, size: int
) -> str:
    """The continuous study (axial width ``width_mm`` at the case) beside the filed default's
    value and u_num (Markdown)."""
    rows = {r.quantity: r for r in study.rows}
    body = [
        [
            q,
            f"{filed.values[q]:.4g}",
            f"{filed.u_num[q]:.3g}",
            " / ".join(f"{v:.4g}" for v in reversed(rows[q].values)),
            f"{rows[q].observed_order:.2f}{'' if rows[q].asymptotic else ' *'}",
            f"{rows[q].u_num_case:.3g}",
        ]
        for q in SHOWN
        if q in rows and q in filed.values
    ]
    levels = ", ".join(str(d) for d in study.dofs)
    table = markdown_table(
        (
            "quantity (C)",
            "reference_facets: case",
            "u_num case",
            "continuous: coarse ... fine",
            "order",
            "u_num case",
        ),
        body,
    )
    run = (
        f"`mpirun -n {size} python benchmarks/verification/flux_evaluation.py --kinds {study.kind} "
        f"--axial-width-mm {width_mm:g} --docs`: "
        f"{wall:.0f} s on {size} ranks, load average {os.getloadavg()[0]:.1f}."
        if wall is not None
        else f"Filed from the study's refinement.json ({study.resolution_key})."
    )
    return (
        f"{study.kind} study of the built-in case (factor {study.factor:g}, the case the "
        f"{study.case_level_name} of {len(study.levels)} levels of {levels} DOFs): the "
        f"reconstruction evaluated per structural facet (the filed study, {where}) and "
        f"continuously at the thermal facets' sample points, axial width {width_mm:g} mm at the "
        f"case.\n\n{table}\n\n"
        "\\* not in the asymptotic range: Fs = 3 and the order clipped.\n\n" + run
    )


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--kinds", nargs="+", default=["thermal_mesh"], choices=tuple(BLOCKS))
    p.add_argument("--out", default="results/flux_evaluation")
    p.add_argument("--reuse", action="store_true", help="read OUT/<kind>/refinement.json")
    p.add_argument("--docs", action="store_true", help="write the docs/reconstruction.md blocks")
    p.add_argument("--stage", action="store_true", help="copy the studies to " + str(STAGE))
    p.add_argument("--axial-width-mm", type=float, default=None)
    args = p.parse_args()
    if args.docs:  # before hours of runs: every block written is in the page
        for kind in args.kinds:
            read_block(DOC, BLOCKS[kind])
    comm = MPI.COMM_WORLD
    case = load_case(None)
    filed_studies = stored_studies(resolution_key(case))
    continuous = dataclasses.replace(
        case,
        sources=dataclasses.replace(
            case.sources,
            flux_evaluation="continuous",
            flux_smoothing_axial_mm=args.axial_width_mm or case.sources.flux_smoothing_axial_mm,
        ),
    )
    for kind in args.kinds:
        if kind not in filed_studies:
            raise SystemExit(f"no filed {kind} study of the built-in case: run it first")
        out = Path(args.out) / kind
        t0 = time.perf_counter()
        if args.reuse:
            study, wall = RefinementStudy.from_json(read_json(out / "refinement.json")), None
            if study.resolution_key != resolution_key(continuous) or study.kind != kind:
                raise SystemExit(f"{out}: not a {kind} study of the continuous evaluation")
        else:
            study = refinement_study(
                continuous,
                out,
                comm,
                kind=kind,
                factor=1.5,
                case_level=BUILTIN_CASE_LEVEL[kind],
                levels=BUILTIN_LEVELS[kind],
            )
            wall = time.perf_counter() - t0
        if comm.rank == 0:
            width = continuous.sources.flux_smoothing_axial_mm
            text = comparison(study, *filed_studies[kind], width, wall, comm.size)
            print(markdown(study), flush=True)
            print(text, flush=True)
            if args.docs:
                replace_block(DOC, BLOCKS[kind], text)
            if args.stage:
                stage = STAGE / study.resolution_key / kind
                stage.mkdir(parents=True, exist_ok=True)
                for name in ("refinement.json", "refinement.png"):
                    shutil.copy(out / name, stage / name)
        comm.barrier()


if __name__ == "__main__":
    main()
