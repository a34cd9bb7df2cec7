"""Refinement studies: the numerical uncertainty of every reported quantity.

``gearfem converge CASE.toml --out DIR [--kind KIND] [--levels N]`` runs the chain of a case on
N (default 3) systematically refined discretisations, one direction (kind) at a time, and
estimates for each reported quantity the observed order, the extrapolated value and the grid
convergence index with the numerical standard uncertainty u_num (:mod:`gearfem.core.gci`: the
three-solution GCI, or for four or more the least-squares procedure of Eça & Hoekstra) — of the
solution at the case's own resolution, which is one of the levels: the coarsest (``case_level =
"coarsest"``, levels 1, r, r², ... times finer than the case), the second coarsest
(``"middle"``, levels 1/r, 1, r, ...: the case's u_num then comes from one coarser solution
and the finer ones; with three levels the GCI of the medium grid of Celik et al.) or the finest
(``"finest"``, levels ..., 1/r², 1/r and 1: the fine-grid GCI of Celik et al., what the
procedure reports for the solution it is applied to). A fourth level tells a slow trend from
settling where three solutions differ by little more than their scatter. Per kind:

* ``thermal_mesh``: the thermal model's mesh (``[thermal_mesh]``; every element size and the size
  gradient divided by the factor, the layer count multiplied by it and rounded up); the
  structural cycle is the case's, solved once. h = N^(-1/3) for N temperature DOFs.
* ``structural_mesh``: the contact zone of the structural mesh (flank, tip, root and tooth element
  sizes divided by the factor; body size, size gradient and layers kept: the contact pressures and
  the friction flux live there); the thermal mesh and the flux reconstruction's widths stay the
  case's. h = the flank element size.
* ``structural_layers``: the element layers of the structural mesh across the face width
  (multiplied by the factor and rounded up: 2, 3, 5 from 2 by 1.5), which set the axial
  distribution of the contact pressure and of the friction heat near the side faces, where the
  camera looks, and the axial width of the flux reconstruction with them; the thermal mesh stays
  the case's. h = 1 / layers.
* ``positions``: the pinion positions per pitch of the cycle (multiplied by the factor and
  rounded) and the profile width of the flux reconstruction with their spacing; h = 1 /
  positions per pitch.
* ``tip``: the tip element size alone (the tip rounds): the largest contact pressure of the cycle
  sits on the mating gear's tip round (docs/cycle.md).

Quantities: every temperature of the thermal summary at the end of the run, and for the kinds that
re-solve the cycle (and for every kind when the sources come from a cycle) the friction power, the
effective contact ratio, the pitch-point and largest contact pressures and the mean transmission
error. Outputs (DIR): ``level<i>/`` (each level's thermal outputs), ``refinement.csv`` and
``refinement.md`` (one row per quantity), ``refinement.png`` (each quantity against h with the
extrapolated value), ``refinement.json`` (written last). The study is also filed in the
uncertainty store (:mod:`gearfem.uncertainty`) under the case's resolution key, where
``gearfem run`` finds it and reports u_num with its headline numbers.
"""

from __future__ import annotations

import csv
import dataclasses
import itertools
import math
import os
from pathlib import Path
from typing import Any

from mpi4py import MPI

from gearfem import pipeline
from gearfem.config import Case
from gearfem.core.errors import ParameterError
from gearfem.core.gci import branch_convergence, representative_size
from gearfem.core.io import prepare_output, write_json
from gearfem.core.params import require_choice, require_range
from gearfem.core.results import JsonRecord
from gearfem.geometry.options import MeshOptions
from gearfem.instruments.evaluate import evaluate
from gearfem.uncertainty import (
    KINDS,
    STUDY_DESIGN_VERSION,
    StudyUncertainty,
    resolution_key,
    store_study,
)

#: the number of levels of a study: three by default, up to five
LEVELS = 3
MAX_LEVELS = 5
#: where the case's own resolution sits among the levels (:func:`case_level_index`)
CASE_LEVELS = ("coarsest", "middle", "finest")


