"""gearfem's steady temperatures of the thesis pair (PEEK 450G / PEEK 450G) beside VDI 2736-2's, at
the operating points of docs/materials.md's VDI table.

Runs the built-in thesis case (its resolution, its constant mu = 0.5, ambient 23 C) as a study of
the points 1000 rpm / 4 N m, 1000 rpm / 8 N m and 2000 rpm / 4 N m (``gearfem study``: one cycle
per torque, found in the cycle cache when the main job or the bench runs computed it), then puts
side by side, per point and for the pinion:

* VDI 2736-2's flank temperature against gearfem's steady flank temperature, the drive flank's
  mean and its maximum (the hottest node of the drive flank, at the foot where the mate's tip
  enters);
* VDI 2736-2's root temperature against gearfem's steady root mean and bulk mean;
* what the bench's camera would read (the instrument model of the built-in case).

The VDI values are the run's own baselines (gearfem.baselines with the case's mu, geometry and
ambient: the same constants on both sides). Bulk and camera carry their numerical uncertainty
u_num (the refinement studies of the resolution); the flank and root means have no stored study
and are printed without one.

    mpirun -n 2 python benchmarks/studies/vdi2736_gearfem.py [--out results/vdi2736_peek] [--docs]

``--docs`` writes block ``vdi2736_gearfem`` of docs/materials.md, headed by the provenance the runs
recorded (resolution key, code hash, commit: ``gearfem claims`` and tests/test_claims.py mark it
stale when the model changes).

Purpose: study (issue 45, VDI 2736 side by side: the PEEK pair, the one whose gearfem model exists
today; the steel and POM/PA66 pairs wait for the steel body and a sourced H(T)).
Writes: the study under ``--out``; block ``vdi2736_gearfem`` of docs/materials.md (``--docs``).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from mpi4py import MPI

import gearfem  # noqa: F401  (import order)
from gearfem.config import load_case
from gearfem.core.doctables import Provenance, markdown_table, replace_block
from gearfem.core.errors import ParameterError
from gearfem.pipeline import RunSummary
from gearfem.study import Study, StudyOptions, case_label, run_study

ROOT = Path(__file__).resolve().parents[2]
#: The operating points of the VDI table of docs/materials.md (benchmarks/studies/vdi2736_pairs.py).
POINTS = ((1000.0, 4.0), (1000.0, 8.0), (2000.0, 4.0))


def _pm(value: float, u: float | None) -> str:
    return f"{value:.1f} ± {u:.1f}" if u is not None else f"{value:.1f}"


def table(summaries: list[RunSummary]) -> tuple[str, Provenance]:
    """The side-by-side table of the runs and the provenance they share."""
    rows, provs = [], []
    for s in summaries:
        h, b, steady = s.headline, s.baselines, s.thermal["steady_state_C"]
        u = h.u_num or {}
        if s.provenance is None:
            raise ParameterError("run summary", s.case, "a run that recorded its provenance")
        provs.append(Provenance(**s.provenance))
        rows.append(
            (
                f"{s.speed_rpm:g}",
                f"{s.torque_Nm:g}",
                f"{b['power_W']:.0f}",
                f"{b['vdi2736_flank1_C']:.1f}",
                f"{steady['flank_mean']:.1f}",
                f"{steady['flank_max']:.1f}",
                f"{b['vdi2736_root1_C']:.1f}",
                f"{steady['root_mean']:.1f}",
                _pm(steady["mean_bulk"], u.get("mean_bulk_temperature_C")),
                _pm(h.camera_max_steady_C, u.get("camera_max_C")),
            )
        )
    first = provs[0]
    for p in provs[1:]:
        if (p.resolution, p.code) != (first.resolution, first.code):
            raise ParameterError(
                "study runs", [q.line() for q in provs], "runs of one resolution and one code"
            )
    head = (
        "n (rpm)",
        "T (N m)",
        "P (W)",
        "VDI flank (°C)",
        "gearfem flank mean (°C)",
        "gearfem flank max (°C)",
        "VDI root (°C)",
        "gearfem root mean (°C)",
        "gearfem bulk mean (°C)",
        "camera reads (°C)",
    )
    note = (
        "PEEK 450G / PEEK 450G, the built-in thesis case (μ = 0.5 constant, ambient 23 °C), "
        "pinion, steady state; VDI 2736-2 with the same μ and geometry (plastic/plastic k_θ "
        "9000 / 2148). gearfem's flank max is the drive flank's hottest node; ± is u_num where "
        "a refinement study of the resolution gives one. Written by `mpirun -n 2 python "
        "benchmarks/studies/vdi2736_gearfem.py --docs`."
    )
    return markdown_table(head, rows) + "\n\n" + note, first


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "vdi2736_peek")
    ap.add_argument("--docs", action="store_true", help="write block vdi2736_gearfem")
    args = ap.parse_args(argv)
    comm = MPI.COMM_WORLD
    case = load_case(None)
    study = Study(
        name=f"{case.name}: VDI 2736 points",
        case=case,
        options=StudyOptions(points=POINTS),
    )
    run_study(study, args.out, comm)
    summaries = [
        RunSummary.read(args.out / "cases" / case_label(s, t) / "summary.json") for s, t in POINTS
    ]
    text, prov = table(summaries)
    if comm.rank == 0:
        print(text)
        if args.docs:
            replace_block(ROOT / "docs" / "materials.md", "vdi2736_gearfem", text, prov)
            print("wrote block vdi2736_gearfem of docs/materials.md")


if __name__ == "__main__":
    main()
