"""Fold margins of a verdict whose friction law is bistable: how far each data point lies from the
fold that decides the branch it runs on.

A friction heat that rises with temperature (μ stepping up at the glass transition) can give a
gear a cool and a hot steady state. A run from ambient ends on the lowest steady state above its
start: the heat equation with a source that does not fall with temperature keeps an ordered pair
of solutions ordered (comparison principle), so the transient from ambient rises monotonically and
stops at the first steady state it meets — the cool one wherever the cool branch exists. Which
branch a data point lands on is therefore decided by whether the cool branch exists there, and
the cool branch ends at its fold (a saddle-node, where it meets the unstable middle branch).

The **margin** of a point in a parameter p is p_fold − p at the verdict's values: positive, the
point lands on the cool branch and would jump to the hot one if p rose by the margin; negative, it
lands on the hot branch and would come down only if p fell by that much. Parameters:

* the **fitted parameter** (the winner's, e.g. glassy μ): the law itself is changed
  (:meth:`gearfem.coupling.friction_heat.ThermalFrictionFlux.set_law`);
* the **torque**, to first order the friction-heat scale λ (the flank heat is proportional to the
  load at a given μ and speed; :meth:`gearfem.thermal.problem.ThermalProblem.set_friction_scale`):
  torque margin = (λ_fold − 1) × torque;
* the **ambient**, to first order a uniform shift of every temperature, which the law sees as its
  transition moved the other way (glass_transition_C − ΔT): this margin, in kelvin, is also the
  margin of the contact temperature that decides the branch, to be compared with that
  temperature's numerical uncertainty;
* the **stated flash half-width** (``[friction] flash_width = "stated"``), a modelling choice
  without a source: the bands read with another width
  (:meth:`gearfem.coupling.friction_heat.ThermalFrictionFlux.set_band_model`). A wider contact
  spreads the same heat, so its flash is cooler: the margin is the stated width minus the fold's
  (positive: lands cool, and jumps if the width shrank by the margin), searched within a factor
  :data:`FLASH_WIDTH_SPAN` of the stated width and compared with :data:`FLASH_WIDTH_RELATIVE_U`
  of it;
* the camera's view, aim and blur change what the camera reads, not the heat balance: they move no
  fold.

A case that splits the friction heat by contact temperature (both gears' runs solved together) is
traced one gear at a time with the pinion's share held at the one the verdict's model reaches at
the point (:func:`gearfem.diagnose.report.margin_case`): first-order, as the torque's and the
ambient's margins are.

Method (:func:`gearfem.thermal.branches.trace_lowest_branch`): natural-parameter continuation of
the cool branch from a value where it exists, stepping towards the fold with step halving. A few
tens of steady solves per gear and parameter, no transient.
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Sequence
from pathlib import Path

from mpi4py import MPI

from gearfem import pipeline
from gearfem.config import Case
from gearfem.contact.friction import FLASH_HALF_WIDTH_RANGE_UM, dma_glass_transition_C
from gearfem.core.results import JsonRecord
from gearfem.core.tasks import run_split
from gearfem.diagnose.candidates import LIBRARY, Candidate, apply_all, by_name
from gearfem.geometry.options import BODIES
from gearfem.thermal.branches import (
    SAFE_SCALE,
    Fold,
    cool_at_full_heat,
    trace_lowest_branch,
)

log = logging.getLogger(__name__)


@dataclasses.dataclass(frozen=True)
class FoldMargin(JsonRecord):
    """One data point's margin to the fold of one gear in one parameter.

    ``value``: the parameter at the verdict; ``fold``: where the gear's cool branch ends (None:
    not within the searched range); ``margin`` = fold − value (value − fold for the flash
    half-width, whose rise cools; positive: lands cool; negative: lands hot; None: no fold
    found, i.e. the point stays on the cool branch over the range, or never reaches it);
    ``uncertainty``: what the parameter is known to (its interval's half-width, the torque
    meter's uncertainty, the ambient's ± 2 K with the contact temperature's numerical
    uncertainty, a stated flash half-width's :data:`FLASH_WIDTH_RELATIVE_U`); ``fragile``: the
    fold lies within that uncertainty."""

    speed_rpm: float
    torque_Nm: float
    ambient_C: float
    gear: str
    parameter: str
    unit: str
    value: float
    fold: float | None
    margin: float | None
    lands: str
    uncertainty: float
    fragile: bool
    solves: int


def _margin(
    point: tuple[float, float, float],
    gear: str,
    parameter: str,
    unit: str,
    value: float,
    fold: Fold,
    uncertainty: float,
    to_value=lambda p: p,
    heat_falls: bool = False,
) -> FoldMargin:
    """``heat_falls``: a parameter whose rise cools the contact (the flash half-width), whose
    margin is value − fold (positive: lands cool)."""
    f = fold.fold
    fv = to_value(f) if f is not None else None
    margin = None if fv is None else (value - fv if heat_falls else fv - value)
    if margin is not None:
        lands = "cool" if margin > 0.0 else "hot"
    else:  # no fold within the range searched: cool over all of it, or never cool
        lands = "cool" if fold.cool is not None else "hot"
    fragile = margin is not None and abs(margin) <= uncertainty
    return FoldMargin(
        *point, gear, parameter, unit, value, fv, margin, lands, uncertainty, fragile, fold.solves
    )


def fold_margins(
    case: Case,
    points: Sequence[tuple[float, float, float]],
    params: dict[str, float],
    comm: MPI.Comm,
    interval_half_width: dict[str, float] | None = None,
    torque_u_Nm: float = 0.0,
    temperature_u_K: float = 2.0,
    cycle=None,
    library: tuple[Candidate, ...] = LIBRARY,
    mesh_cache: Path | None = None,
) -> list[FoldMargin]:
    """The fold margins of every data point (speed, torque, ambient) and gear for the model
    ``params`` (the winner at its fitted values) on ``case``: in each fitted parameter, the
    torque and the ambient (see the module docstring). Collective; the two gears run on ranks of
    their own (:func:`gearfem.core.tasks.run_split`). ``cycle(torque_Nm)`` gives the structural
    cycle of a torque (default: :func:`gearfem.pipeline.cycle`); ``interval_half_width`` per
    parameter, ``torque_u_Nm`` (the torque meter) and ``temperature_u_K`` (ambient and contact
    temperature) say what is fragile."""
    model_case = apply_all(case, params, library)
    law = model_case.friction_law()
    if not law.may_rise_with_temperature:
        return []
    cycles = {}

    def cycle_of(torque: float):
        if torque not in cycles:
            cycles[torque] = (
                cycle(torque)
                if cycle is not None
                else pipeline.cycle(case.with_operating(torque_Nm=torque), comm)[0]
            )
        return cycles[torque]

    half = interval_half_width or {}
    out: list[FoldMargin] = []
    for speed, torque, ambient in points:
        cyc = cycle_of(torque)  # collective, before the gears split

        def one_gear(gear: str, sub: MPI.Comm, speed=speed, torque=torque, ambient=ambient):
            c = model_case.with_operating(speed_rpm=speed, torque_Nm=torque)
            c = dataclasses.replace(
                c,
                thermal=dataclasses.replace(
                    c.thermal, body=gear, mode="steady", ambient_C=ambient, output_times_s=()
                ),
            )
            setup = pipeline.thermal_problem(c, sub, cyc, mesh_cache)
            problem = setup.problem
            flux = problem.sources.flank_flux_model
            found = []
            point = (speed, torque, ambient)
            with problem:
                # the torque, to first order the friction-heat scale: the cool branch from a fifth
                # of the heat upwards
                fold, x = trace_lowest_branch(
                    problem, problem.set_friction_scale, SAFE_SCALE, 3.0, 1.0, proportional=True
                )
                _destroy(x)
                found.append(
                    _margin(
                        point,
                        gear,
                        "torque",
                        "N m",
                        torque,
                        fold,
                        torque_u_Nm,
                        to_value=lambda lam, torque=torque: lam * torque,
                    )
                )
                # the fitted parameters: the law itself changed, traced from the prior's lower
                # end (reached from a fifth of the heat) upwards
                for name, v in params.items():
                    cand = by_name(name, library)
                    prm = cand.parameter
                    others = {k: w for k, w in params.items() if k != name}

                    def set_value(p, cand=cand, others=others):
                        varied = apply_all(case, {**others, cand.name: p}, library)
                        flux.set_law(varied.friction_law())

                    set_value(prm.lo)
                    fold = Fold(None, prm.lo, prm.hi, 0)
                    full, x = cool_at_full_heat(problem)
                    n = full.solves
                    if full.gone is None:
                        fold, y = trace_lowest_branch(
                            problem,
                            set_value,
                            prm.lo,
                            prm.hi,
                            prm.hi - prm.lo,
                            x0=x,
                            proportional=name == "friction_glass_transition",
                        )
                        _destroy(y)
                    _destroy(x)
                    fold = dataclasses.replace(fold, solves=fold.solves + n)
                    problem.set_friction_scale(1.0)
                    flux.set_law(law)  # the trace left the law at its last value
                    found.append(_margin(point, gear, name, prm.unit, v, fold, half.get(name, 0.0)))

                bm = flux.band_model
                if bm.flash_width == "stated":
                    found.append(_flash_width_margin(problem, flux, law, bm, point, gear))

                # the ambient, to first order every temperature shifted: the law's shifted back;
                # traced from 60 K cooler (reached from a fifth of the heat) upwards
                def set_shift(dT):
                    shifted = _shifted(model_case.friction, dT)
                    flux.set_law(shifted.law_for(model_case.contact.friction_coefficient))

                set_shift(-SHIFT_RANGE_K)
                fold = Fold(None, -SHIFT_RANGE_K, SHIFT_RANGE_K, 0)
                full, x = cool_at_full_heat(problem)
                n = full.solves
                if full.gone is None:
                    fold, y = trace_lowest_branch(
                        problem, set_shift, -SHIFT_RANGE_K, SHIFT_RANGE_K, SHIFT_RANGE_K, x0=x
                    )
                    _destroy(y)
                _destroy(x)
                fold = dataclasses.replace(fold, solves=fold.solves + n)
                problem.set_friction_scale(1.0)
                flux.set_law(law)
                found.append(_margin(point, gear, "ambient", "K", 0.0, fold, temperature_u_K))
            return found

        for gear_margins in run_split(comm, BODIES, one_gear).values():
            out.extend(gear_margins)
    return out


#: How far the ambient (every temperature) is shifted either way in the search for its fold (K).
SHIFT_RANGE_K = 60.0
#: The stated flash half-width's search range: this factor either way of the stated value. The
#: two lengths docs/friction.md compares, the tip round's Hertz half-width (about 100 um on the
#: thesis pair) and the nominal load's at the pitch point (about 300 um), differ by it.
FLASH_WIDTH_SPAN = 3.0
#: What the stated flash half-width is taken to be known to, as a fraction of itself: a length
#: without a source (assumed; the switching flank temperature moves by 30-80 K between 100 and
#: 300 um, docs/friction.md).
FLASH_WIDTH_RELATIVE_U = 0.5


def _flash_width_margin(problem, flux, law, bm, point, gear: str) -> FoldMargin:
    """The margin in the stated flash half-width (``[friction] flash_half_width_um``) of the
    model's ``law``: the bands read with another width
    (:meth:`ThermalFrictionFlux.set_band_model`), the cool branch traced from the widest of the
    range (the coolest flash) towards the narrowest."""
    flux.set_law(law)
    w = bm.flash_half_width_m * 1e6
    lo_range, _ = FLASH_HALF_WIDTH_RANGE_UM
    wide, narrow = w * FLASH_WIDTH_SPAN, max(w / FLASH_WIDTH_SPAN, lo_range)

    def set_width(w_um: float) -> None:
        flux.set_band_model(dataclasses.replace(bm, flash_half_width_m=w_um * 1e-6))

    set_width(wide)
    fold = Fold(None, wide, narrow, 0)
    full, x = cool_at_full_heat(problem)
    n = full.solves
    if full.gone is None:
        fold, y = trace_lowest_branch(problem, set_width, wide, narrow, wide - narrow, x0=x)
        _destroy(y)
    _destroy(x)
    fold = dataclasses.replace(fold, solves=fold.solves + n)
    problem.set_friction_scale(1.0)
    flux.set_band_model(bm)
    return _margin(
        point,
        gear,
        "flash half-width",
        "um",
        w,
        fold,
        FLASH_WIDTH_RELATIVE_U * w,
        heat_falls=True,
    )


def _destroy(x) -> None:
    if x is not None:
        x.destroy()


def _shifted(friction, dT_K: float):
    """The friction options with every temperature the law sees raised by ``dT_K``: its transition
    (and reference and range) moved down by it."""
    changes = {}
    if friction.law == "glass_transition":
        tg = friction.glass_transition_C
        changes["glass_transition_C"] = (tg if tg is not None else dma_glass_transition_C()) - dT_K
    if friction.temperature_coefficient_per_K != 0.0:
        lo, hi = friction.temperature_range_C
        changes["reference_C"] = friction.reference_C - dT_K
        changes["temperature_range_C"] = (lo - dT_K, hi - dT_K)
    if friction.law == "table":
        t, m = friction.table_C
        changes["table_C"] = (tuple(x - dT_K for x in t), m)
        changes["table_file"] = None
    return dataclasses.replace(friction, **changes)


def fragile(margins: Sequence[FoldMargin]) -> list[FoldMargin]:
    """The margins that lie within their parameter's uncertainty."""
    return [m for m in margins if m.fragile]


def markdown(margins: Sequence[FoldMargin]) -> str:
    """The margins as a Markdown table with a one-line summary."""
    if not margins:
        return "No fold margins: the chosen model has one steady state at every point."
    rows = [
        "| point | gear | parameter | at the verdict | fold | margin | lands | uncertainty | |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for m in margins:
        fold = "-" if m.fold is None else f"{m.fold:.4g}"
        margin = "beyond the range" if m.margin is None else f"{m.margin:+.3g} {m.unit}"
        rows.append(
            f"| {m.speed_rpm:g} rpm, {m.torque_Nm:g} N m | {m.gear} | {m.parameter} | "
            f"{m.value:.4g} {m.unit} | {fold} | {margin} | {m.lands} | ± {m.uncertainty:.3g} | "
            f"{'**fragile**' if m.fragile else 'robust'} |"
        )
    bad = fragile(margins)
    head = (
        f"**Fragile**: {len(bad)} of {len(margins)} margins lie within their parameter's "
        "uncertainty: "
        + "; ".join(
            f"{m.speed_rpm:g} rpm / {m.torque_Nm:g} N m {m.gear} in {m.parameter} "
            f"({m.margin:+.3g} {m.unit}, ± {m.uncertainty:.3g})"
            for m in bad
        )
        if bad
        else "Robust: every fold lies beyond its parameter's uncertainty."
    )
    return head + "\n\n" + "\n".join(rows)


__all__ = [
    "FoldMargin",
    "fold_margins",
    "fragile",
    "markdown",
]
