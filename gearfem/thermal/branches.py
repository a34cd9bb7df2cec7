"""Several steady states of one thermal problem: finding them, their stability, and continuation.

A heat source that grows with temperature (friction whose mu rises across the glass transition at
the contact temperature) can give the steady problem F(T) = 0 several solutions: a cool branch, a
hot branch and, between them, an unstable one. Which one a gear runs on depends on its history;
the transient from a cold start picks the physical one.

* **Starts** (:func:`steady_states`): Newton's method for the steady state from several initial
  temperature fields (ambient, the end of the transient, a hot uniform field); the distinct
  solutions are the branches found at this operating point. A start from which Newton fails
  (no solution nearby, the heating runs away) is reported, not raised.
* **Stability** (:func:`stability_eigenvalue`): the linearised transient M dδT/dt = -J δT is stable
  when every eigenvalue of J v = λ M v (M = ρ c_p(T) mass matrix, J the steady Jacobian) has a
  positive real part. The eigenvalue nearest zero decides (it is the one that crosses zero where
  a branch turns): SLEPc, shift-and-invert at 0 with an LU factorisation (MUMPS). Its inverse is
  the slowest time constant of the state (s); negative: the state is unstable.
* **Continuation** (:func:`continuation`): pseudo-arclength continuation in the friction-heat scale
  λ (:meth:`ThermalProblem.set_friction_scale`; heat input proportional to λ, as the load p·v of a
  lumped model, or to first order the torque), with Keller's bordering of the Jacobian: through
  turning points, so that every branch between λ_min and λ_max is traced and the turning points
  (where dλ/ds changes sign) are located.

The solver for these systems is GMRES preconditioned by an LU factorisation (MUMPS): the Jacobian
is not positive definite on an unstable branch.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Callable
from typing import Any

import numpy as np
from mpi4py import MPI

from gearfem.core.errors import ConvergenceError, ParameterError
from gearfem.core.materials import ZERO_CELSIUS_K
from gearfem.core.results import JsonRecord
from gearfem.thermal.newton import Effort

log = logging.getLogger(__name__)

#: Largest angle between the tangents at the two ends of a continuation step (rad): a step that
#: turns more is retaken at half the length (the curve's folds are resolved).
MAX_TURN_RAD = 0.2


@dataclasses.dataclass(frozen=True)
class SteadyState(JsonRecord):
    """One steady state found from one start (``converged`` False: Newton failed from there;
    ``same_as`` names an earlier start that reached the same state)."""

    start: str
    converged: bool
    temperatures_C: dict[str, float]
    friction_W: float | None
    generated_W: float | None
    newton_iterations: int
    eigenvalue_per_s: float | None
    stable: bool | None
    same_as: str | None = None
    message: str = ""


def _ksp(comm, prefix: str):
    from petsc4py import PETSc

    ksp = PETSc.KSP().create(comm)
    ksp.setOptionsPrefix(prefix)
    ksp.setType("gmres")
    pc = ksp.getPC()
    pc.setType("lu")
    pc.setFactorSolverType("mumps")
    ksp.setTolerances(rtol=1e-12, atol=1e-30, max_it=200)
    ksp.setFromOptions()
    return ksp


def stability_eigenvalue(problem) -> float:
    """Real part of the eigenvalue of J v = λ M v nearest zero at the current T (1/s; collective).
    Positive: stable."""
    from slepc4py import SLEPc

    J, _ = problem.steady_system()
    M = problem.heat_capacity_matrix()
    eps = SLEPc.EPS().create(problem.comm)
    try:
        eps.setOptionsPrefix(problem.petsc_prefix + "stability_")
        eps.setOperators(J, M)
        eps.setProblemType(SLEPc.EPS.ProblemType.GNHEP)
        eps.setDimensions(nev=1)
        eps.setTarget(0.0)
        eps.setWhichEigenpairs(SLEPc.EPS.Which.TARGET_MAGNITUDE)
        st = eps.getST()
        st.setType(SLEPc.ST.Type.SINVERT)
        ksp = st.getKSP()
        ksp.setType("preonly")
        pc = ksp.getPC()
        pc.setType("lu")
        pc.setFactorSolverType("mumps")
        eps.setTolerances(1e-10, 200)
        eps.setFromOptions()
        eps.solve()
        if eps.getConverged() < 1:
            raise ConvergenceError("SLEPc EPS", "no eigenvalue converged", "stability")
        vals = [eps.getEigenvalue(i) for i in range(eps.getConverged())]
        lam = min(vals, key=abs)
        return float(lam.real)
    finally:
        eps.destroy()
        M.destroy()


def _record(problem, start: str, its: int, message: str = "") -> SteadyState:
    bal = problem.heat_balance()
    lam = stability_eigenvalue(problem)
    return SteadyState(
        start=start,
        converged=True,
        temperatures_C={k: v - ZERO_CELSIUS_K for k, v in problem.temperatures_K().items()},
        friction_W=float(bal.friction_W),
        generated_W=float(bal.generated_W),
        newton_iterations=its,
        eigenvalue_per_s=lam,
        stable=lam > 0.0,
        message=message,
    )


def steady_states(
    problem, starts: dict[str, Any], same_tolerance_K: float = 0.05
) -> list[SteadyState]:
    """The steady state reached by Newton from each start (name -> kelvin value, Function or
    callable as :meth:`ThermalProblem.set_initial` takes), with its stability. Two states whose
    nodal temperatures differ by less than ``same_tolerance_K`` are the same (``same_as``). The
    problem's temperature is left at the last state found (collective)."""
    out: list[SteadyState] = []
    fields: list[tuple[str, np.ndarray]] = []
    for name, T0 in starts.items():
        problem.set_initial(T0)
        try:
            rec = problem.solve_steady()
        except ConvergenceError as err:
            out.append(SteadyState(name, False, {}, None, None, 0, None, None, message=str(err)))
            continue
        arr = problem.T.x.array.copy()
        n = problem.V.dofmap.index_map.size_local
        same = None
        for other, a in fields:
            d = float(np.max(np.abs(arr[:n] - a[:n]))) if n else 0.0
            if problem.comm.allreduce(d, op=MPI.MAX) < same_tolerance_K:
                same = other
                break
        st = _record(problem, name, rec.newton_iterations)
        out.append(dataclasses.replace(st, same_as=same))
        if same is None:
            fields.append((name, arr))
    return out


