"""The Newton driver shared by the contact and thermal solves (gearfem.core.newton) and the one
way PETSc options are set (gearfem.core.petsc)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from petsc4py import PETSc

from gearfem.core.errors import ConvergenceError, ParameterError
from gearfem.core.newton import NewtonSettings, newton_solve
from gearfem.core.petsc import ksp_reason, set_options


class Dense:
    """F(x) = 0 with a dense Jacobian, as a NewtonSystem."""

    def __init__(self, F, J, x0, tol=1e-12, floor=None):
        self.F, self.J, self.x = F, J, np.atleast_1d(np.asarray(x0, dtype=float))
        self.tol, self.floor = tol, floor
        self.norm = float(np.linalg.norm(F(self.x)))
        self.history = [self.norm]

    def residual_norm(self):
        return self.norm

    def tolerance(self):
        return self.tol

    def compute_direction(self, iteration):
        self.base = self.x.copy()
        try:
            self.d = -np.linalg.solve(np.atleast_2d(self.J(self.x)), np.atleast_1d(self.F(self.x)))
        except np.linalg.LinAlgError as err:
            raise ConvergenceError("dense", "DIVERGED_LINEAR_SOLVE", iteration=iteration) from err

    def try_step(self, alpha):
        self.x = self.base + alpha * self.d
        self.trial = float(np.linalg.norm(self.F(self.x)))
        return self.trial

    def accept(self):
        self.norm = self.trial
        self.history.append(self.norm)

    def revert(self):
        self.x = self.base

    def accepts_stall(self, norm):
        return self.floor is not None and norm <= self.floor

    def step_negligible(self, alpha):
        return False


def test_quadratic_convergence_on_a_smooth_system():
    F = lambda x: np.array([x[0] ** 2 + x[1] ** 2 - 4.0, x[0] * x[1] - 1.0])
    J = lambda x: np.array([[2 * x[0], 2 * x[1]], [x[1], x[0]]])
    sys_ = Dense(F, J, [2.0, 0.3])
    rep = newton_solve(sys_, NewtonSettings(max_it=20), "test")
    assert rep.residual_norm <= 1e-12 and not rep.stalled
    h = sys_.history
    # quadratic: e_{k+1} / e_k^2 bounded over the last steps (before round-off)
    ratios = [h[k + 1] / h[k] ** 2 for k in range(len(h) - 1) if h[k + 1] > 1e-13]
    assert max(ratios[-2:]) < 10.0
    assert rep.iterations == len(h) - 1


def test_backtracking_converges_where_full_steps_diverge():
    F, J = (lambda x: np.arctan(x)), (lambda x: np.diag(1.0 / (1.0 + np.minimum(x**2, 1e300))))
    with pytest.raises(ConvergenceError) as err, np.errstate(over="ignore", invalid="ignore"):
        newton_solve(Dense(F, J, [3.0]), NewtonSettings(max_it=20, line_search="full"), "atan")
    assert err.value.reason.startswith("DIVERGED_")
    rep = newton_solve(Dense(F, J, [3.0]), NewtonSettings(max_it=30), "atan")
    assert rep.residual_norm <= 1e-12


def test_failures_carry_reason_step_and_iteration():
    F, J = (lambda x: x**2 + 1.0), (lambda x: np.diag(2 * x))  # no real root
    with pytest.raises(ConvergenceError) as err:
        newton_solve(
            Dense(F, J, [1.3]),
            NewtonSettings(max_it=5, on_line_search_failure="raise"),
            "no root",
            step="t = 5 s",
        )
    assert err.value.reason.startswith(("DIVERGED_LINE_SEARCH", "DIVERGED_MAX_IT"))
    assert err.value.step == "t = 5 s" and err.value.iteration >= 1
    with pytest.raises(ConvergenceError) as err:
        newton_solve(Dense(lambda x: np.full(1, np.nan), J, [1.0]), NewtonSettings(max_it=5), "nan")
    assert err.value.reason == "DIVERGED_FNORM_NAN" and err.value.iteration == 0


def test_a_residual_floor_is_accepted_as_a_stall_only_below_the_stall_level():
    # |F| can never go below 1e-6 (a floor), the tolerance asks for 1e-12
    F = lambda x: np.array([x[0] ** 2 + 1e-6])
    J = lambda x: np.array([[2 * x[0]]])
    rep = newton_solve(Dense(F, J, [1.0], floor=1e-5), NewtonSettings(max_it=60), "floor")
    assert rep.stalled and rep.residual_norm <= 1e-5
    with pytest.raises(ConvergenceError):
        newton_solve(
            Dense(F, J, [1.0]), NewtonSettings(max_it=60, on_line_search_failure="raise"), "f"
        )


def test_bad_settings_name_the_parameter():
    with pytest.raises(ParameterError) as err:
        NewtonSettings(max_it=5, line_search="cubic")
    assert err.value.name == "newton.line_search"


def test_petsc_options_defaults_under_user_values_and_cleared():
    opts = PETSc.Options()
    prefix = "gearfem_test_newton_"
    opts[prefix + "ksp_type"] = "cg"  # the user's choice
    scope = set_options(
        prefix, {"ksp_type": "gmres", "pc_type": "lu"}, overrides={"ksp_rtol": 1e-9}
    )
    assert opts.getString(prefix + "ksp_type") == "cg"
    assert opts.getString(prefix + "pc_type") == "lu"
    assert math.isclose(opts.getReal(prefix + "ksp_rtol"), 1e-9)
    scope.clear()
    assert not opts.hasName(prefix + "pc_type") and not opts.hasName(prefix + "ksp_rtol")
    assert opts.getString(prefix + "ksp_type") == "cg"  # the user's value stays
    opts.delValue(prefix + "ksp_type")
    assert ksp_reason(-3) in ("DIVERGED_ITS (-3)", "DIVERGED_MAX_IT (-3)")  # alias names
