"""Refinement studies: the numerical uncertainty of every reported thermal quantity.

``gearfem converge CASE.toml --out DIR`` runs the thermal model of a case on three systematically
refined thermal meshes (every element size and the size gradient divided by ``factor`` and the
layer count multiplied by it, level by level; the structural cycle is the case's, computed once
and cached) and estimates, for each reported temperature, the observed order, the extrapolated
value and the grid convergence index with the numerical standard uncertainty u_num of the finest
value (:mod:`gearfem.core.gci`). The representative size of a level is h = N^(-1/3) for its N
temperature DOFs (the volume is the same on every level, so only the ratios matter).

Outputs (DIR): ``level<i>/`` (each level's thermal outputs), ``refinement.csv`` and
``refinement.md`` (one row per quantity), ``refinement.png`` (each quantity against h with the
extrapolated value), ``refinement.json`` (written last).
"""

from __future__ import annotations

import csv
import dataclasses
import math
import os
from pathlib import Path
from typing import Any

from mpi4py import MPI

from gearfem import pipeline
from gearfem.config import Case
from gearfem.core.errors import ParameterError
from gearfem.core.gci import grid_convergence, representative_size
from gearfem.core.io import prepare_output, write_json
from gearfem.core.results import JsonRecord
from gearfem.geometry.options import MeshOptions

LEVELS = 3


@dataclasses.dataclass(frozen=True)
class RefinementRow(JsonRecord):
    """One quantity on the three levels and its convergence (values fine to coarse)."""

    quantity: str
    unit: str
    values: tuple[float, float, float]
    sizes: tuple[float, float, float]
    observed_order: float
    extrapolated: float
    gci: float
    u_num: float
    asymptotic: bool


@dataclasses.dataclass(frozen=True)
class RefinementStudy(JsonRecord):
    """A thermal refinement study of one case (``refinement.json``)."""

    case: str
    factor: float
    dofs: tuple[int, ...]  # per level, coarse to fine
    meshes: tuple[dict[str, Any], ...]
    rows: tuple[RefinementRow, ...]

    def row(self, quantity: str) -> RefinementRow:
        return next(r for r in self.rows if r.quantity == quantity)


def refined_mesh(options: MeshOptions, factor: float) -> MeshOptions:
    """``options`` refined geometrically similarly: every element size and the size gradient
    divided by ``factor`` (the size grows linearly with the distance from the fine curves, so the
    gradient must shrink too for the whole mesh to refine by ``factor``), the layers multiplied."""
    if not factor >= 1.0:
        raise ParameterError("refinement factor", factor, ">= 1")
    return dataclasses.replace(
        options,
        size_flank_mm=options.size_flank_mm / factor,
        size_tip_mm=options.size_tip_mm / factor,
        size_root_mm=options.size_root_mm / factor,
        size_tooth_mm=options.size_tooth_mm / factor,
        size_body_mm=options.size_body_mm / factor,
        size_growth=options.size_growth / factor,
        layers=max(1, math.ceil(options.layers * factor - 1e-9)),
    )


def thermal_refinement(
    case: Case, out_dir: str | Path, comm: MPI.Comm, factor: float = 1.5
) -> RefinementStudy:
    """Run the refinement study (collective); see the module docstring."""
    if not 1.2 <= factor <= 3.0:
        raise ParameterError("refinement factor", factor, "[1.2, 3]")
    out = prepare_output(out_dir, "refinement.json", comm)
    cyc = None
    if case.sources.mode == "cycle":
        cyc, _, _ = pipeline.cycle(case, comm)
    base = case.thermal_mesh_options
    summaries, meshes = [], []
    for level in range(LEVELS):
        mesh = refined_mesh(base, factor**level)
        c = dataclasses.replace(case, thermal_mesh=mesh)
        summaries.append(
            pipeline.thermal(
                c,
                out / f"level{level}",
                comm,
                cyc,
                write_fields=False,
                steady=False,
                write_plot=False,
            )
        )
        meshes.append(dataclasses.asdict(mesh))
    dofs = tuple(int(s["dofs"]) for s in summaries)
    sizes = [representative_size(n) for n in dofs]
    formal = case.thermal.degree + 1.0
    rows = []
    for q in summaries[0]["final_temperatures_C"]:
        values = [s["final_temperatures_C"][q] for s in summaries]
        conv = grid_convergence(values, sizes, formal_order=formal)
        rows.append(
            RefinementRow(
                q,
                "C",
                conv.values,
                conv.sizes,
                conv.observed_order,
                conv.extrapolated,
                conv.gci,
                conv.u_num,
                conv.asymptotic,
            )
        )
    study = RefinementStudy(case.name, factor, dofs, tuple(meshes), tuple(rows))
    if comm.rank == 0:
        _write_table(study, out)
        _plot(study, out)
        write_json(out / "refinement.json", study)  # last: marks a complete study
    comm.barrier()
    return study


def _write_table(study: RefinementStudy, out: Path) -> None:
    cols = ("quantity", "fine", "medium", "coarse", "order", "extrapolated", "gci", "u_num")
    tmp = out / f".refinement.csv.tmp{os.getpid()}"
    with tmp.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow([*cols, "asymptotic"])
        for r in study.rows:
            w.writerow(
                [
                    r.quantity,
                    *r.values,
                    r.observed_order,
                    r.extrapolated,
                    r.gci,
                    r.u_num,
                    r.asymptotic,
                ]
            )
    os.replace(tmp, out / "refinement.csv")
    lines = [
        f"# Thermal refinement study: {study.case}",
        "",
        f"Three thermal meshes, refinement factor {study.factor:g} (DOFs "
        f"{', '.join(str(n) for n in study.dofs)}); values at the end of the run (C).",
        "",
        "| quantity | fine | medium | coarse | observed order | extrapolated | GCI (K) | "
        "u_num (K) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in study.rows:
        flag = "" if r.asymptotic else " *"
        lines.append(
            f"| {r.quantity} | {r.values[0]:.2f} | {r.values[1]:.2f} | {r.values[2]:.2f} | "
            f"{r.observed_order:.2f}{flag} | {r.extrapolated:.2f} | {r.gci:.2f} | {r.u_num:.2f} |"
        )
    lines += [
        "",
        "\\* not in the asymptotic range: Fs = 3 and the order clipped (core/gci.py).",
        "",
    ]
    (out / "refinement.md").write_text("\n".join(lines))


def _plot(study: RefinementStudy, out: Path) -> None:
    import matplotlib  # plotting only here: not imported with the CLI

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.5, 4.8))
    for r in study.rows:
        if not r.quantity.endswith(("max", "mean", "surface", "bulk")):
            continue
        h = [x / r.sizes[0] for x in r.sizes]
        (line,) = ax.plot(h, r.values, "o-", label=f"{r.quantity} (±{r.u_num:.1f} K)")
        ax.plot([0.0], [r.extrapolated], "*", color=line.get_color(), ms=10)
    ax.set_xlabel("relative mesh size h / h_fine (★: extrapolated to h = 0)")
    ax.set_ylabel("temperature at the end (°C)")
    ax.set_title(f"Thermal mesh refinement, factor {study.factor:g}")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(out / "refinement.png", dpi=120)
    plt.close(fig)
