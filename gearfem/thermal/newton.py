"""Newton (PETSc SNES) for the thermal residual with its linear part assembled once.

The residual of a step is split as::

    F(T) = alpha M T + c + K T + F_nl(T),

with M the (rho c_p) mass matrix (constant c_p), K the conduction matrix (constant k), alpha =
a0/dt and c = M (a1 T^n + a2 T^{n-1})/dt set per step, and F_nl the rest (sources, convection,
radiation, and the storage/conduction terms when c_p(T) or k(T) vary), assembled at every
iteration with its exact Jacobian J_nl. The Jacobian is J = alpha M + K + J_nl(T). For the usual
case (constant k and c_p) only boundary integrals and the sources are assembled per iteration,
which is several times cheaper than assembling the whole Jacobian.

Linear solver: MUMPS LU (``direct``) or CG/GMRES with algebraic multigrid (``iterative``). The
preconditioner (factorisation or AMG hierarchy) is rebuilt when alpha has changed by more than
``REBUILD_RATIO`` since it was built, and at the first Newton iteration of each solve otherwise it
is reused: the Krylov method then corrects for the small change of the matrix, so the Newton
iteration stays exact (the residual is always the true one).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from gearfem.errors import ConvergenceError

REBUILD_RATIO = 0.25


def _names(enum) -> dict[int, str]:
    return {v: k for k, v in vars(enum).items() if isinstance(v, int)}


class NewtonSolver:
    """SNES on the split residual (see the module docstring).

    Args:
        T: The unknown Function.
        F_nl, J_nl: Compiled residual and Jacobian of the nonlinear part (J_nl may be None).
        mass, stiffness: Compiled bilinear forms of M and K (None when folded into F_nl).
        pattern: Compiled volume bilinear form fixing the sparsity of every matrix.
        prefix: PETSc options prefix.
        options: SNES/KSP/PC options (under the prefix).
        iterative: Whether the KSP is a Krylov method with a reusable preconditioner.
    """

    def __init__(self, T, F_nl, J_nl, mass, stiffness, pattern, prefix: str, options: dict[str, Any],
                 iterative: bool) -> None:
        from dolfinx.fem.petsc import assemble_matrix, create_matrix, create_vector
        from petsc4py import PETSc

        self.T = T
        self._F, self._J = F_nl, J_nl
        V = T.function_space
        self.comm = V.mesh.comm
        self.A = create_matrix(pattern)
        assemble_matrix(self.A, pattern)  # fixes the nonzero structure (entries are zeroed per Jacobian)
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
        self.x = create_vector(V)
        self._c = create_vector(V)
        self._tmp = create_vector(V)
        self.alpha = 0.0
        self._alpha_pc: float | None = None
        self._have_c = False
        self.iterative = iterative

        snes = PETSc.SNES().create(self.comm)
        snes.setOptionsPrefix(prefix)
        snes.setFunction(self._residual, self.b)
        snes.setJacobian(self._jacobian, self.A, self.A)
        # The options stay in the database while the solver lives: some are read only when the
        # preconditioner is first set up (e.g. the sub-PC of block Jacobi).
        opts = PETSc.Options()
        self._option_keys = [f"{prefix}{k}" for k in options]
        for k, v in options.items():
            opts[f"{prefix}{k}"] = v
        snes.setFromOptions()
        self.snes = snes
        self._first_jacobian = True

    def destroy(self) -> None:
        from petsc4py import PETSc

        opts = PETSc.Options()
        for k in self._option_keys:
            if opts.hasName(k):
                opts.delValue(k)
        self._option_keys = []
        for obj in (self.snes, self.A, self.M, self.K, self.b, self.x, self._c, self._tmp):
            if obj is not None:
                obj.destroy()

    def __del__(self) -> None:
        try:
            self.destroy()
        except Exception:  # noqa: BLE001 - interpreter shutdown
            pass

    # ------------------------------------------------------------------------------------------
    def set_time_terms(self, alpha: float, history) -> None:
        """alpha = a0/dt and the history combination (a1 T^n + a2 T^{n-1})/dt as a PETSc Vec (or None)."""
        self.alpha = float(alpha)
        self._have_c = history is not None and self.M is not None
        if self._have_c:
            self.M.mult(history, self._c)

    def _assign(self, x) -> None:
        from petsc4py import PETSc

        x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        x.copy(self.T.x.petsc_vec)
        self.T.x.scatter_forward()

    def _residual(self, snes, x, b) -> None:
        from dolfinx.fem.petsc import assemble_vector
        from petsc4py import PETSc

        self._assign(x)
        with b.localForm() as bl:
            bl.set(0.0)
        assemble_vector(b, self._F)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        if self.K is not None:
            self.K.multAdd(x, b, b)
        if self.M is not None and self.alpha != 0.0:
            self.M.mult(x, self._tmp)
            b.axpy(self.alpha, self._tmp)
        if self._have_c:
            b.axpy(1.0, self._c)

    def _jacobian(self, snes, x, J, P) -> None:
        from dolfinx.fem.petsc import assemble_matrix
        from petsc4py import PETSc

        self._assign(x)
        J.zeroEntries()
        same = PETSc.Mat.Structure.SAME_NONZERO_PATTERN
        if self.K is not None:
            J.axpy(1.0, self.K, same)
        if self.M is not None and self.alpha != 0.0:
            J.axpy(self.alpha, self.M, same)
        if self._J is not None:
            assemble_matrix(J, self._J)
        J.assemble()
        if self.iterative:
            rebuild = (self._first_jacobian or self._alpha_pc is None
                       or abs(self.alpha - self._alpha_pc) > REBUILD_RATIO * max(abs(self._alpha_pc), 1e-300))
            self.snes.getKSP().getPC().setReusePreconditioner(not rebuild)
            if rebuild:
                self._alpha_pc = self.alpha
        self._first_jacobian = False

    # ------------------------------------------------------------------------------------------
    def solve(self, where: str, linesearch: str = "basic") -> int:
        """Newton from the current T; returns the iterations. Raises ConvergenceError on failure."""
        from petsc4py import PETSc

        self.snes.getLineSearch().setType(linesearch)
        self._first_jacobian = self._alpha_pc is None
        self.T.x.petsc_vec.copy(self.x)
        self.snes.solve(None, self.x)
        self._assign(self.x)
        reason = self.snes.getConvergedReason()
        its = self.snes.getIterationNumber()
        if reason <= 0 or not np.all(np.isfinite(self.T.x.array)):
            ksp_reason = self.snes.getKSP().getConvergedReason()
            raise ConvergenceError(
                "thermal Newton (SNES)",
                f"{_names(PETSc.SNES.ConvergedReason).get(reason, '?')} ({reason}); last KSP "
                f"{_names(PETSc.KSP.ConvergedReason).get(ksp_reason, '?')} ({ksp_reason})",
                step=where, iteration=its, residual=self.snes.getFunctionNorm(),
            )
        return its
