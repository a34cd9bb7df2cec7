"""Newton's method around a PETSc KSP for the thermal residual, its linear part assembled once.

The residual of a step is split as::

    F(T) = alpha M T + c + K T + F_nl(T),

with M the (rho c_p) mass matrix (constant c_p), K the conduction matrix (constant k), alpha =
a0/dt and c = M (a1 T^n + a2 T^{n-1})/dt set per step, and F_nl the rest (sources, convection,
radiation, and the storage/conduction terms when c_p(T) or k(T) vary), assembled at every
iteration with its exact Jacobian J_nl. The Jacobian is J = alpha M + K + J_nl(T). For the usual
case (constant k and c_p) only boundary integrals and the sources are assembled per iteration.

Newton (the iteration is :func:`gearfem.core.newton.newton_solve`, shared with the contact solve):
x <- x - lambda J^{-1} F with full steps (lambda = 1, transient: the extrapolated
predictor starts close) or backtracking (halving lambda until ||F|| decreases by the Armijo
factor, steady state). Converged when ||F||_2 <= max(atol, rtol ||F_0||_2) (W; the residual is a
heat flow per test function) or when the update is below 1e-14 ||x||. Failures raise
:class:`~gearfem.core.errors.ConvergenceError` named like PETSc's SNES reasons (DIVERGED_MAX_IT,
DIVERGED_LINE_SEARCH, DIVERGED_FNORM_NAN, DIVERGED_LINEAR_SOLVE with the KSP reason).

Periodic cut faces (:mod:`gearfem.thermal.periodic`): with a tie P the Newton iteration is the
Galerkin one on the periodic space: the KSP solves (P^T J P) y = P^T F and the update is
dx = P y; the convergence test measures ||P^T F||.

Linear solver: a KSP with the options of ``ThermalOptions.linear_solver``. With
``reuse_preconditioner`` (the MUMPS factorisation of the ``direct`` choice) the preconditioner
is rebuilt only when alpha has changed by more than the factor ``REBUILD_RATIO`` since it was
built; otherwise the old factorisation preconditions the current Jacobian (which differs by the
change of dt and of the radiation/H(T) terms) and the Krylov method needs a few iterations. The
Newton iteration stays exact: the residual and the Jacobian are always the current ones.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import time
from typing import Any

import numpy as np

from gearfem.core.errors import ConvergenceError
from gearfem.core.newton import NewtonSettings, newton_solve
from gearfem.core.params import require_int
from gearfem.core.petsc import ksp_reason, set_options

log = logging.getLogger(__name__)

REBUILD_RATIO = 1.25
ARMIJO = 1e-4
MAX_HALVINGS = 12


@dataclasses.dataclass(frozen=True)
class Effort:
    """The most Newton work one solve may take: ``max_it`` iterations (at most the solver's own)
    and ``max_halvings`` halvings of the step in each backtracking line search. A solve whose
    failure is itself an answer (a continuation's probe beyond a fold, a check whether a start
    reaches a state) is given less than the solver's defaults, so that it fails sooner; a solve
    within the effort ends where it would have with the defaults."""

    max_it: int
    max_halvings: int = MAX_HALVINGS

    def __post_init__(self) -> None:
        require_int("thermal Newton effort max_it", self.max_it, 1, 1000)
        require_int("thermal Newton effort max_halvings", self.max_halvings, 0, MAX_HALVINGS)


#: KSP reasons of an indefinite operator or preconditioner (DIVERGED_INDEFINITE_PC,
#: DIVERGED_INDEFINITE_MAT): CG needs a positive definite Jacobian.
INDEFINITE_REASONS = (-8, -10)


@dataclasses.dataclass(frozen=True)
class SolverStatistics:
    """The work of a :class:`NewtonSolver` so far: counts, and wall seconds on this rank.

    jacobians: Jacobian assemblies (J_nl assembled and added to alpha M + K).
    residuals: Residual evaluations.
    factorisations: Preconditioner builds (MUMPS factorisations of the ``direct`` solver).
    krylov_iterations: Krylov iterations over all linear solves.
    jacobian_s, residual_s, linear_solve_s: Time in each (the linear solves include the
        factorisations).
    """

    jacobians: int
    residuals: int
    factorisations: int
    krylov_iterations: int
    jacobian_s: float
    residual_s: float
    linear_solve_s: float

    def as_dict(self) -> dict[str, float]:
        return dataclasses.asdict(self)


class NewtonSolver:
    """Newton + KSP on the split residual (see the module docstring).

    Args:
        T: The unknown Function.
        F_nl, J_nl: Compiled residual and Jacobian of the nonlinear part (J_nl may be None).
        mass, stiffness: Compiled bilinear forms of M and K (None when folded into F_nl).
        pattern: Compiled volume bilinear form fixing the sparsity of every matrix.
        prefix: PETSc options prefix of the KSP.
        options: KSP/PC options (under the prefix).
        rtol, atol_W, max_it: Newton tolerances.
        reuse_preconditioner: Keep the preconditioner while alpha changes little (see above).
        pre_residual: Called before every residual evaluation (collective): updates coefficients
            that are functions of the current T outside UFL (a surface flux model).
        extra_jacobian: Called with the assembled Jacobian to add terms UFL cannot express (the
            surface flux model's dependence on cell-mean temperatures; collective).
        tie: A :class:`~gearfem.thermal.periodic.PeriodicTie` when the cut faces are periodic:
            the linear systems are reduced with it (module docstring).
    """

    def __init__(
        self,
        T,
        F_nl,
        J_nl,
        mass,
        stiffness,
        pattern,
        prefix: str,
        options: dict[str, Any],
        rtol: float,
        atol_W: float,
        max_it: int,
        reuse_preconditioner: bool,
        pre_residual=None,
        extra_jacobian=None,
        tie=None,
    ) -> None:
        from dolfinx.fem.petsc import assemble_matrix, create_matrix, create_vector
        from petsc4py import PETSc

        self.T = T
        self._F, self._J = F_nl, J_nl
        V = T.function_space
        self.comm = V.mesh.comm
        self.rtol, self.atol, self.max_it = rtol, atol_W, max_it
        self.A = create_matrix(pattern)
        assemble_matrix(
            self.A, pattern
        )  # fixes the nonzero structure (entries are zeroed per Jacobian)
        self.A.assemble()
        self.M = self.K = None
        if mass is not None:
            self.M = create_matrix(pattern)
            assemble_matrix(self.M, mass)
            self.M.assemble()
        if stiffness is not None:
            self.K = create_matrix(pattern)
            assemble_matrix(self.K, stiffness)
            self.K.assemble()
        self.b = create_vector(V)
        self.dx = create_vector(V)
        self.tie = tie
        # the KSP's operator and vectors: the sector's, or the reduced ones of a periodic tie
        self._rb = self._ry = self._Ahat = None
        if tie is not None:
            self._rb, self._ry = tie.create_vector(), tie.create_vector()
            self._Ahat = tie.reduce_matrix(self.A)  # the reduced operator's pattern
        self._x0 = create_vector(V)
        self._c = create_vector(V)
        self._tmp = create_vector(V)
        self.alpha = 0.0
        self._alpha_pc: float | None = None
        self._have_c = False
        self.reuse = reuse_preconditioner
        self.pre_residual = pre_residual
        self.extra_jacobian = extra_jacobian
        self.prefix = prefix
        self.switched_to_general = False
        self.pc_builds = 0
        self.linear_iterations = 0
        self._jacobians = self._residuals = 0
        self._jacobian_s = self._residual_s = self._linear_solve_s = 0.0

        # The options stay in the database while the solver lives: some are read only when the
        # preconditioner is first set up (e.g. the sub-PC of block Jacobi).
        ksp = PETSc.KSP().create(self.comm)
        ksp.setOptionsPrefix(prefix)
        ksp.setOperators(self.operator)
        self._options = set_options(prefix, {}, options)
        ksp.setFromOptions()
        self.ksp = ksp

    @property
    def operator(self):
        """The matrix the KSP solves with: J, or P^T J P with a periodic tie."""
        return self.A if self.tie is None else self._Ahat

    @property
    def residual_vector(self):
        """The residual the Newton iteration drives to zero: F, or P^T F with a periodic tie (as
        last evaluated)."""
        return self.b if self.tie is None else self._rb

    def statistics(self) -> SolverStatistics:
        """Counts and times of the work done so far (see :class:`SolverStatistics`)."""
        return SolverStatistics(
            jacobians=self._jacobians,
            residuals=self._residuals,
            factorisations=self.pc_builds,
            krylov_iterations=self.linear_iterations,
            jacobian_s=self._jacobian_s,
            residual_s=self._residual_s,
            linear_solve_s=self._linear_solve_s,
        )

    def _forget_options(self) -> None:
        self._options.clear()

    def destroy(self) -> None:
        """Free the PETSc objects. Collective: call it at the same point on every rank (the MUMPS
        factorisation is freed collectively; leaving it to the garbage collector, which may run at
        different times on different ranks, can deadlock)."""
        self._forget_options()
        for obj in (
            self.ksp,
            self.A,
            self.M,
            self.K,
            self.b,
            self.dx,
            self._x0,
            self._c,
            self._tmp,
            self._rb,
            self._ry,
            self._Ahat,
        ):
            if obj is not None:
                obj.destroy()
        self.ksp = self.A = self.M = self.K = self._rb = self._ry = self._Ahat = None

    def __del__(self) -> None:
        try:
            self._forget_options()  # not collective; the objects are freed by destroy() or petsc4py
        except Exception:
            pass

    # ------------------------------------------------------------------------------------------
    def set_time_terms(self, alpha: float, history) -> None:
        """alpha = a0/dt and the history combination (a1 T^n + a2 T^{n-1})/dt as a PETSc Vec (or
        None)."""
        self.alpha = float(alpha)
        self._have_c = history is not None and self.M is not None
        if self._have_c:
            self.M.mult(history, self._c)

    def use_general_solver(self) -> bool:
        """Switch a CG/Cholesky (or ICC) solver to GMRES/LU (ILU): the Jacobian turned out not to be
        positive definite. Returns False when it already was general (collective)."""
        from petsc4py import PETSc

        ksp = self.ksp
        pc = ksp.getPC()
        if ksp.getType() != PETSc.KSP.Type.CG:
            return False
        new = {"ksp_type": "gmres"}
        if pc.getType() == PETSc.PC.Type.CHOLESKY:
            new["pc_type"] = "lu"
        elif pc.getType() == PETSc.PC.Type.BJACOBI:
            new["sub_pc_type"] = "ilu"
        elif pc.getType() == PETSc.PC.Type.ICC:
            new["pc_type"] = "ilu"
        scope = set_options(self.prefix, {}, new)
        self._options.keys.extend(k for k in scope.keys if k not in self._options.keys)
        ksp.reset()
        ksp.setOperators(self.operator)
        ksp.setFromOptions()
        self._alpha_pc = None
        self.switched_to_general = True
        return True

    def _residual(self) -> float:
        """F at the current T into self.b; returns ||F||_2."""
        from dolfinx.fem.petsc import assemble_vector
        from petsc4py import PETSc

        t0 = time.perf_counter()
        if self.pre_residual is not None:
            self.pre_residual()
        x = self.T.x.petsc_vec
        with self.b.localForm() as bl:
            bl.set(0.0)
        assemble_vector(self.b, self._F)
        self.b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        if self.K is not None:
            self.K.multAdd(x, self.b, self.b)
        if self.M is not None and self.alpha != 0.0:
            self.M.mult(x, self._tmp)
            self.b.axpy(self.alpha, self._tmp)
        if self._have_c:
            self.b.axpy(1.0, self._c)
        if self.tie is not None:
            self.tie.restrict(self.b, self._rb)
        norm = self.residual_vector.norm()
        self._residuals += 1
        self._residual_s += time.perf_counter() - t0
        return norm

    def _jacobian(self) -> None:
        from dolfinx.fem.petsc import assemble_matrix
        from petsc4py import PETSc

        t0 = time.perf_counter()
        J = self.A
        J.zeroEntries()
        same = PETSc.Mat.Structure.SAME_NONZERO_PATTERN
        if self.K is not None:
            J.axpy(1.0, self.K, same)
        if self.M is not None and self.alpha != 0.0:
            J.axpy(self.alpha, self.M, same)
        if self._J is not None:
            assemble_matrix(J, self._J)
        J.assemble()
        if self.extra_jacobian is not None:
            self.extra_jacobian(J)
        if self.tie is not None:
            self.tie.reduce_matrix(J, self._Ahat)  # P^T J P into the KSP's operator
        self._jacobians += 1
        self._jacobian_s += time.perf_counter() - t0

    def _linear_solve(self) -> int:
        """dx = J^-1 b with the KSP (its preconditioner built or kept as set up); returns the KSP
        reason."""
        t0 = time.perf_counter()
        if self.tie is None:
            self.ksp.solve(self.b, self.dx)
        else:
            self.ksp.solve(self._rb, self._ry)
            self.tie.prolong(self._ry, self.dx)
        self.linear_iterations += self.ksp.getIterationNumber()
        self._linear_solve_s += time.perf_counter() - t0
        return self.ksp.getConvergedReason()

    def _fail(self, reason: str, where: str, it: int, norm: float):
        raise ConvergenceError("thermal Newton", reason, step=where, iteration=it, residual=norm)

    # ------------------------------------------------------------------------------------------
    def solve(
        self,
        where: str,
        linesearch: str = "basic",
        chord: bool = False,
        effort: Effort | None = None,
    ) -> int:
        """Newton from the current T (``linesearch``: "basic" full steps or "bt" backtracking),
        driven by :func:`gearfem.core.newton.newton_solve`; ``effort`` caps the iterations and
        the line search's halvings below the solver's (:class:`Effort`).

        ``chord``: keep the Jacobian of the first iteration while each iteration reduces the
        residual at least tenfold (a modified Newton method; the converged result is the same,
        the residual being exact), which saves assemblies and Krylov iterations when the
        nonlinearity is weak (radiation from a good predictor). Returns the number of
        iterations; raises ConvergenceError on failure.
        """
        settings = NewtonSettings(
            max_it=self.max_it if effort is None else min(self.max_it, effort.max_it),
            line_search="full" if linesearch == "basic" else "backtracking",
            max_halvings=MAX_HALVINGS if effort is None else effort.max_halvings,
            armijo=ARMIJO,
            accept_below_tolerance=False,
            on_line_search_failure="raise",
        )
        system = _ThermalSystem(self, chord, where)
        report = newton_solve(system, settings, "thermal Newton", where)
        it, norm = report.iterations, report.residual_norm
        if not np.all(np.isfinite(self.T.x.array)):
            self._fail("DIVERGED_FNORM_NAN", where, it, norm)
        return it


class _ThermalSystem:
    """The thermal Newton step as a :class:`gearfem.core.newton.NewtonSystem`: x ← x − α J⁻¹F,
    the Jacobian reassembled when fresh (every iteration, or with ``chord`` only when the last
    step reduced the residual less than tenfold) and the preconditioner rebuilt as
    ``reuse_preconditioner`` says."""

    def __init__(self, solver: NewtonSolver, chord: bool, where: str) -> None:
        self.s, self.chord, self.where = solver, chord, where
        if solver.reuse:
            a, a_pc = solver.alpha, solver._alpha_pc
            self.rebuild = (
                a_pc is None
                or (a == 0.0) != (a_pc == 0.0)
                or (a != 0.0 and max(a / a_pc, a_pc / a) > REBUILD_RATIO)
            )
        else:
            self.rebuild = True
        self.norm = self.norm0 = solver._residual()
        self.fresh = True
        self.trial_norm = math.nan

    def residual_norm(self) -> float:
        return self.norm

    def tolerance(self) -> float:
        return max(self.s.atol, self.s.rtol * self.norm0)

    def compute_direction(self, iteration: int) -> None:
        s = self.s
        pc = s.ksp.getPC()
        if self.fresh:
            s._jacobian()
            pc.setReusePreconditioner(not self.rebuild)  # rebuild (if at all) at the first only
            if self.rebuild:
                s._alpha_pc = s.alpha
                s.pc_builds += 1
                self.rebuild = False
            s.ksp.setOperators(s.operator)
        kr = s._linear_solve()
        if kr in INDEFINITE_REASONS and s.use_general_solver():
            # CG met a Jacobian that is not positive definite (a heat source rising with T): the
            # solver follows the physics, GMRES with an LU factorisation from now on
            log.warning(
                "thermal Newton at %s: KSP %s, switching to GMRES/LU", self.where, ksp_reason(kr)
            )
            s._jacobian()
            s.ksp.setOperators(s.operator)
            s._alpha_pc = s.alpha
            s.pc_builds += 1
            kr = s._linear_solve()
        if kr < 0:
            if s.reuse and s._alpha_pc is not None:
                s._alpha_pc = None  # a stale preconditioner may be the cause: rebuild next time
            raise ConvergenceError(
                "thermal Newton",
                f"DIVERGED_LINEAR_SOLVE; KSP {ksp_reason(kr)}",
                step=self.where,
                iteration=iteration - 1,
                residual=self.norm,
            )
        s.T.x.petsc_vec.copy(s._x0)

    def try_step(self, alpha: float) -> float:
        s = self.s
        s.T.x.petsc_vec.waxpy(-alpha, s.dx, s._x0)  # x = x0 - alpha dx
        s.T.x.scatter_forward()
        self.trial_norm = s._residual()
        return self.trial_norm

    def accept(self) -> None:
        self.fresh = not self.chord or self.trial_norm > 0.1 * self.norm
        self.norm = self.trial_norm

    def revert(self) -> None:  # never asked: the thermal solve accepts no stall
        s = self.s
        s._x0.copy(s.T.x.petsc_vec)
        s.T.x.scatter_forward()

    def accepts_stall(self, norm: float) -> bool:
        return False

    def step_negligible(self, alpha: float) -> bool:
        s = self.s
        return alpha * s.dx.norm() <= 1e-14 * s.T.x.petsc_vec.norm()