def case_level_index(name: str, levels: int = LEVELS) -> int:
    """Index (coarse to fine) of the case among ``levels`` levels: ``"coarsest"`` 0,
    ``"middle"`` 1 (one level coarser than the case, the others finer), ``"finest"`` the last."""
    require_choice("refinement case_level", name, CASE_LEVELS)
    return {"coarsest": 0, "middle": 1, "finest": levels - 1}[name]


@dataclasses.dataclass(frozen=True)
class RefinementRow(JsonRecord):
    """One quantity on the study's levels and its convergence (values fine to coarse).

    ``gci`` and ``u_num`` are those of the finest level; ``u_num_case`` that of the case's own
    level (:meth:`gearfem.core.gci.Convergence.u_num_at`)."""

    quantity: str
    unit: str
    values: tuple[float, ...]
    sizes: tuple[float, ...]
    observed_order: float
    extrapolated: float
    gci: float
    u_num: float
    asymptotic: bool
    u_num_case: float
    # the levels reached different steady states: u_num is the gap between the branches
    # (gearfem.core.gci.branch_convergence)
    branches_differ: bool = False


@dataclasses.dataclass(frozen=True)
class RefinementLevel(JsonRecord):
    """One discretisation of the study: its representative size and what was varied."""

    level: int
    size: float
    dofs: int  # thermal DOFs (thermal_mesh) or structural DOFs (the other kinds)
    setting: dict[str, Any]


@dataclasses.dataclass(frozen=True)
class RefinementStudy(JsonRecord):
    """A refinement study of one case (``refinement.json``). Levels coarse to fine."""

    case: str
    kind: str
    factor: float
    case_level: int  # index (coarse to fine) of the case's own resolution
    resolution_key: str
    levels: tuple[RefinementLevel, ...]
    rows: tuple[RefinementRow, ...]
    # the steady-state branch each level reached (coarse to fine; None: one steady state)
    branches: tuple[int | None, ...] = ()

    @property
    def dofs(self) -> tuple[int, ...]:
        return tuple(lv.dofs for lv in self.levels)

    @property
    def case_value_index(self) -> int:
        """Index of the case's own value in each row's ``values`` (fine to coarse)."""
        return _value_index(self.case_level, len(self.levels))

    @property
    def case_level_name(self) -> str:
        """``"coarsest"``, ``"middle"`` or ``"finest"`` (:func:`case_level_index`)."""
        return next(
            k for k in CASE_LEVELS if case_level_index(k, len(self.levels)) == self.case_level
        )

    def row(self, quantity: str) -> RefinementRow:
        try:
            return next(r for r in self.rows if r.quantity == quantity)
        except StopIteration:
            raise ParameterError(
                "refinement quantity", quantity, ", ".join(r.quantity for r in self.rows)
            ) from None


def _value_index(case_level: int, levels: int) -> int:
    """Index in a row's values (fine to coarse) of level ``case_level`` (coarse to fine)."""
    return levels - 1 - case_level


def refined_mesh(options: MeshOptions, factor: float) -> MeshOptions:
    """``options`` refined geometrically similarly: every element size and the size gradient
    divided by ``factor`` (the size grows linearly with the distance from the fine curves, so the
    gradient must shrink too for the whole mesh to refine by ``factor``), the layers multiplied
    and rounded up. A factor below 1 coarsens."""
    return dataclasses.replace(
        refined_contact_zone(options, factor),
        size_body_mm=_divided(options.size_body_mm, factor),
        size_growth=_divided(options.size_growth, factor),
        layers=_layers(options.layers, factor),
    )


def _layers(layers: int, factor: float) -> int:
    """``layers`` multiplied by ``factor`` and rounded up (at least 1)."""
    return max(1, math.ceil(layers * factor - 1e-9))


def refined_contact_zone(options: MeshOptions, factor: float) -> MeshOptions:
    """The contact zone of ``options`` refined: flank, tip, root, tooth and (when set) entry
    element sizes divided by ``factor`` (body size, size gradient and layers kept). A factor
    below 1 coarsens."""
    if not factor > 0.0:
        raise ParameterError("refinement factor", factor, "> 0")
    return dataclasses.replace(
        options,
        size_flank_mm=_divided(options.size_flank_mm, factor),
        size_tip_mm=_divided(options.size_tip_mm, factor),
        size_root_mm=_divided(options.size_root_mm, factor),
        size_tooth_mm=_divided(options.size_tooth_mm, factor),
        size_entry_mm=None
        if options.size_entry_mm is None
        else _divided(options.size_entry_mm, factor),
    )


