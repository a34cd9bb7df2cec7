"""One Newton driver for every nonlinear solve of gearfem (contact and thermal).

The driver owns the iteration: the convergence test, the line search, the stall rule and the
failures; a :class:`NewtonSystem` owns the algebra (residual, Newton direction, trial steps). For
F(x) = 0 with current iterate x_k and direction d_k (J(x_k) d_k = −F(x_k)):

    x_{k+1} = x_k + α d_k,  α = 1, ½, ¼, ... (backtracking) until the Armijo condition
    ||F(x_{k+1})|| ≤ (1 − c α) ||F(x_k)||  (c = ``armijo``) holds, or ||F(x_{k+1})|| ≤ tol.

Converged when ||F(x_k)|| ≤ tol (the system gives tol at every iterate: it may depend on the
state, e.g. a force scale) after at least ``min_iterations`` steps, or when the system reports a
negligible step. When the line search cannot decrease the residual the settings say what
happens: raise (``DIVERGED_LINE_SEARCH``), keep the last trial and go on, or, if the system
accepts the current residual as a stall (a residual floor of the discretisation above the
tolerance), return to the last iterate and stop there. Failures raise
:class:`~gearfem.core.errors.ConvergenceError` with a PETSc SNES-like reason (``DIVERGED_MAX_IT``,
``DIVERGED_LINE_SEARCH``, ``DIVERGED_FNORM_NAN``), the step label and the iteration.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from typing import Protocol

from gearfem.core.errors import ConvergenceError, ParameterError

log = logging.getLogger(__name__)

LINE_SEARCHES = ("full", "backtracking")
ON_LINE_SEARCH_FAILURE = ("raise", "keep_last")


@dataclasses.dataclass(frozen=True)
class NewtonSettings:
    """How the driver iterates.

    Args:
        max_it: Largest number of Newton steps.
        line_search: ``"full"`` (α = 1 always) or ``"backtracking"`` (halving α).
        max_halvings: Halvings of α tried by the backtracking search.
        armijo: Sufficient-decrease constant c of the Armijo condition.
        accept_below_tolerance: A trial whose residual is below the tolerance is accepted even
            without sufficient decrease.
        on_line_search_failure: ``"raise"`` or ``"keep_last"`` (continue from the last trial).
        min_iterations: Steps taken before convergence is tested (1: always at least one step).
    """

    max_it: int
    line_search: str = "backtracking"
    max_halvings: int = 12
    armijo: float = 1e-4
    accept_below_tolerance: bool = True
    on_line_search_failure: str = "raise"
    min_iterations: int = 0

    def __post_init__(self) -> None:
        if self.max_it < 1:
            raise ParameterError("newton.max_it", self.max_it, "integer >= 1")
        if self.line_search not in LINE_SEARCHES:
            raise ParameterError("newton.line_search", self.line_search, ", ".join(LINE_SEARCHES))
        if self.on_line_search_failure not in ON_LINE_SEARCH_FAILURE:
            raise ParameterError(
                "newton.on_line_search_failure",
                self.on_line_search_failure,
                ", ".join(ON_LINE_SEARCH_FAILURE),
            )
        if self.max_halvings < 0:
            raise ParameterError("newton.max_halvings", self.max_halvings, "integer >= 0")


@dataclasses.dataclass(frozen=True)
class NewtonReport:
    """Result of a converged (or accepted-stalled) Newton solve."""

    iterations: int
    residual_norm: float
    stalled: bool = False


class NewtonSystem(Protocol):
    """The algebra the driver needs. The system holds the current iterate and its residual."""

    def residual_norm(self) -> float:
        """||F|| at the current iterate (evaluated by the system when it was set up)."""

    def tolerance(self) -> float:
        """Convergence tolerance at the current iterate."""

    def compute_direction(self, iteration: int) -> None:
        """The Newton direction at the current iterate (remembers the iterate as the base of the
        coming trials); raises ConvergenceError if the linear solve fails."""

    def try_step(self, alpha: float) -> float:
        """Set the iterate to base + α·direction and return its residual norm."""

    def accept(self) -> None:
        """Make the last trial the current iterate."""

    def revert(self) -> None:
        """Return to the base iterate (discarding the trial)."""

    def accepts_stall(self, norm: float) -> bool:
        """Whether a residual ``norm`` that the line search cannot decrease is accepted."""

    def step_negligible(self, alpha: float) -> bool:
        """Whether the accepted step α·direction is negligible (convergence by the update)."""


def newton_solve(
    system: NewtonSystem, settings: NewtonSettings, name: str, step: str = ""
) -> NewtonReport:
    """Run Newton on ``system`` (see the module docstring). ``name`` and ``step`` label the
    ConvergenceError and the debug log."""
    s = settings
    norm = system.residual_norm()
    if not math.isfinite(norm):
        raise ConvergenceError(name, "DIVERGED_FNORM_NAN", step=step, iteration=0, residual=norm)
    it = 0
    tries = 1 if s.line_search == "full" else s.max_halvings + 1
    while True:
        tol = system.tolerance()
        log.debug("%s %s Newton %d: |F| = %.3e (tol %.3e)", name, step, it, norm, tol)
        if norm <= tol and it >= s.min_iterations:
            return NewtonReport(it, norm)
        if it >= s.max_it:
            raise ConvergenceError(
                name,
                f"DIVERGED_MAX_IT ({s.max_it} iterations; residual {norm:.3e} > tolerance "
                f"{tol:.3e})",
                step=step,
                iteration=it,
                residual=norm,
            )
        system.compute_direction(it + 1)
        it += 1
        alpha = 1.0
        for k in range(tries):
            new = system.try_step(alpha)
            if s.line_search == "full" or _decreased(new, norm, alpha, tol, s) or k == tries - 1:
                break
            alpha *= 0.5
        if s.line_search == "backtracking" and not _decreased(new, norm, alpha, tol, s):
            if system.accepts_stall(norm):
                system.revert()
                log.warning(
                    "%s %s: Newton stalled at |F| = %.3e (tolerance %.3e): accepted",
                    name,
                    step,
                    norm,
                    tol,
                )
                return NewtonReport(it, norm, stalled=True)
            if s.on_line_search_failure == "raise":
                raise ConvergenceError(
                    name, "DIVERGED_LINE_SEARCH", step=step, iteration=it, residual=norm
                )
            log.debug("%s %s Newton %d: line search did not decrease |F|", name, step, it)
        elif alpha < 1.0:
            log.debug("%s %s Newton %d: line search step %g", name, step, it, alpha)
        system.accept()
        if not math.isfinite(new):
            raise ConvergenceError(
                name, "DIVERGED_FNORM_NAN", step=step, iteration=it, residual=new
            )
        norm = new
        if system.step_negligible(alpha):
            return NewtonReport(it, norm)


def _decreased(new: float, norm: float, alpha: float, tol: float, s: NewtonSettings) -> bool:
    if not math.isfinite(new):
        return False
    return new <= (1.0 - s.armijo * alpha) * norm or (s.accept_below_tolerance and new <= tol)