def _crossing(problem, T_prev, lam_prev: float, lam: float, target: float, k: int) -> SteadyState:
    """Newton at the scale ``target`` from the field interpolated between the last two points of
    the curve (the current T at ``lam``, ``T_prev`` at ``lam_prev``); T is restored after."""
    keep = problem.state_vector()
    T = keep.copy()
    s = (target - lam_prev) / (lam - lam_prev) if lam != lam_prev else 1.0
    T.scale(s)
    T.axpy(1.0 - s, T_prev)
    problem.set_state(T)
    T.destroy()
    problem.set_friction_scale(target)
    name = f"continuation {k + 1} at scale {target:g}"
    try:
        rec = problem.solve_steady()
        out = _record(problem, name, rec.newton_iterations)
    except ConvergenceError as err:
        out = SteadyState(name, False, {}, None, None, 0, None, None, message=str(err))
    problem.set_state(keep)
    keep.destroy()
    return out


#: The Newton work of a probe: a continuation's step (:func:`trace_lowest_branch`) and the check
#: from ambient (:func:`lowest_steady_state`), whose failure is an answer (beyond the fold; no
#: state near ambient). A probe that fails does so after several iterations each ending in a long
#: line search, and with the solver's defaults (25 iterations, 12 halvings) the failures were 60 %
#: of the branch search's solve time. Measured on the built-in case (glass-transition law at
#: mu_g 0.10-0.20, 1000 rpm / 8 N m and 2000 rpm / 4 N m, both gears; 257 probes that
#: converged): at most 9 iterations and 9 halvings (step 2^-9) in any probe that converged. With
#: this effort the same 257 probes converge to the same states, the failed ones take 50 s instead
#: of 66 s (rank 0) and the 12 evaluations 206 s instead of 227 s.
PROBE_EFFORT = Effort(max_it=15, max_halvings=10)