def _divided(size: float, factor: float) -> float:
    """``size / factor`` to 12 significant digits: a level reached by refining and coarsening
    again (0.14 / (1 / 1.5)) is the same mesh, with the same cache key, as the one it came from."""
    return float(f"{size / factor:.12g}")


def level_case(case: Case, kind: str, factor: float) -> Case:
    """The case refined by ``factor`` (> 0; below 1: coarsened) in direction ``kind``. The
    thermal mesh is pinned to the case's (``[thermal_mesh]``, or ``[mesh]`` when absent) in every
    kind but ``thermal_mesh``, so that refining the structural mesh does not refine the thermal
    one with it. The reconstruction of the cycle's facet flux (``[sources]
    flux_smoothing_*_mm``) is part of the structural discretisation: its profile width shrinks
    with the positions' spacing (it smooths the comb of the positions' contact bands: shrunk at a
    fixed spacing, the comb appears and the hottest node climbs, docs/refinement.md), its axial
    width with the structural layers; the contact zone's refinement keeps both (finer facets
    represent the same reconstructed flux more finely). Evaluated continuously (``[sources]
    flux_evaluation = "continuous"``) the reconstruction is a smooth flux whose axial width is
    its own, not the layers': the layers study keeps it, and so refines the structural solution
    only (per facet the flux is a step per facet row, which the width must follow to converge).
    """
    require_choice("refinement kind", kind, KINDS)
    pinned = dataclasses.replace(case, thermal_mesh=case.thermal_mesh_options)
    if kind == "thermal_mesh":
        return dataclasses.replace(
            case, thermal_mesh=refined_mesh(case.thermal_mesh_options, factor)
        )
    src = case.sources
    if kind == "structural_mesh":
        return dataclasses.replace(pinned, mesh=refined_contact_zone(case.mesh, factor))
    if kind == "structural_layers":
        layers = _layers(case.mesh.layers, factor)
        mesh = dataclasses.replace(case.mesh, layers=layers)
        if src.flux_evaluation == "continuous":  # a smooth flux of its own width: kept
            return dataclasses.replace(pinned, mesh=mesh)
        smooth = dataclasses.replace(  # per facet: the axial width with the layers' thickness
            src,
            flux_smoothing_axial_mm=_divided(
                src.flux_smoothing_axial_mm, layers / case.mesh.layers
            ),
        )
        return dataclasses.replace(pinned, mesh=mesh, sources=smooth)
    if kind == "tip":
        mesh = dataclasses.replace(case.mesh, size_tip_mm=_divided(case.mesh.size_tip_mm, factor))
        return dataclasses.replace(pinned, mesh=mesh)
    n = round(case.cycle.positions_per_pitch * factor)
    smooth = dataclasses.replace(  # and with the spacing of the positions along the profile
        src,
        flux_smoothing_profile_mm=_divided(
            src.flux_smoothing_profile_mm, n / case.cycle.positions_per_pitch
        ),
    )
    return dataclasses.replace(
        pinned, cycle=dataclasses.replace(case.cycle, positions_per_pitch=n), sources=smooth
    )


def _size_and_setting(case: Case, kind: str, thermal: dict, cycle) -> tuple[float, int, dict]:
    if kind == "thermal_mesh":
        n = int(thermal["dofs"])
        return representative_size(n), n, dataclasses.asdict(case.thermal_mesh_options)
    dofs = int(cycle.info["dofs"]) if cycle is not None else 0
    if kind == "structural_mesh":
        return case.mesh.size_flank_mm * 1e-3, dofs, dataclasses.asdict(case.mesh)
    if kind == "tip":
        return case.mesh.size_tip_mm * 1e-3, dofs, {"size_tip_mm": case.mesh.size_tip_mm}
    if kind == "structural_layers":
        return 1.0 / case.mesh.layers, dofs, {"layers": case.mesh.layers}
    n = case.cycle.positions_per_pitch
    return 1.0 / n, dofs, {"positions_per_pitch": n}


