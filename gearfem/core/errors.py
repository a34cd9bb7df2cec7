"""Exceptions raised by gearfem.

Every error a user can trigger names what was wrong: a bad parameter names the parameter, its
value and the allowed range; a solver failure carries the solver's own reason and where (which
step, which iteration) it happened.
"""

from __future__ import annotations

from typing import Any


class GearfemError(Exception):
    """Base class of all gearfem errors."""


class ParameterError(GearfemError, ValueError):
    """A parameter has a value outside its allowed range.

    Args:
        name: Dotted name of the parameter as the user wrote it (``geometry.teeth``).
        value: The offending value.
        allowed: Human-readable allowed range (``"integer >= 8"``, ``"(0, 45) degrees"``).
        reason: Optional extra explanation (why the range is what it is).
    """

    def __init__(self, name: str, value: Any, allowed: str, reason: str = "") -> None:
        self.name = name
        self.value = value
        self.allowed = allowed
        self.reason = reason
        msg = f"{name} = {value!r} is not allowed; allowed: {allowed}"
        if reason:
            msg += f" ({reason})"
        super().__init__(msg)


class ConvergenceError(GearfemError, RuntimeError):
    """A nonlinear or linear solver failed.

    Args:
        solver: Which solver (``"contact Newton"``, ``"thermal Newton"``, ``"KSP"``).
        reason: The solver's reason, e.g. the PETSc converged-reason name and code.
        step: Where it happened (load step, angle, time) in words with units.
        iteration: Iteration number at failure, if known.
        residual: Last residual norm, if known.
    """

    def __init__(
        self,
        solver: str,
        reason: str,
        step: str = "",
        iteration: int | None = None,
        residual: float | None = None,
    ) -> None:
        self.solver = solver
        self.reason = reason
        self.step = step
        self.iteration = iteration
        self.residual = residual
        parts = [f"{solver} did not converge: {reason}"]
        if step:
            parts.append(f"at {step}")
        if iteration is not None:
            parts.append(f"iteration {iteration}")
        if residual is not None:
            parts.append(f"residual {residual:.3e}")
        super().__init__(", ".join(parts))


class MissingDependencyError(GearfemError, ImportError):
    """A required library is missing or too old."""


class UncoveredContactError(GearfemError):
    """A contact found outside the surfaces a reduced (condensed) contact model solves on.

    Args:
        where: The step (load step, angle) in words with units.
        contacts: One line per surface pair that touches outside the set: what touches what,
            how deep, where, which facets.
        hint: How to widen the set (or to use the full solver).
    """

    def __init__(self, where: str, contacts: list[str], hint: str = "") -> None:
        self.where = where
        self.contacts = list(contacts)
        self.hint = hint
        msg = f"contact outside the condensed contact surfaces at {where}: " + "; ".join(contacts)
        if hint:
            msg += f" ({hint})"
        super().__init__(msg)
