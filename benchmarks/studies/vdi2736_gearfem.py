"""gearfem's steady temperatures of a gear pair beside VDI 2736-2's: the thesis pair (PEEK 450G /
PEEK 450G) at the operating points of docs/materials.md's VDI table, or any case's.

Runs the case (default the built-in thesis case: its resolution, its constant mu = 0.5, ambient
23 C) as a study of the points (``gearfem study``: one cycle per torque, found in the cycle cache
when an earlier run computed it), then puts side by side, per point, for the gear of the case's
thermal model (``[thermal] body``: the pinion of the thesis case, the POM wheel of the steel/POM
demo):

* VDI 2736-2's flank temperature against gearfem's steady flank temperature, the drive flank's
  mean and its maximum (the hottest node of the drive flank, at the foot where the mate's tip
  enters);
* VDI 2736-2's root temperature against gearfem's steady root mean and bulk mean;
* what the case's camera would read.

The VDI values are the run's own baselines (gearfem.baselines with the case's mu, geometry,
materials and ambient: the same constants on both sides, the k_theta of the pair's VDI pairing).
Bulk and camera carry their numerical uncertainty u_num where refinement studies of the
resolution are filed (the built-in case's); the flank and root means have no stored study and are
printed without one.

    mpirun -n 2 python benchmarks/studies/vdi2736_gearfem.py [--docs]
    mpirun -n 2 python benchmarks/studies/vdi2736_gearfem.py --case demos/steel_pom.toml \
        --points 1000/2,1000/4,2000/2 --block vdi2736_gearfem_steel_pom [--docs]
    mpirun -n 2 python benchmarks/studies/vdi2736_gearfem.py \
        --case benchmarks/studies/cases/pom_pom.toml --block vdi2736_gearfem_pom_pom [--docs]
    mpirun -n 2 python benchmarks/studies/vdi2736_gearfem.py \
        --case benchmarks/studies/cases/steel_pa66.toml --block vdi2736_gearfem_steel_pa66 [--docs]

``--docs`` writes block ``--block`` (default ``vdi2736_gearfem``) of docs/materials.md, headed by
the provenance the runs recorded (resolution key, code hash, commit: ``gearfem claims`` and
tests/test_claims.py mark it stale when the model changes).

Purpose: study (issue 45, VDI 2736 side by side).
Writes: the study under ``--out``; the block of docs/materials.md (``--docs``).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from mpi4py import MPI

import gearfem  # noqa: F401  (import order)
from gearfem.baselines import vdi2736_pairing
from gearfem.config import Case, load_case
from gearfem.core.doctables import Provenance, markdown_table, replace_block
from gearfem.core.errors import ParameterError
from gearfem.pipeline import RunSummary
from gearfem.study import Study, StudyOptions, case_label, parse_points, run_study

ROOT = Path(__file__).resolve().parents[2]
#: The operating points of the VDI table of docs/materials.md (benchmarks/studies/vdi2736_pairs.py).
POINTS = ((1000.0, 4.0), (1000.0, 8.0), (2000.0, 4.0))
DEFAULT_POINTS = ",".join(f"{s:g}/{t:g}" for s, t in POINTS)


def _pm(value: float, u: float | None) -> str:
    return f"{value:.1f} ± {u:.1f}" if u is not None else f"{value:.1f}"


def table(summaries: list[RunSummary], case: Case, command: str) -> tuple[str, Provenance]:
    """The side-by-side table of the runs of ``case`` and the provenance they share, for the gear
    of the case's thermal model (``[thermal] body``); ``command`` wrote it."""
    body = case.thermal.body
    gear = {"pinion": 1, "wheel": 2}[body]
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
                f"{b[f'vdi2736_flank{gear}_C']:.1f}",
                f"{steady['flank_mean']:.1f}",
                f"{steady['flank_max']:.1f}",
                f"{b[f'vdi2736_root{gear}_C']:.1f}",
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
    mats = case.materials
    k_flank, k_root = (summaries[0].baselines[f"vdi2736_k_theta_{w}"] for w in ("flank", "root"))
    pairing = vdi2736_pairing(mats["pinion"], mats["wheel"])
    note = (
        f"{mats['pinion'].name} pinion / {mats['wheel'].name} wheel, {case.geometry.teeth_pinion}/"
        f"{case.geometry.teeth_wheel} teeth, case '{case.name}' (μ = "
        f"{case.contact.friction_coefficient:g} constant, ambient {case.thermal.ambient_C:g} °C), "
        f"the {body}, steady state; VDI 2736-2 with the same μ and geometry ({pairing} k_θ "
        f"{k_flank:g} / {k_root:g}). gearfem's flank max is the drive flank's hottest node; ± is "
        "u_num where a refinement study of the resolution gives one. Written by "
        f"`{command} --docs`."
    )
    return markdown_table(head, rows) + "\n\n" + note, first


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", default=None, help="case TOML (default: the built-in thesis case)")
    ap.add_argument(
        "--points",
        default=DEFAULT_POINTS,
        help=f"operating points 'rpm/Nm,...' (default {DEFAULT_POINTS}, the VDI table's)",
    )
    ap.add_argument(
        "--block",
        choices=(
            "vdi2736_gearfem",
            "vdi2736_gearfem_steel_pom",
            "vdi2736_gearfem_pom_pom",
            "vdi2736_gearfem_steel_pa66",
        ),
        default="vdi2736_gearfem",
        help="block of docs/materials.md (the PEEK pair's, the steel/POM demo's, the POM pair's "
        "and the steel/PA66 pair's of benchmarks/studies/cases/)",
    )
    ap.add_argument("--out", type=Path, default=None, help="study directory (default results/)")
    ap.add_argument("--docs", action="store_true", help="write the block")
    args = ap.parse_args(argv)
    comm = MPI.COMM_WORLD
    case = load_case(args.case)
    points = parse_points(args.points, "--points")
    command = f"mpirun -n {comm.size} python benchmarks/studies/vdi2736_gearfem.py" + (
        f" --case {args.case} --points {args.points} --block {args.block}" if args.case else ""
    )
    out = args.out or ROOT / "results" / ("vdi2736_peek" if args.case is None else args.block)
    study = Study(
        name=f"{case.name}: VDI 2736 points",
        case=case,
        options=StudyOptions(points=points),
    )
    run_study(study, out, comm)
    summaries = [
        RunSummary.read(out / "cases" / case_label(s, t) / "summary.json") for s, t in points
    ]
    text, prov = table(summaries, case, command)
    if comm.rank == 0:
        print(text)
        if args.docs:
            replace_block(ROOT / "docs" / "materials.md", args.block, text, prov)
            print(f"wrote block {args.block} of docs/materials.md")


if __name__ == "__main__":
    main()