#: A continuation step whose friction heat grows by more than this factor has left the cool
#: branch (the branches of the glass step differ by the ratio of the two mu, about 3; a step on
#: one branch changes the heat by a few per cent).
JUMP_RATIO = 1.25
#: Steps of the continuation: the first, and the smallest (the fold's bracket), as fractions of
#: the parameter's scale. (Doubling the step after a step of at most two Newton iterations, up to
#: 0.4, until the first failure: 26 % fewer converged probes but 30 % more failed ones on the
#: built-in case, 3 % slower; not adopted.)
FIRST_STEP = 0.1
TOLERANCE = 2e-3


@dataclasses.dataclass(frozen=True)
class Fold(JsonRecord):
    """Where the lowest (cool) branch ends in a parameter, traced from ``start`` towards
    ``limit`` (:func:`trace_lowest_branch`).

    ``cool``: the last parameter value with a state on the branch; ``gone``: the first without
    (the fold lies between them); ``cool = None``: none at the start; ``gone = None``: the branch
    reached ``limit``. ``solves``: steady solves spent."""

    cool: float | None
    gone: float | None
    limit: float
    solves: int

    @property
    def fold(self) -> float | None:
        """The middle of the bracket (None: no fold within the range)."""
        if self.cool is None or self.gone is None:
            return None
        return 0.5 * (self.cool + self.gone)


