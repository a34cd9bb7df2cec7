"""PETSc options set one way, readable solver reasons, and MUMPS factorisations of sequential SPD
matrices (Cholesky, Schur complement).

Every PETSc object gearfem creates has its own options prefix (``petsc_options_prefix``). Its
options are put in the PETSc options database with :func:`set_options`: gearfem's defaults for
the solver, under any value the user already put there (command line, ``PETSC_OPTIONS``, or an
earlier ``PETSc.Options()[prefix + key] = value``), and then the caller's explicit ``overrides``.
The returned :class:`OptionsScope` removes what it set when the solver is destroyed, so that a
later solver with the same prefix starts from the user's options again.
"""

from __future__ import annotations

import ctypes
import dataclasses
from collections.abc import Mapping
from typing import Any

import numpy as np
from petsc4py import PETSc

from gearfem.core.errors import ConvergenceError


@dataclasses.dataclass
class OptionsScope:
    """The options :func:`set_options` put in the database (removed by :meth:`clear`)."""

    keys: list[str]

    def clear(self) -> None:
        opts = PETSc.Options()
        for k in self.keys:
            if opts.hasName(k):
                opts.delValue(k)
        self.keys = []


def set_options(
    prefix: str, defaults: Mapping[str, Any], overrides: Mapping[str, Any] | None = None
) -> OptionsScope:
    """Put ``defaults`` (where the database has no value under ``prefix``) and ``overrides``
    (always) into the PETSc options database; returns the scope of what was set."""
    opts = PETSc.Options()
    keys = []
    for k, v in defaults.items():
        if not opts.hasName(prefix + k):
            opts[prefix + k] = v
            keys.append(prefix + k)
    for k, v in (overrides or {}).items():
        opts[prefix + k] = v
        if prefix + k not in keys:
            keys.append(prefix + k)
    return OptionsScope(keys)


def _names(enum) -> dict[int, str]:
    return {v: k for k, v in vars(enum).items() if isinstance(v, int)}


_KSP_REASONS = _names(PETSc.KSP.ConvergedReason)


def ksp_reason(reason: int) -> str:
    """``"DIVERGED_ITS (-3)"`` for a KSP converged reason."""
    return f"{_KSP_REASONS.get(reason, '?')} ({reason})"


# ------------------------------------------------------------------------------------------------
# MUMPS factorisations of sequential SPD matrices (static condensation)
# ------------------------------------------------------------------------------------------------
_MUMPS_DEFAULTS = {
    "pc_type": "cholesky",
    "pc_factor_mat_solver_type": "mumps",
    "mat_mumps_icntl_24": 1,  # detect null pivots: a body not held by its supports fails loudly
}


def _libpetsc() -> ctypes.CDLL:
    """The PETSc library petsc4py runs on (dlsym on petsc4py's extension module searches the
    libraries it links, wherever PETSc is installed: wheel, conda or container)."""
    return ctypes.CDLL(PETSc.__file__)


def _check(code: int, call: str) -> None:
    if code != 0:
        raise ConvergenceError("PETSc " + call, f"PETSc error code {code}")


def _mumps_pc(A: PETSc.Mat, prefix: str) -> tuple[PETSc.PC, OptionsScope]:
    pc = PETSc.PC().create(PETSc.COMM_SELF)
    pc.setOptionsPrefix(prefix)
    scope = set_options(prefix, _MUMPS_DEFAULTS)
    pc.setOperators(A)
    pc.setFromOptions()
    return pc, scope


def _factor_failed(pc: PETSc.PC, what: str) -> None:
    """Raise if the MUMPS factorisation of ``pc`` failed (INFOG(1) < 0) or met null pivots
    (INFOG(28), detected with ICNTL(24) = 1)."""
    F = pc.getFactorMatrix()
    info, null_pivots = F.getMumpsInfog(1), F.getMumpsInfog(28)
    if info < 0 or null_pivots > 0:
        raise ConvergenceError(
            what,
            f"MUMPS INFOG(1) = {info}, INFOG(2) = {F.getMumpsInfog(2)}, {null_pivots} null pivots "
            "(a singular matrix: a body not held by its Dirichlet conditions)",
        )


