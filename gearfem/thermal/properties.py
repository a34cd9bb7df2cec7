"""Heat content of a material with temperature-dependent specific heat.

The transient equation is written for the volumetric enthalpy e(T) = rho * int_{T_ref}^{T} c_p(s) ds
(J/m^3), so that the discrete stored heat is an exact difference of contents and the heat
balance closes also when c_p depends on T. For the piecewise-linear tables of
:class:`~gearfem.core.materials.TemperatureTable` (constant outside the table) the antiderivative is
piecewise quadratic; it is built here for numpy and UFL alike.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import ufl

from gearfem.core.materials import TemperatureTable


def _segments(table: TemperatureTable):
    """Knots, values and the antiderivative G at the knots (G(t_0) = 0)."""
    t = np.asarray(table.T_K, dtype=float)
    v = np.asarray(table.values, dtype=float)
    G = np.zeros_like(t)
    G[1:] = np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(t))
    return t, v, G


def antiderivative(table: TemperatureTable, T_K: Any) -> Any:
    """G(T) = int_{T_0}^{T} table(s) ds with T_0 the first knot (numpy)."""
    t, v, G = _segments(table)
    T = np.asarray(T_K, dtype=float)
    if len(t) == 1:
        out = v[0] * (T - t[0])
    else:
        out = np.where(t[0] > T, v[0] * (T - t[0]), G[-1] + v[-1] * (T - t[-1]))
        for i in range(len(t) - 1):
            s = (v[i + 1] - v[i]) / (t[i + 1] - t[i])
            inside = (t[i] <= T) & (t[i + 1] > T)
            d = T - t[i]
            out = np.where(inside, G[i] + v[i] * d + 0.5 * s * d * d, out)
    return float(out) if np.ndim(out) == 0 else out


def antiderivative_ufl(table: TemperatureTable, T: Any) -> Any:
    """The same G(T) as a UFL expression of ``T`` (kelvin)."""
    t, v, G = _segments(table)
    if len(t) == 1 or table.is_constant:
        return float(v[0]) * (T - float(t[0]))
    expr = float(G[-1]) + float(v[-1]) * (T - float(t[-1]))
    for i in range(len(t) - 2, -1, -1):
        s = (v[i + 1] - v[i]) / (t[i + 1] - t[i])
        d = T - float(t[i])
        expr = ufl.conditional(
            ufl.lt(T, float(t[i + 1])), float(G[i]) + float(v[i]) * d + 0.5 * float(s) * d * d, expr
        )
    return ufl.conditional(ufl.lt(T, float(t[0])), float(v[0]) * (T - float(t[0])), expr)


def enthalpy_ufl(density_kg_m3: float, cp: TemperatureTable, T: Any, T_ref_K: float) -> Any:
    """e(T) = rho (G(T) - G(T_ref)), J/m^3, as UFL."""
    return density_kg_m3 * (antiderivative_ufl(cp, T) - antiderivative(cp, T_ref_K))


def enthalpy(density_kg_m3: float, cp: TemperatureTable, T_K: Any, T_ref_K: float) -> Any:
    """e(T) = rho (G(T) - G(T_ref)), J/m^3 (numpy)."""
    return density_kg_m3 * (np.asarray(antiderivative(cp, T_K)) - antiderivative(cp, T_ref_K))


def table_ufl(table: TemperatureTable, T: Any) -> Any:
    """The piecewise-linear ``table`` as a function of the UFL expression ``T`` (kelvin), constant
    outside the table."""
    t, v = table.T_K, table.values
    if len(t) == 1 or table.is_constant:
        return ufl.as_ufl(float(v[0]))
    expr = ufl.as_ufl(float(v[-1]))  # T >= t[-1]
    for i in range(len(t) - 2, -1, -1):
        slope = (v[i + 1] - v[i]) / (t[i + 1] - t[i])
        expr = ufl.conditional(ufl.lt(T, t[i + 1]), v[i] + slope * (T - t[i]), expr)
    return ufl.conditional(ufl.lt(T, t[0]), float(v[0]), expr)
