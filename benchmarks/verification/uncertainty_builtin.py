"""The built-in case's numerical uncertainty: refinement studies in every direction, filed with
gearfem and written into docs/refinement.md.

For each kind (thermal mesh, structural contact zone, structural layers, positions per pitch, tip
elements) this runs
:func:`gearfem.refinement.refinement_study` on the built-in thesis case (its resolution the middle
of three levels for the thermal mesh and the positions, the coarsest for the other kinds:
:data:`gearfem.uncertainty.BUILTIN_CASE_LEVEL`), then
(rank 0):

* files the study as package data, ``gearfem/data/uncertainty/<resolution key>/<kind>.json``:
  ``gearfem run`` of the built-in case reads u_num from there (tests/test_uncertainty.py checks
  that the shipped studies belong to the built-in case's current resolution, so a change of
  resolution without re-running this script fails the test suite);
* replaces the block ``refinement_<kind>`` of docs/refinement.md with the study's table
  (gearfem.core.doctables) and copies its plot to docs/images/refinement_<kind>.png;
* at the end, replaces the block ``refinement_summary`` with the u_num of the case per kind and
  combined, from the filed studies (``--summary-only``: only that).

Usage (2 ranks; the cycles of the refined levels are cached under cache/cycles):

    mpirun -n 2 python benchmarks/verification/uncertainty_builtin.py \
        [--kinds thermal_mesh positions ...]
        [--factor 1.5] [--case-level coarsest|middle|finest] [--levels N]
        [--out results/uncertainty]

Purpose: verification (the built-in case's five refinement studies, filed as package data).
Writes: blocks ``refinement_<kind>`` and ``refinement_summary`` of docs/refinement.md.
"""

from __future__ import annotations

import argparse
import os
import shutil
import time
from pathlib import Path

from mpi4py import MPI

import gearfem  # noqa: F401  (must precede dolfinx/petsc4py)
from gearfem.config import load_case
from gearfem.core.doctables import markdown_table, replace_block
from gearfem.core.io import read_json, write_json
from gearfem.refinement import (
    CASE_LEVELS,
    KINDS,
    RefinementStudy,
    markdown,
    plot,
    refinement_study,
    study_uncertainty,
)
from gearfem.uncertainty import (
    BUILTIN_CASE_LEVEL,
    BUILTIN_LEVELS,
    resolution_key,
    run_uncertainty,
    stored_studies,
)

#: The docs/refinement.md block of each kind.
BLOCKS = {
    "thermal_mesh": "refinement_thermal_mesh",
    "structural_mesh": "refinement_structural_mesh",
    "structural_layers": "refinement_structural_layers",
    "positions": "refinement_positions",
    "tip": "refinement_tip",
}
#: The quantities of the summary block (docs/refinement.md, refinement_summary).
SUMMARY = (
    "camera_max",
    "mean_bulk",
    "flank_mean",
    "max_surface_field",
    "max_surface",
    "friction_power_W",
)
ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "gearfem" / "data" / "uncertainty"
DOC = ROOT / "docs" / "refinement.md"


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--kinds", nargs="+", default=list(KINDS), choices=KINDS)
    p.add_argument("--factor", type=float, default=1.5)
    p.add_argument(
        "--case-level",
        default=None,
        choices=tuple(CASE_LEVELS),
        help="where the built-in case's resolution sits among the levels (default: "
        "BUILTIN_CASE_LEVEL of each kind)",
    )
    p.add_argument(
        "--levels",
        type=int,
        default=None,
        help="levels of each study (default: BUILTIN_LEVELS of each kind)",
    )
    p.add_argument("--out", default="results/uncertainty")
    p.add_argument(
        "--file-only",
        action="store_true",
        help="do not run: file the finished studies found in OUT/<kind> (their refinement.json, "
        "written last by a complete study) and write their tables",
    )
    p.add_argument("--note", help="with --file-only: how the study was run (the table's caption)")
    p.add_argument(
        "--summary-only",
        action="store_true",
        help="only write the block refinement_summary from the filed studies",
    )
    args = p.parse_args()
    comm = MPI.COMM_WORLD
    case = load_case(None)
    for kind in () if args.summary_only else args.kinds:
        t0 = time.perf_counter()
        case_level = args.case_level or BUILTIN_CASE_LEVEL[kind]
        levels = args.levels or BUILTIN_LEVELS[kind]
        if args.file_only and not (Path(args.out) / kind / "refinement.json").is_file():
            # an incomplete study (e.g. a cycle that did not converge): say so in its block
            if comm.rank == 0:
                text = f"No complete {kind} study in {args.out}/{kind}"
                replace_block(DOC, BLOCKS[kind], f"{text}: {args.note or 'not run'}.")
            continue
        if args.file_only:
            study = RefinementStudy.from_json(read_json(Path(args.out) / kind / "refinement.json"))
            if study.resolution_key != resolution_key(case) or study.kind != kind:
                raise SystemExit(
                    f"{args.out}/{kind}: a study of resolution {study.resolution_key} "
                    f"({study.kind}), not of the built-in case's {resolution_key(case)} ({kind})"
                )
        else:
            study = refinement_study(
                case,
                Path(args.out) / kind,
                comm,
                kind=kind,
                factor=args.factor,
                case_level=case_level,
                levels=levels,
            )
        wall = time.perf_counter() - t0
        if comm.rank == 0:
            write_json(DATA / study.resolution_key / f"{kind}.json", study_uncertainty(case, study))
            caption = (
                f"\n\n`mpirun -n {comm.size} python benchmarks/verification/uncertainty_builtin.py "
                f"--kinds "
                f"{kind} --case-level {case_level} --levels {levels}`: {wall:.0f} s on "
                f"{comm.size} ranks, "
                f"load average {os.getloadavg()[0]:.1f}."
            )
            if args.file_only:
                caption = f"\n\n{args.note or 'Filed from ' + args.out + '/' + kind}."
            replace_block(DOC, BLOCKS[kind], markdown(study) + caption)
            image = ROOT / "docs" / "images" / f"refinement_{kind}.png"
            if args.file_only:  # drawn again from the study: the plot of the current code
                plot(study, image)
            else:
                shutil.copy(Path(args.out) / kind / "refinement.png", image)
            print(markdown(study), flush=True)
        comm.barrier()
    if comm.rank == 0:
        replace_block(DOC, "refinement_summary", summary_table(case))


def summary_table(case) -> str:
    """u_num of the built-in case per kind and combined, as ``gearfem run`` combines the filed
    studies (:func:`gearfem.uncertainty.run_uncertainty` at the case's own values)."""
    found = stored_studies(resolution_key(case))
    values = {
        q: next(study.values[q] for study, _ in found.values() if q in study.values)
        for q in SUMMARY
    }
    run = run_uncertainty(case, values)
    rows = []
    for q in SUMMARY:
        u = run.quantities[q]
        parts = [f"{u.parts[k]:.3g}" if k in u.parts else "-" for k in KINDS]
        rows.append([q, f"{values[q]:.4g}", *parts, f"{u.u_num:.3g}"])
    table = markdown_table(("quantity", "value of the case", *KINDS, "combined"), rows)
    missing = f" Kinds without a study: {', '.join(run.missing)}." if run.missing else ""
    return (
        f"u_num of the case (units of the quantity) per refinement kind, combined in quadrature as "
        f"`gearfem run` does; resolution {run.resolution_key}.{missing}\n\n{table}"
    )


if __name__ == "__main__":
    main()