@dataclasses.dataclass(frozen=True)
class LevelSolution:
    """One level of a study solved: the thermal summary of ``[thermal] body``, the instruments'
    snapshot of the thermal models (rank 0; None without instruments) and the reported
    quantities (:func:`gearfem.pipeline.reported_quantities`: name -> (value, unit))."""

    thermal: dict[str, Any]
    snapshot: Any
    quantities: dict[str, tuple[float, str]]


#: Steady states whose friction heats differ by less than this factor are one branch (the
#: branches of a friction law that steps at the glass transition differ by its mu ratio, about 3;
#: the levels of a study on one branch by a few per cent).
BRANCH_HEAT_RATIO = 1.25


@dataclasses.dataclass(frozen=True)
class LevelBranch:
    """The steady states a level found (distinct and stable): each one's friction heat (W) and
    temperatures (C, by quantity), and which of them the transient from ambient reached."""

    heats_W: tuple[float, ...]
    temperatures_C: tuple[dict[str, float], ...]
    reached: int


def level_branch(thermal: dict[str, Any]) -> LevelBranch | None:
    """The steady states of one level's thermal summary (None when its friction heat cannot rise
    with temperature, or the branches were not searched)."""
    fr = thermal.get("friction") or {}
    states = [
        b
        for b in fr.get("branches", ())
        if b.get("converged") and b.get("same_as") is None and b.get("stable") is not False
    ]
    picked = fr.get("transient_branch")
    names = [b["start"] for b in states]
    if not states or picked not in names or any(b.get("friction_W") is None for b in states):
        return None
    return LevelBranch(
        tuple(float(b["friction_W"]) for b in states),
        tuple(dict(b["temperatures_C"]) for b in states),
        names.index(picked),
    )


def branch_labels(
    levels: list[LevelBranch | None],
) -> tuple[list[int | None], dict[str, float]]:
    """The branch each level reached, labelled alike across the levels, and per quantity the gap
    between the branches (the largest over the levels that found more than one).

    The distinct stable states of all levels are grouped by their friction heat (single linkage:
    heats within :data:`BRANCH_HEAT_RATIO` of each other are one branch, labelled 0, 1, ... from
    the coolest); a level's label is the group of the state its transient reached. A level
    without several steady states (None) is labelled None, and so is every level when none
    found any."""
    heats = sorted({h for lv in levels if lv is not None for h in lv.heats_W})
    if not heats:
        return [None] * len(levels), {}
    group, g = {}, 0
    for i, h in enumerate(heats):
        if i and not h <= BRANCH_HEAT_RATIO * max(heats[i - 1], 1e-300):
            g += 1
        group[h] = g
    labels = [None if lv is None else group[lv.heats_W[lv.reached]] for lv in levels]
    gaps: dict[str, float] = {}
    for lv in levels:
        if lv is None or len({group[h] for h in lv.heats_W}) < 2:
            continue
        mine = lv.temperatures_C[lv.reached]
        for k, h in enumerate(lv.heats_W):
            if group[h] == group[lv.heats_W[lv.reached]]:
                continue
            for q, v in lv.temperatures_C[k].items():
                if q in mine and math.isfinite(v) and math.isfinite(mine[q]):
                    gaps[q] = max(gaps.get(q, 0.0), abs(v - mine[q]))
    return labels, gaps


def solve_level(case: Case, out_dir: Path, comm: MPI.Comm, cycle) -> LevelSolution:
    """The thermal models the instruments read (both gears with the camera) on ``cycle`` (the
    case's cycle result, None for prescribed sources), their readings and every reported
    quantity, as each level of :func:`refinement_study` is measured (collective)."""
    # a friction heat that may rise with temperature can have several steady states: each level
    # then finds them (the steady states from a cold, the transient's and a hot start), so that
    # the levels are compared branch by branch (level_branch)
    rising = case.friction_law().may_rise_with_temperature
    th, _, snapshot = pipeline.observed_thermal(
        case, out_dir, comm, cycle, write_fields=False, steady=rising, write_plot=False
    )
    readings = None
    if comm.bcast(snapshot is not None, root=0):
        readings = pipeline.on_root(comm, lambda: evaluate(case.instruments, snapshot))
    at_speed = pipeline.CycleAtSpeed.of(cycle, case.operating.speed_rpm) if cycle else None
    field_max = pipeline.surface_field_max(snapshot, case.thermal.body, comm)
    quantities = pipeline.reported_quantities(th, at_speed, readings, field_max)
    return LevelSolution(th, snapshot, quantities)


