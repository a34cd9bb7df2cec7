"""PETSc options set one way, and readable solver reasons.

Every PETSc object gearfem creates has its own options prefix (``petsc_options_prefix``). Its
options are put in the PETSc options database with :func:`set_options`: gearfem's defaults for
the solver, under any value the user already put there (command line, ``PETSC_OPTIONS``, or an
earlier ``PETSc.Options()[prefix + key] = value``), and then the caller's explicit ``overrides``.
The returned :class:`OptionsScope` removes what it set when the solver is destroyed, so that a
later solver with the same prefix starts from the user's options again.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any

from petsc4py import PETSc


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
