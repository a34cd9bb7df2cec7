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
* the camera's view, aim and blur change what the camera reads, not the heat balance: they move no
  fold.

Method (:func:`cool_branch_fold`): natural-parameter continuation of the cool branch from a value
where it exists (Newton from ambient), stepping towards the fold; a step whose Newton fails, or
whose friction heat leaves the cool branch (grows by more than :data:`JUMP_RATIO` in one step),
is halved, until the step is below the tolerance: the fold lies between the last cool solution
and the first failure. A few tens of steady solves per gear and parameter, no transient.
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Callable, Sequence
from pathlib import Path

from mpi4py import MPI

from gearfem import pipeline
from gearfem.config import Case
from gearfem.contact.friction import dma_glass_transition_C
from gearfem.core.errors import ConvergenceError
from gearfem.core.results import JsonRecord
from gearfem.core.tasks import run_split
from gearfem.diagnose.candidates import LIBRARY, Candidate, apply_all, by_name
from gearfem.geometry.options import BODIES

log = logging.getLogger(__name__)

#: A continuation step whose friction heat grows by more than this factor has left the cool
#: branch (the branches of the glass step differ by the ratio of the two mu, about 3; a step on
#: one branch changes the heat by a few per cent).
JUMP_RATIO = 1.25
#: Steps of the continuation: the first, and the smallest (the fold's bracket), as fractions of
#: the parameter's scale.
FIRST_STEP = 0.1
TOLERANCE = 2e-3


@dataclasses.dataclass(frozen=True)
class Fold(JsonRecord):
    """Where the cool branch of one gear ends in one parameter.

    ``fold``: the middle of the bracket [``cool``, ``gone``] (the last parameter value with a cool
    steady state, the first without); ``None`` when the cool branch did not end within the
    searched range (``limit``). ``solves``: steady solves spent."""

    cool: float | None
    gone: float | None
    limit: float
    solves: int

    @property
    def fold(self) -> float | None:
        if self.cool is None or self.gone is None:
            return None
        return 0.5 * (self.cool + self.gone)


def cool_branch_fold(
    problem,
    set_parameter: Callable[[float], None],
    start: float,
    limit: float,
    scale: float,
    x0=None,
    tolerance: float = TOLERANCE,
) -> tuple[Fold, object]:
    """Trace the cool branch of ``problem`` in a parameter from ``start`` towards ``limit`` and
    bracket its fold (collective). Returns the fold and the last cool state (a PETSc Vec of the
    problem's unknowns, the caller's to destroy; None when there was none).

    ``set_parameter(p)`` sets the parameter on the problem. The trace starts from the state
    ``x0`` (a cool steady state at ``start``), or, without one, from Newton from ambient at
    ``start``, which must then be a value where the cool branch surely exists (a start from
    which Newton fails gives ``Fold(None, start, ...)``). Steps start at :data:`FIRST_STEP` ×
    ``scale`` and are halved at a failure down to ``tolerance`` × ``scale``.
    """
    direction = 1.0 if limit >= start else -1.0
    solves = 0

    def solve(p: float, x) -> float | None:
        """The friction heat of the steady state at p from the state x (None: ambient), or None
        when Newton fails."""
        nonlocal solves
        set_parameter(p)
        if x is None:
            problem.set_initial(problem.initial_K)
        else:
            problem.set_state(x)
        solves += 1
        try:
            rec = problem.solve_steady()
        except ConvergenceError:
            return None
        return float(rec.balance.friction_W)

    heat = solve(start, x0)
    if heat is None:
        return Fold(None, start, limit, solves), None
    x = problem.state_vector()
    p, step = start, FIRST_STEP * scale
    while step >= tolerance * scale:
        q = p + direction * step
        if (q - limit) * direction > 0.0:
            q = limit
        h = solve(q, x)
        if h is not None and h <= JUMP_RATIO * max(heat, 1e-300):
            p, heat = q, h
            x.destroy()
            x = problem.state_vector()
            if p == limit:
                return Fold(p, None, limit, solves), x
        else:
            step *= 0.5
    set_parameter(p)
    problem.set_state(x)
    return Fold(p, p + direction * 2.0 * step, limit, solves), x


#: Friction-heat scale at which every trace starts (Newton from ambient): a fifth of the heat,
#: far below any fold of the cool branch.
SAFE_SCALE = 0.2


def _cool_at_full_heat(problem, start_state=None) -> tuple[bool, object, int]:
    """From the cool state at the friction-heat scale :data:`SAFE_SCALE` (Newton from ambient),
    the cool branch traced to the full heat (scale 1): (whether it reaches it, its state there or
    None, solves)."""
    fold, x = cool_branch_fold(problem, problem.set_friction_scale, SAFE_SCALE, 1.0, 1.0)
    reached = fold.gone is None and fold.cool == 1.0
    if not reached and x is not None:
        x.destroy()
        x = None
    return reached, x, fold.solves


@dataclasses.dataclass(frozen=True)
class FoldMargin(JsonRecord):
    """One data point's margin to the fold of one gear in one parameter.

    ``value``: the parameter at the verdict; ``fold``: where the gear's cool branch ends (None:
    not within the searched range); ``margin`` = fold − value (positive: lands cool; negative:
    lands hot; None: no fold found, i.e. the point stays on the cool branch over the range, or
    never reaches it); ``uncertainty``: what the parameter is known to (its interval's half-width,
    the torque meter's uncertainty, the ambient's ± 2 K with the contact temperature's numerical
    uncertainty); ``fragile``: the fold lies within that uncertainty."""

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
) -> FoldMargin:
    f = fold.fold
    fv = to_value(f) if f is not None else None
    margin = None if fv is None else fv - value
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
                fold, x = cool_branch_fold(
                    problem, problem.set_friction_scale, SAFE_SCALE, 3.0, 1.0
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
                    cool, x, n = _cool_at_full_heat(problem)
                    if cool:
                        fold, y = cool_branch_fold(
                            problem, set_value, prm.lo, prm.hi, prm.hi - prm.lo, x0=x
                        )
                        _destroy(y)
                    _destroy(x)
                    fold = dataclasses.replace(fold, solves=fold.solves + n)
                    problem.set_friction_scale(1.0)
                    found.append(_margin(point, gear, name, prm.unit, v, fold, half.get(name, 0.0)))

                # the ambient, to first order every temperature shifted: the law's shifted back;
                # traced from 60 K cooler (reached from a fifth of the heat) upwards
                def set_shift(dT):
                    shifted = _shifted(model_case.friction, dT)
                    flux.set_law(shifted.law_for(model_case.contact.friction_coefficient))

                set_shift(-SHIFT_RANGE_K)
                fold = Fold(None, -SHIFT_RANGE_K, SHIFT_RANGE_K, 0)
                cool, x, n = _cool_at_full_heat(problem)
                if cool:
                    fold, y = cool_branch_fold(
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
    "FIRST_STEP",
    "JUMP_RATIO",
    "TOLERANCE",
    "Fold",
    "FoldMargin",
    "cool_branch_fold",
    "fold_margins",
    "fragile",
    "markdown",
]