def refinement_study(
    case: Case,
    out_dir: str | Path,
    comm: MPI.Comm,
    kind: str = "thermal_mesh",
    factor: float = 1.5,
    case_level: str = "coarsest",
    levels: int = LEVELS,
) -> RefinementStudy:
    """Run the refinement study of ``case`` in direction ``kind`` on ``levels`` levels (3 to
    :data:`MAX_LEVELS`; collective); see the module docstring. ``case_level``: ``"coarsest"``,
    ``"middle"`` or ``"finest"``, where the case's own resolution sits among the levels."""
    require_choice("refinement kind", kind, KINDS)
    require_range("refinement factor", factor, 1.2, 3.0)
    if not (isinstance(levels, int) and LEVELS <= levels <= MAX_LEVELS):
        raise ParameterError("refinement levels", levels, f"an integer {LEVELS} ... {MAX_LEVELS}")
    at = case_level_index(case_level, levels)
    if kind != "thermal_mesh" and case.sources.mode != "cycle":
        raise ParameterError(
            "sources.mode", case.sources.mode, "'cycle'", f"a {kind} study re-solves the cycle"
        )
    cases = [
        case if level == at else level_case(case, kind, factor ** (level - at))
        for level in range(levels)
    ]
    if len({resolution_key(c) for c in cases}) < levels:  # rounded counts can coincide
        raise ParameterError(
            "refinement factor",
            factor,
            f"a factor that gives {levels} different {kind} levels around the case "
            f"(case_level {case_level!r})",
        )
    out = prepare_output(out_dir, "refinement.json", comm)
    done, quantities, thermals = [], [], []
    cyc_fixed = None
    if kind == "thermal_mesh" and case.sources.mode == "cycle":
        cyc_fixed, _, _ = pipeline.cycle(case, comm)
    for level, c in enumerate(cases):
        cyc = cyc_fixed
        if cyc is None and c.sources.mode == "cycle":
            cyc, _, _ = pipeline.cycle(c, comm)
        solved = solve_level(c, out / f"level{level}", comm, cyc)
        size, dofs, setting = _size_and_setting(c, kind, solved.thermal, cyc)
        done.append(RefinementLevel(level, size, dofs, setting))
        quantities.append(solved.quantities)
        thermals.append(solved.thermal)
    formal = case.thermal.degree + 1.0 if kind == "thermal_mesh" else None
    labels, gaps = branch_labels([level_branch(th) for th in thermals])
    rows = []
    for q, (_, unit) in quantities[0].items():
        values = [lq[q][0] for lq in quantities]
        sizes = [lv.size for lv in done]
        if not all(math.isfinite(v) for v in values):
            continue
        conv = branch_convergence(values, sizes, labels, gaps.get(q), formal_order=formal)
        rows.append(
            RefinementRow(
                q,
                unit,
                conv.values,
                conv.sizes,
                conv.observed_order,
                conv.extrapolated,
                conv.gci,
                conv.u_num,
                conv.asymptotic,
                conv.u_num_at(_value_index(at, levels)),  # the case's level
                conv.branches_differ,
            )
        )
    key = resolution_key(case)
    study = RefinementStudy(
        case.name, kind, factor, at, key, tuple(done), tuple(rows), branches=tuple(labels)
    )
    if comm.rank == 0:
        _write_table(study, out)
        plot(study, out / "refinement.png")
        store_study(study_uncertainty(case, study))
        write_json(out / "refinement.json", study)  # last: marks a complete study
    comm.barrier()
    return study