def cholesky_factor(A: PETSc.Mat, prefix: str) -> tuple[PETSc.PC, OptionsScope]:
    """A MUMPS Cholesky factorisation of the sequential SPD matrix ``A`` as a PC (``pc.apply``
    solves); options under ``prefix`` (defaults: :data:`_MUMPS_DEFAULTS`). Raises
    ConvergenceError if MUMPS fails."""
    pc, scope = _mumps_pc(A, prefix)
    pc.setUp()
    _factor_failed(pc, "MUMPS Cholesky factorisation")
    return pc, scope


def schur_complement(A: PETSc.Mat, rows: np.ndarray, prefix: str) -> np.ndarray:
    """Dense Schur complement S = A_cc − A_ci A_ii⁻¹ A_ic of the sequential SPD matrix ``A`` on
    the rows and columns ``rows`` (c; i is the rest), in the order of ``rows``.

    MUMPS computes it during a partial Cholesky factorisation with c ordered last (ICNTL(19), via
    PETSc's ``MatFactorSetSchurIS`` and ``MatFactorCreateSchurComplement``, which petsc4py does
    not wrap: called through ctypes). The cost is about that of one factorisation of A, against
    one forward/backward solve per column of c for the compliance by solves. The Schur complement
    comes in the order of the index set (tests/test_condensed.py checks it against solves).
    """
    rows = np.asarray(rows, dtype=np.int64)
    n = len(rows)
    lib = _libpetsc()
    pc, scope = _mumps_pc(A, prefix)
    iss = PETSc.IS().createGeneral(rows.astype(PETSc.IntType), comm=PETSc.COMM_SELF)
    S_handle = ctypes.c_void_p()
    try:
        pc.setFactorSetUpSolverType()
        F = pc.getFactorMatrix()
        _check(
            lib.MatFactorSetSchurIS(ctypes.c_void_p(F.handle), ctypes.c_void_p(iss.handle)),
            "MatFactorSetSchurIS",
        )
        pc.setUp()
        _factor_failed(pc, "MUMPS Cholesky factorisation with a Schur complement")
        status = ctypes.c_int()
        _check(
            lib.MatFactorCreateSchurComplement(
                ctypes.c_void_p(F.handle), ctypes.byref(S_handle), ctypes.byref(status)
            ),
            "MatFactorCreateSchurComplement",
        )
        lda = (ctypes.c_int64 if np.dtype(PETSc.IntType).itemsize == 8 else ctypes.c_int32)()
        _check(lib.MatDenseGetLDA(S_handle, ctypes.byref(lda)), "MatDenseGetLDA")
        data = ctypes.POINTER(ctypes.c_double)()
        _check(lib.MatDenseGetArrayRead(S_handle, ctypes.byref(data)), "MatDenseGetArrayRead")
        # column-major with leading dimension lda: column j at data[j * lda : j * lda + n]; S is
        # symmetric, so its columns are its rows
        S = np.array(np.ctypeslib.as_array(data, shape=(n, lda.value))[:, :n])
        _check(lib.MatDenseRestoreArrayRead(S_handle, ctypes.byref(data)), "MatDenseRestore")
    finally:
        if S_handle.value:
            lib.MatDestroy(ctypes.byref(S_handle))
        iss.destroy()
        pc.destroy()
        scope.clear()
    asym = max_asymmetry(S)
    if not asym <= 1e-10 * np.max(np.abs(S), initial=0.0):
        raise ConvergenceError("MUMPS Schur complement", f"not symmetric (|S - Sᵀ| = {asym:.3e})")
    return S


def max_asymmetry(S: np.ndarray, block: int = 512) -> float:
    """max |S − Sᵀ| by blocks of rows (no n² temporary)."""
    n = S.shape[0]
    worst = 0.0
    for i0 in range(0, n, block):
        i1 = min(n, i0 + block)
        worst = max(worst, float(np.abs(S[i0:i1] - S[:, i0:i1].T).max(initial=0.0)))
    return worst