def trace_lowest_branch(
    problem,
    set_parameter: Callable[[float], None],
    start: float,
    limit: float,
    scale: float,
    x0=None,
    tolerance: float = TOLERANCE,
    proportional: bool = False,
) -> tuple[Fold, object]:
    """Trace the cool branch of ``problem`` in a parameter from ``start`` towards ``limit`` and
    bracket its fold (collective). Returns the fold and the last cool state (a PETSc Vec of the
    problem's unknowns, the caller's to destroy; None when there was none).

    ``set_parameter(p)`` sets the parameter on the problem. The trace starts from the state
    ``x0`` (a cool steady state at ``start``), or, without one, from Newton from ambient at
    ``start``, which must then be a value where the cool branch surely exists (a start from
    which Newton fails gives ``Fold(None, start, ...)``). Steps start at :data:`FIRST_STEP` ×
    ``scale`` and are halved at a failure down to ``tolerance`` × ``scale``. A step fails when
    Newton fails or the friction heat jumps by more than :data:`JUMP_RATIO` (with
    ``proportional``, a parameter the heat is proportional to on a branch, such as the heat scale
    or a glassy mu: the heat per unit parameter).
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
            rec = problem.solve_steady(PROBE_EFFORT)
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
        grow = q / p if proportional and p != 0.0 and q / p > 0.0 else 1.0
        if h is not None and h <= JUMP_RATIO * grow * max(heat, 1e-300):
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


def cool_at_full_heat(problem, tolerance: float = TOLERANCE) -> tuple[Fold, Any]:
    """The lowest branch from its state at the friction-heat scale :data:`SAFE_SCALE` (Newton
    from ambient) traced to the full heat (scale 1): the fold (``gone`` None: it reached the
    full heat) and its last state (a PETSc Vec, the caller's to destroy; None when Newton failed
    at the start)."""
    return trace_lowest_branch(
        problem,
        problem.set_friction_scale,
        SAFE_SCALE,
        1.0,
        1.0,
        tolerance=tolerance,
        proportional=True,
    )


@dataclasses.dataclass(frozen=True)
class LowestState(JsonRecord):
    """The steady state a run from ambient ends on, found by continuation
    (:func:`lowest_steady_state`): ``branch`` is ``"lowest"`` when the lowest branch reaches
    the full heat, ``"above the fold"`` when it ends before (``fold_scale``: where) and the state
    is the one the transient from the fold reaches at the full heat."""

    branch: str
    fold_scale: float | None
    solves: int


#: The bracket of the fold to which :func:`lowest_steady_state` traces the lowest branch (in the
#: heat scale): its run-away starts that close to the fold.
LOWEST_TOLERANCE = 0.02

#: Above the fold (:func:`lowest_steady_state`): the hot start's uniform temperature lies this
#: far above the hottest node of the last state on the lowest branch (K).
HOT_START_ABOVE_K = 150.0


def lowest_steady_state(problem, settle_s: float = 1800.0, max_settles: int = 4):
    """The steady state a transient from ambient reaches, without resolving the transient
    (collective).

    With a heat source that does not fall with temperature, a transient that starts below every
    steady state rises monotonically and ends on the lowest steady state above its start
    (comparison principle): the lowest branch, continued in the friction-heat scale from
    :data:`SAFE_SCALE` (where it is the only state near ambient), if it reaches the full heat.

    If the lowest branch ends at a fold before the full heat, the run goes on from the fold to the
    next stable state up. For the S-shaped response of a glass step (a cool and a hot branch) that
    is the hot branch, which Newton from a uniform start :data:`HOT_START_ABOVE_K` above the fold
    state's hottest node finds; it is taken when it lies above the fold state everywhere (the
    order the transient keeps). Otherwise the transient from the fold state is integrated
    (``settle_s``, doubled while the steady solve from its end fails, ``max_settles`` times).
    The continuation's steps can pass a small fold where only a part of the contacts switches
    (states a per cent apart in heat, below the step's jump criterion): the state Newton reaches
    from ambient at the full heat is therefore solved as well and taken when it lies below the
    continuation's everywhere (:func:`_lower_from_ambient`). Returns the steady record (as
    :meth:`ThermalProblem.solve_steady`) and how it was found; the friction scale is restored to
    1."""
    rec, how = _continued_lowest_state(problem, settle_s, max_settles)
    return _lower_from_ambient(problem, rec, how)


#: :func:`_lower_from_ambient` takes the state from ambient when it lies below the continuation's
#: everywhere within this (K) and somewhere by more.
BELOW_K = 0.5


def _lower_from_ambient(problem, rec, how: LowestState):
    """``rec`` (the problem at that state), or the steady state Newton reaches from ambient at
    the full heat when that one lies below it at every node (by :data:`BELOW_K`, and somewhere
    by more): a transient from ambient stays below every steady state above its start
    (comparison principle), so it cannot end on ``rec`` then (collective)."""
    found = problem.state_vector()
    n = problem.V.dofmap.index_map.size_local
    above = problem.T.x.array[:n].copy()
    try:
        problem.set_initial(problem.initial_K)
        try:
            cold = problem.solve_steady(PROBE_EFFORT)
        except ConvergenceError:
            cold = None
        if cold is not None:
            d = problem.T.x.array[:n] - above
            up = problem.comm.allreduce(float(np.max(d)) if n else -np.inf, op=MPI.MAX)
            down = problem.comm.allreduce(float(np.min(d)) if n else np.inf, op=MPI.MIN)
            if up <= BELOW_K and down < -BELOW_K:
                return cold, LowestState("from ambient, below the continuation's", None,
                                         how.solves + 1)  # fmt: skip
        problem.set_state(found)  # back to the continuation's state, the flux model with it
        return problem.solve_steady(), dataclasses.replace(how, solves=how.solves + 2)
    finally:
        found.destroy()


def _continued_lowest_state(problem, settle_s: float, max_settles: int):
    """:func:`lowest_steady_state` by continuation alone."""
    # the fold is bracketed only as far as the next state up needs a start near it
    fold, x = cool_at_full_heat(problem, tolerance=LOWEST_TOLERANCE)
    solves = fold.solves
    try:
        if fold.gone is None:
            problem.set_friction_scale(1.0)
            problem.set_state(x)
            rec = problem.solve_steady()
            return rec, LowestState("lowest", None, solves + 1)
        problem.set_friction_scale(1.0)
        if x is not None:
            problem.set_state(x)
        below = problem.T.x.array.copy()
        top = problem.temperatures_K()["max_surface"]
        problem.set_initial(top + HOT_START_ABOVE_K)
        try:
            rec = problem.solve_steady()
            n = problem.V.dofmap.index_map.size_local
            gap = float(np.min(problem.T.x.array[:n] - below[:n])) if n else 0.0
            if problem.comm.allreduce(gap, op=MPI.MIN) >= -0.5:
                return rec, LowestState("above the fold", fold.fold, solves + 1)
        except ConvergenceError:
            pass
        # not ordered above the fold state (or no state from the hot start): the transient
        problem.set_initial(problem.initial_K)
        problem.T.x.array[:] = below
        problem.set_initial(problem.T.copy())
        last: ConvergenceError | None = None
        for k in range(max_settles):
            problem.integrate(duration_s=problem.time_s + settle_s * 2**k)
            try:
                end = problem.T.copy()
                problem.set_initial(end)
                rec = problem.solve_steady()
                return rec, LowestState("above the fold (transient)", fold.fold, solves + k + 2)
            except ConvergenceError as err:
                last = err
        raise ConvergenceError(
            "thermal Newton",
            "no steady state after the lowest branch's fold "
            f"(scale {fold.fold}): the transient from there had not settled "
            f"({last.reason if last else ''})",
            step="lowest steady state",
        )
    finally:
        if x is not None:
            x.destroy()
        problem.set_friction_scale(1.0)


@dataclasses.dataclass(frozen=True)
class ContinuationPoint(JsonRecord):
    """A point of a traced branch: friction scale, temperatures (C), friction heat (W), the
    λ-component of the unit tangent (its sign change marks a turning point)."""

    scale: float
    temperatures_C: dict[str, float]
    friction_W: float
    tangent_scale: float


@dataclasses.dataclass(frozen=True)
class Continuation(JsonRecord):
    """A traced solution curve, its turning points (λ, max surface temperature C) and the steady
    states where it crosses the target scales (every branch there, with its stability)."""

    points: tuple[ContinuationPoint, ...]
    turning_points: tuple[tuple[float, float], ...]
    stopped: str
    crossings: tuple[SteadyState, ...] = ()


def continuation(
    problem,
    scale_start: float,
    scale_range: tuple[float, float],
    step: float = 0.05,
    max_steps: int = 400,
    temperature_unit_K: float = 100.0,
    newton_tol: float | None = None,
    refine_turning_points: float = 1e-4,
    targets: tuple[float, ...] = (),
    max_step: float | None = None,
) -> Continuation:
    """Pseudo-arclength continuation of the steady state in the friction scale λ from
    ``scale_start`` (converged there first from the problem's current T), until λ leaves
    ``scale_range`` or ``max_steps``. Arclength in the norm sqrt(|δT|²/(n T_u²) + δλ²) with
    T_u = ``temperature_unit_K`` (n: number of dofs). Turning points are located to
    ``refine_turning_points`` in arclength by reducing the step where dλ/ds changes sign. Where
    the curve crosses a scale of ``targets``, the steady state there is solved by Newton from the
    interpolated field and its stability computed (``crossings``: every branch at that scale, the
    unstable ones included, which Newton from uniform starts does not find). The step grows up to
    ``max_step`` (default 4 ``step``) while the corrector converges quickly. The friction scale
    is restored at the end; T is left at the last point (collective)."""
    if not problem.has_friction:
        raise ParameterError("sources", "no friction heat", "a problem with a friction flux")
    lo, hi = scale_range
    if not lo <= scale_start <= hi:
        raise ParameterError("scale_start", scale_start, f"[{lo:g}, {hi:g}]")
    comm = problem.comm
    n = problem.num_unknowns
    w = 1.0 / (n * temperature_unit_K**2)
    scale_before = problem.friction_scale
    problem.set_friction_scale(scale_start)
    problem.solve_steady()
    ksp = _ksp(comm, problem.petsc_prefix + "continuation_")
    T = problem.state_vector()  # the unknowns (reduced with periodic cut faces)
    a, b, z = T.duplicate(), T.duplicate(), T.duplicate()
    problem.steady_system()
    Fl0 = problem.friction_scale_derivative()
    # residual tolerance relative to the friction heat per test function (a tighter one meets the
    # round-off of hot states)
    tol = newton_tol if newton_tol is not None else 1e-8 * Fl0.norm()
    Fl0.destroy()

    def tangent(prev: tuple[Any, float] | None):
        J, _ = problem.steady_system()
        Fl = problem.friction_scale_derivative()
        ksp.setOperators(J)
        ksp.solve(Fl, z)  # J z = F_lambda  ->  dT/dlambda = -z
        Fl.destroy()
        tT = z.copy()
        tT.scale(-1.0)
        tl = 1.0
        nrm = math.sqrt(w * tT.dot(tT) + tl * tl)
        tT.scale(1.0 / nrm)
        tl /= nrm
        if prev is not None and w * tT.dot(prev[0]) + tl * prev[1] < 0.0:
            tT.scale(-1.0)
            tl = -tl
        return tT, tl

    def point(tl: float) -> ContinuationPoint:
        bal = problem.heat_balance()
        return ContinuationPoint(
            problem.friction_scale,
            {k: v - ZERO_CELSIUS_K for k, v in problem.temperatures_K().items()},
            float(bal.friction_W),
            float(tl),
        )

    try:
        t_prev = tangent(None)
        pts = [point(t_prev[1])]
        turning: list[tuple[float, float]] = []
        T0 = T.copy()
        lam0 = problem.friction_scale
        ds = step
        ds_max = max_step if max_step is not None else 4.0 * step
        stopped = "max_steps"
        steps = 0
        crossings: list[SteadyState] = []
        while steps < max_steps:
            tT, tl = t_prev
            ok = False
            its = 0
            for _ in range(12):  # corrector, halving ds on failure
                T0.copy(T)
                T.axpy(ds, tT)
                problem.set_state(T)
                lam = lam0 + ds * tl
                for its in range(25):  # noqa: B007 - the count sets the next step
                    problem.set_friction_scale(lam)
                    J, F = problem.steady_system()
                    Fl = problem.friction_scale_derivative()
                    dT = T.copy()
                    dT.axpy(-1.0, T0)
                    N = w * tT.dot(dT) + tl * (lam - lam0) - ds
                    fn = F.norm()
                    if fn <= tol and abs(N) <= 1e-12:
                        Fl.destroy()
                        dT.destroy()
                        ok = True
                        break
                    ksp.setOperators(J)
                    ksp.solve(F, a)
                    ksp.solve(Fl, b)
                    Fl.destroy()
                    dT.destroy()
                    denom = tl - w * tT.dot(b)
                    dl = (w * tT.dot(a) - N) / denom
                    T.axpy(-1.0, a)
                    T.axpy(-dl, b)
                    problem.set_state(T)
                    lam += dl
                if ok:
                    break
                ds *= 0.5
            if not ok:
                stopped = "corrector failed"
                break
            steps += 1
            t_new = tangent(t_prev)
            cos = w * t_new[0].dot(tT) + t_new[1] * tl
            if cos < math.cos(MAX_TURN_RAD) and ds > refine_turning_points:
                # the curve turns too much over this step: retake it shorter
                T0.copy(T)
                problem.set_state(T)
                problem.set_friction_scale(lam0)
                ds *= 0.5
                continue
            if t_new[1] * t_prev[1] < 0.0 and ds > refine_turning_points:
                # a turning point between the last two points: go back and take a smaller step
                T0.copy(T)
                problem.set_state(T)
                problem.set_friction_scale(lam0)
                ds *= 0.25
                continue
            if t_new[1] * t_prev[1] < 0.0:
                turning.append((0.5 * (lam0 + lam), pts[-1].temperatures_C["max_surface"]))
                ds = step
            pts.append(point(t_new[1]))
            for tgt in targets:
                if (lam0 - tgt) * (lam - tgt) < 0.0 or lam == tgt:
                    crossings.append(_crossing(problem, T0, lam0, lam, tgt, len(crossings)))
                    problem.set_friction_scale(lam)
            T.copy(T0)
            lam0 = lam
            t_prev = t_new
            if not lo <= lam <= hi:
                stopped = "left the range"
                break
            smooth = its <= 3 and cos > math.cos(0.25 * MAX_TURN_RAD)
            ds = min(ds_max, ds * (1.5 if smooth else 1.0))
        for v in (a, b, z, T0, t_prev[0], T):
            v.destroy()
        return Continuation(tuple(pts), tuple(turning), stopped, tuple(crossings))
    finally:
        ksp.destroy()
        problem.set_friction_scale(scale_before)  # T stays at the last point


__all__ = [
    "Continuation",
    "ContinuationPoint",
    "SteadyState",
    "continuation",
    "stability_eigenvalue",
    "steady_states",
]