def thermal_refinement(
    case: Case, out_dir: str | Path, comm: MPI.Comm, factor: float = 1.5
) -> RefinementStudy:
    """The thermal-mesh refinement study (:func:`refinement_study` with kind ``thermal_mesh``)."""
    return refinement_study(case, out_dir, comm, "thermal_mesh", factor)


def study_uncertainty(case: Case, study: RefinementStudy) -> StudyUncertainty:
    """What the uncertainty store keeps of a study: the case level's value and u_num per
    quantity, with the operating point they were measured at."""
    level = study.case_value_index
    return StudyUncertainty(
        kind=study.kind,
        resolution_key=study.resolution_key,
        case=study.case,
        speed_rpm=case.operating.speed_rpm,
        torque_Nm=case.operating.torque_Nm,
        ambient_C=case.thermal.ambient_C,
        factor=study.factor,
        values={r.quantity: r.values[level] for r in study.rows},
        units={r.quantity: r.unit for r in study.rows},
        u_num={r.quantity: r.u_num_case for r in study.rows},
        asymptotic={r.quantity: r.asymptotic for r in study.rows},
        design=STUDY_DESIGN_VERSION,
    )


_TITLES = {
    "thermal_mesh": "Thermal mesh refinement",
    "structural_mesh": "Structural mesh (contact zone) refinement",
    "structural_layers": "Structural layers across the face width",
    "positions": "Positions per pitch",
    "tip": "Tip element size",
}


def _value_headings(n: int) -> list[str]:
    """Headings of a row's values, fine to coarse: fine, medium, coarse for three levels; fine,
    level n-2, ..., level 1, coarse for more (levels numbered from 0, the coarsest)."""
    if n == LEVELS:
        return ["fine", "medium", "coarse"]
    return ["fine", *(f"level {i}" for i in range(n - 2, 0, -1)), "coarse"]


def _write_table(study: RefinementStudy, out: Path) -> None:
    head = [h.replace(" ", "_") for h in _value_headings(len(study.levels))]
    cols = ("quantity", "unit", *head, "order", "extrapolated", "gci")
    tmp = out / f".refinement.csv.tmp{os.getpid()}"
    with tmp.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow([*cols, "u_num_fine", "u_num_case", "asymptotic"])
        for r in study.rows:
            w.writerow(
                [
                    r.quantity,
                    r.unit,
                    *r.values,
                    r.observed_order,
                    r.extrapolated,
                    r.gci,
                    r.u_num,
                    r.u_num_case,
                    r.asymptotic,
                ]
            )
    os.replace(tmp, out / "refinement.csv")
    lines = [
        f"# {_TITLES[study.kind]}: {study.case}",
        "",
        markdown(study),
        "",
    ]
    (out / "refinement.md").write_text("\n".join(lines))


#: how far a level's layer ratio may stray from the study's factor and still count as similar
LAYER_RATIO_TOLERANCE = 0.02


def layer_similarity(study: RefinementStudy) -> str:
    """A caption sentence when a thermal study's levels are not geometrically similar across the
    face width (empty otherwise). The layers are refined with the element sizes but rounded up
    to whole layers (:func:`refined_mesh`), so a case at 4 layers gives 3 / 4 / 6 at factor 1.5:
    refined by 1.33, then 1.5. The representative size h (from the DOFs) averages that over the
    mesh; a quantity the axial resolution governs (the hottest surface temperature in the middle
    of the face width) sees other ratios and may show no order (docs/refinement.md, "Structural
    layers across the face width")."""
    if study.kind != "thermal_mesh":
        return ""
    layers = [lv.setting.get("layers") for lv in study.levels]
    if any(n is None for n in layers):
        return ""
    ratios = [b / a for a, b in itertools.pairwise(layers)]
    if all(abs(r / study.factor - 1.0) <= LAYER_RATIO_TOLERANCE for r in ratios):
        return ""
    return (
        f" The layers across the face width, {' / '.join(str(n) for n in layers)}, refine by "
        f"{', '.join(f'{r:.3g}' for r in ratios)} (rounded up to whole layers), not by "
        f"{study.factor:g}: across the face width the levels are not geometrically similar, and a "
        "quantity the axial resolution governs may show no order; a case whose layers times the "
        "factor are whole numbers (4 / 6 / 9 at 1.5) avoids it."
    )


