"""Does the hottest value level off across the face width beyond the layers study's 7 layers?

The structural-layers study of the built-in case (2 / 3 / 5 / 7 element layers across the 12.9 mm
face width; docs/refinement.md) has no converging order for the hottest node: it rises about 1 K
per level with either evaluation of the flux reconstruction (block
``flux_evaluation_structural_layers``). This solves the case at the layer counts asked for
(default 2 and 10: the case, and 1.43 times the study's finest 7 layers; the study's own factor
1.5 would give 11) with each setting of the reconstruction (evaluation and axial width at the
case's 2 layers; the width scaled with the layers as the per-facet evaluation's study does,
:func:`gearfem.refinement.level_case`, or kept with ``--fixed-width``). It prints, per layer
count and setting, the quantities a study follows (:func:`gearfem.pipeline.reported_quantities`
of the same runs), among them the pinion's surface
maximum of the quadratic field ``max_surface_field`` (:func:`gearfem.pipeline.surface_field_max`)
and where it is, and with three or more layer counts their convergence (gearfem.core.gci).

    mpirun -n 2 python benchmarks/structural_layers_beyond.py [--layers 2 10]
        [--settings reference_facets:1.5 continuous:3.234] [--fixed-width]
        [--out results/layers_beyond] [--docs]

The cycle is solved once per layer count (cached; the reconstruction is applied after the cache):
2 / 3 / 5 / 7 layers took 106 / 198 / 476 / 1045 s at stop 31. Each setting's thermal runs (both
gears, the camera sees both) take about 4 min on 2 cores. ``--fixed-width`` keeps each
setting's axial width at every layer count, so that only the structural solution is refined.
``--docs`` replaces the block ``structural_layers_beyond`` (``structural_layers_fixed_width``)
of docs/refinement.md.
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
from gearfem.core.gci import convergence
from gearfem.core.io import read_json
from gearfem.refinement import RefinementStudy, level_case, solve_level

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "refinement.md"
#: The docs/refinement.md block of the axial width scaled with the layers, and kept.
BLOCKS = {False: "structural_layers_beyond", True: "structural_layers_fixed_width"}
#: The quantities shown (the headline's, the flank's and the cycle's).
SHOWN = (
    "max_surface",
    "flank_mean",
    "camera_max",
    "mean_bulk",
    "tip_max",
    "root_max",
    "friction_power_W",
    "pitch_point_pressure_MPa",
)

#: The quantities whose convergence across the layers is fitted (gearfem.core.gci).
CONVERGED = ("max_surface", "max_surface_field", "camera_max", "flank_mean")


def setting_label(evaluation: str, width_mm: float) -> str:
    return f"{evaluation}, {width_mm:g} mm"


def _setting(text: str) -> tuple[str, float]:
    evaluation, width = text.split(":")
    return evaluation, float(width)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--layers", nargs="+", type=int, default=[2, 10])
    p.add_argument(
        "--settings",
        nargs="+",
        type=_setting,
        default=[("reference_facets", 1.5), ("continuous", 3.234)],
        help="EVALUATION:AXIAL_WIDTH_MM of the flux reconstruction at the case's layers",
    )
    p.add_argument("--out", default="results/layers_beyond")
    p.add_argument(
        "--fixed-width",
        action="store_true",
        help="keep the axial width at every layer count (default: scaled with the layers)",
    )
    p.add_argument(
        "--with-study",
        type=Path,
        help="a structural_layers refinement.json of the same reconstruction (one setting): its "
        "levels join the fit (and the table) beside the layer counts solved here",
    )
    p.add_argument("--docs", action="store_true")
    args = p.parse_args()
    comm = MPI.COMM_WORLD
    base = load_case(None)
    t0 = time.perf_counter()
    rows = []
    series: dict[str, dict[int, dict[str, float]]] = {}  # setting -> layers -> quantity -> value
    for layers in args.layers:
        factor = layers / base.mesh.layers
        for evaluation, width in args.settings:
            src = dataclasses.replace(
                base.sources, flux_evaluation=evaluation, flux_smoothing_axial_mm=width
            )
            case = dataclasses.replace(base, sources=src)
            if layers != base.mesh.layers:
                case = level_case(case, "structural_layers", factor)
            # the axial width set here, whatever the study's rule (gearfem.refinement.level_case)
            at_layers = (
                width if args.fixed_width else float(f"{width * base.mesh.layers / layers:.12g}")
            )
            case = dataclasses.replace(
                case, sources=dataclasses.replace(case.sources, flux_smoothing_axial_mm=at_layers)
            )
            if case.mesh.layers != layers:
                raise SystemExit(f"layers {layers}: the level has {case.mesh.layers}")
            tc = time.perf_counter()
            cyc, _, cached = pipeline.cycle(case, comm)
            t_cycle = time.perf_counter() - tc
            kept = "_fixed" if args.fixed_width else ""
            out = Path(args.out) / f"layers{layers}_{evaluation}_{width:g}mm{kept}"
            solved = solve_level(case, out, comm, cyc)  # as each level of a study
            q, snapshot = solved.quantities, solved.snapshot
            series.setdefault(setting_label(evaluation, width), {})[layers] = {
                name: value for name, (value, _) in q.items()
            }
            if comm.rank == 0:
                field = snapshot.bodies[case.thermal.body]
                _, x = field.hottest_point(snapshot.label_index("end"))
                rel = x - field.center_m
                row = [
                    str(layers),
                    f"{evaluation}, {case.sources.flux_smoothing_axial_mm:.4g} mm",
                    *(f"{q[name][0]:.5g}" for name in SHOWN),
                    f"{q['max_surface_field'][0]:.5g}",
                    f"r {math.hypot(rel[0], rel[1]) * 1e3:.3f}, z {rel[2] * 1e3:.2f}",
                    f"{int(cyc.info['dofs'])}",
                    "cached" if cached else f"{t_cycle:.0f}",
                ]
                rows.append(row)
                print(row, flush=True)
    if comm.rank == 0:
        text = report(rows, series, args, base.mesh.layers, comm.size, time.perf_counter() - t0)
        print(text, flush=True)
        if args.docs:
            replace_block(DOC, BLOCKS[args.fixed_width], text)


def report(rows: list, series: dict, args, case_layers: int, size: int, wall_s: float) -> str:
    """The docs block: the rows solved here (and ``--with-study``'s levels) and, per setting with
    three or more layer counts, the convergence of :data:`CONVERGED` (Markdown)."""
    rows = list(rows)
    if args.with_study is not None:
        if len(args.settings) != 1:
            raise SystemExit("--with-study: one setting, the study's")
        study = RefinementStudy.from_json(read_json(args.with_study))
        if study.kind != "structural_layers":
            raise SystemExit(f"--with-study: a structural_layers study, not {study.kind}")
        label = setting_label(*args.settings[0])
        by_layers = series.setdefault(label, {})
        for row in study.rows:
            for value, h in zip(row.values, row.sizes, strict=True):
                by_layers.setdefault(round(1.0 / h), {}).setdefault(row.quantity, value)
        for lv in study.levels:
            got = by_layers[lv.setting["layers"]]
            rows.append(
                [
                    str(lv.setting["layers"]),
                    f"{label} (the study's level)",
                    *(f"{got[name]:.5g}" if name in got else "" for name in SHOWN),
                    f"{got['max_surface_field']:.5g}" if "max_surface_field" in got else "",
                    "",
                    str(lv.dofs),
                    f"study {study.resolution_key}",
                ]
            )
        rows.sort(key=lambda r: int(r[0]))
    table = markdown_table(
        ("layers", "reconstruction", *SHOWN, "max_surface_field", "where (mm)", "DOFs", "cycle s"),
        rows,
    )
    fits = []
    for setting, by_layers in series.items():
        counts = sorted(by_layers)
        if len(counts) < 3:
            continue
        for name in CONVERGED:
            if not all(name in by_layers[n] for n in counts):
                continue
            values = [by_layers[n][name] for n in counts]
            conv = convergence(values, [1.0 / n for n in counts])
            at = (
                f"{conv.u_num_at(len(counts) - 1 - counts.index(case_layers)):.2f}"
                if case_layers in counts
                else ""
            )
            fits.append(
                [
                    setting,
                    name,
                    " / ".join(map(str, counts)),
                    " / ".join(f"{v:.2f}" for v in values),
                    f"{conv.observed_order:.2f}{'' if conv.asymptotic else ' *'}",
                    f"{conv.extrapolated:.2f}",
                    at,
                ]
            )
    fit_text = ""
    if fits:
        fit_text = (
            markdown_table(
                (
                    "reconstruction at the case",
                    "quantity",
                    "layers",
                    "values, C",
                    "order",
                    "extrapolated, C",
                    f"u_num at {case_layers} layers, K",
                ),
                fits,
            )
            + "\n\n\\* not in the asymptotic range: Fs = 3 and the order clipped.\n\n"
        )
    width = (
        "width kept at every layer count"
        if args.fixed_width
        else "width at the layers shown, scaled from the case's as in the per-facet study"
    )
    command = " ".join(
        [
            f"`mpirun -n {size} python benchmarks/structural_layers_beyond.py",
            "--layers",
            *map(str, args.layers),
            "--settings",
            *(f"{e}:{w:g}" for e, w in args.settings),
            *(["--fixed-width"] if args.fixed_width else []),
            *(["--with-study", str(args.with_study)] if args.with_study else []),
            "--docs`",
        ]
    )
    return (
        "The built-in case at these structural layers across the face width (the thermal mesh "
        f"the case's; temperatures in C at the end of the run; the reconstruction's axial {width})."
        f"\n\n{table}\n\n{fit_text}{command}: {wall_s:.0f} s on {size} ranks, load average "
        f"{os.getloadavg()[0]:.1f}."
    )


if __name__ == "__main__":
    main()