def markdown(study: RefinementStudy) -> str:
    """The study as a Markdown table with its one-line caption (for refinement.md and docs/)."""
    dofs = ", ".join(str(lv.dofs) for lv in study.levels)
    sizes = ", ".join(f"{lv.size:.4g}" for lv in study.levels)
    head = _value_headings(len(study.levels))  # row values are fine to coarse
    head[study.case_value_index] += " (case)"
    lines = [
        f"{_TITLES[study.kind]}, factor {study.factor:g}: levels coarse to fine with h = {sizes} "
        f"and {dofs} DOFs; the case's resolution is the {study.case_level_name}. Values at the "
        "end of the run." + layer_similarity(study),
        "",
        f"| quantity | unit | {' | '.join(head)} | observed order | extrapolated | "
        "u_num fine | u_num case |",
        "|---|---|" + "---|" * len(head) + "---|---|---|---|",
    ]
    if len(set(study.branches)) > 1:
        lines[0] += (
            " **The levels reached different steady states** (branches, coarse to fine: "
            + ", ".join("-" if b is None else str(b) for b in study.branches)
            + "): the discretisation decides the branch, and u_num is the gap between the "
            "branches (†)."
        )
    for r in study.rows:
        flag = " †" if r.branches_differ else ("" if r.asymptotic else " *")
        vals = " | ".join(f"{v:.4g}" for v in r.values)
        lines.append(
            f"| {r.quantity} | {r.unit} | {vals} | {r.observed_order:.2f}{flag} | "
            f"{r.extrapolated:.4g} | {r.u_num:.3g} | {r.u_num_case:.3g} |"
        )
    lines += [
        "",
        "\\* not in the asymptotic range: Fs = 3 and the order clipped (gearfem/core/gci.py)"
        + (
            ""
            if len(study.levels) == LEVELS
            else "; orders and extrapolations of a least-"
            "squares fit through all levels, u_num with the fit's scatter"
        )
        + ".",
    ]
    return "\n".join(lines)


def plot(study: RefinementStudy, path: Path) -> None:
    """The study's temperatures against h, each relative to the case's value, with the case's
    u_num and the extrapolated values (PNG at ``path``)."""
    import matplotlib  # plotting only here: not imported with the CLI

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(9.0, 4.8))
    rows = [
        r
        for r in study.rows
        if r.unit == "C" and r.quantity.endswith(("max", "mean", "surface", "bulk", "field"))
    ]
    colours = plt.get_cmap("tab20").colors  # one colour per quantity (the default cycle has 10)
    at = study.case_value_index
    for r, colour in zip(rows, colours[::2] + colours[1::2]):
        # each quantity relative to the case's own value: the changes (tenths of a kelvin to a
        # few kelvin) are what the study is about, not the temperatures (100-300 C)
        h = [x / r.sizes[0] for x in r.sizes]
        ref = r.values[at]
        ax.plot(
            h,
            [v - ref for v in r.values],
            "o-",
            color=colour,
            label=f"{r.quantity} {ref:.1f} ± {r.u_num_case:.2g} K{'' if r.asymptotic else ' *'}",
        )
        shift = 0.012 * (max(h) - 1.0) * (rows.index(r) - len(rows) / 2)  # bars side by side
        ax.errorbar(h[at] + shift, 0.0, yerr=r.u_num_case, color=colour, capsize=2, lw=1)
        ax.plot([0.0], [r.extrapolated - ref], "*", color=colour, ms=10)
    ax.axhline(0.0, color="0.5", lw=0.8)
    ax.set_xlabel("relative size h / h_fine (★: extrapolated to h = 0)")
    ax.set_ylabel("change from the case's value (K)")
    ax.set_title(
        f"{_TITLES[study.kind]}, factor {study.factor:g}, {len(study.levels)} levels\n"
        "(bar at the case's level: ± u_num of the case; *: outside the asymptotic range)",
        fontsize=10,
    )
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.01, 0.5))
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
