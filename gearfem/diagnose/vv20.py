"""ASME V&V 20 comparison: E = S - D per measurement, u_val = sqrt(u_num^2 + u_input^2 + u_D^2).

* u_D: the measurement's standard uncertainty (data file);
* u_num: numerical (discretisation) uncertainty of S, from two discretisations (P1 and P2 on the
  case mesh in :func:`gearfem.diagnose.report.run_diagnosis`);
* u_input: propagated input uncertainty, sqrt(sum_i (dS/dx_i u_x_i)^2) by one-sided finite
  differences of the forward model in each uncertain input (material ranges of the shared data).

Verdict per measurement: the model error is resolved (``|E| > k u_val``, k = 2 by default, about
95 % for a normal u_val) or lies within the validation uncertainty.

Each measurement's numbers are in the unit of its reading (:class:`Row`): a temperature's S and D
in C with E and the uncertainties in K, a torque meter's loss in N m, an efficiency as a fraction.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from gearfem.core.params import require_positive
from gearfem.core.results import JsonRecord


@dataclasses.dataclass(frozen=True)
class Comparison:
    """V&V 20 numbers of a set of measurements (arrays in the data's row order, K or C)."""

    S: np.ndarray
    D: np.ndarray
    u_num: np.ndarray
    u_input: np.ndarray
    u_D: np.ndarray
    k: float = 2.0

    def __post_init__(self) -> None:
        require_positive("vv20.k", self.k)

    @property
    def E(self) -> np.ndarray:
        return np.asarray(self.S) - np.asarray(self.D)

    @property
    def u_val(self) -> np.ndarray:
        return np.sqrt(
            np.asarray(self.u_num) ** 2 + np.asarray(self.u_input) ** 2 + np.asarray(self.u_D) ** 2
        )

    @property
    def resolved(self) -> np.ndarray:
        """True where |E| > k u_val: a model error that the uncertainties do not explain."""
        return np.abs(self.E) > self.k * self.u_val

    def rows(self, labels: list[str], units: list[str]) -> tuple[Row, ...]:
        """One :class:`Row` per measurement, in the data's order, each in its reading's unit."""
        return tuple(
            Row(
                lab,
                unit,
                float(s),
                float(d),
                float(e),
                float(a),
                float(b),
                float(c),
                float(v),
                bool(r),
            )
            for lab, unit, s, d, e, a, b, c, v, r in zip(
                labels,
                units,
                self.S,
                self.D,
                self.E,
                self.u_num,
                self.u_input,
                self.u_D,
                self.u_val,
                self.resolved,
                strict=True,
            )
        )


@dataclasses.dataclass(frozen=True)
class Row(JsonRecord):
    """One measurement's V&V 20 comparison in the unit of its reading (``unit``, as
    :func:`gearfem.diagnose.data.unit_of` gives it): for a temperature ("C") the prediction
    ``S`` and the datum ``D`` in C and the error ``E`` and the uncertainties in K; for a torque
    loss ("N m") or an efficiency ("1") all of them in that unit."""

    measurement: str
    unit: str
    S: float
    D: float
    E: float
    u_num: float
    u_input: float
    u_D: float
    u_val: float
    resolved: bool

    @property
    def is_temperature(self) -> bool:
        return self.unit == "C"

    @property
    def difference_unit(self) -> str:
        """The unit of E and the uncertainties: K for a temperature, the reading's otherwise."""
        return "K" if self.is_temperature else self.unit

    def _value(self, x: float) -> str:
        # a temperature to 0.1 C; a torque loss or an efficiency to four significant digits (to
        # 0.1 a loss of 0.044 N m would read 0.0)
        return f"{x:.1f}" if self.is_temperature else f"{x:.4g}"

    def _difference(self, x: float, sign: bool = False) -> str:
        if self.is_temperature:
            return f"{x:+.1f}" if sign else f"{x:.2f}"
        return f"{x:+.3g}" if sign else f"{x:.3g}"

    def line(self) -> str:
        """The row as ``gearfem diagnose`` prints it, each number with its unit."""
        u = "" if self.unit == "1" else f" {self.unit}"
        du = "" if self.difference_unit == "1" else f" {self.difference_unit}"
        resolved = " (resolved)" if self.resolved else ""
        if self.is_temperature:
            return (
                f"{self.measurement}: S = {self.S:.1f}{u}, D = {self.D:.1f}{u}, E = "
                f"{self.E:+.1f}{du}, u_val = {self.u_val:.1f}{du}{resolved}"
            )
        return (
            f"{self.measurement}: S = {self._value(self.S)}{u}, D = {self._value(self.D)}{u}, "
            f"E = {self._difference(self.E, True)}{du}, u_val = "
            f"{self._difference(self.u_val)}{du}{resolved}"
        )

    def cells(self) -> tuple[str, ...]:
        """The row in a table of the columns :data:`TABLE_HEAD`: the reading's unit in the
        second column, the numbers in it without units."""
        return (
            self.measurement,
            self.unit,
            self._value(self.S),
            self._value(self.D),
            self._difference(self.E, True),
            self._difference(self.u_num),
            self._difference(self.u_input),
            self._difference(self.u_D),
            self._difference(self.u_val),
            "yes" if self.resolved else "no",
        )


#: The columns of :meth:`Row.cells`.
TABLE_HEAD = (
    "measurement",
    "unit (differences: K for C)",
    "S",
    "D",
    "E",
    "u_num",
    "u_input",
    "u_D",
    "u_val",
    "E beyond 2 u_val",
)


@dataclasses.dataclass(frozen=True)
class ComparisonTable(JsonRecord):
    """The V&V 20 comparison of a diagnosis's baseline: a :class:`Row` per measurement in the
    data's order, the coverage factor ``k``, how u_num was obtained and u_input's parts per
    input (each measurement's part in its row's difference unit)."""

    rows: tuple[Row, ...]
    k: float
    u_num_method: str
    u_input_parts: dict[str, tuple[float, ...]]


def input_uncertainty(
    predict, nominal: np.ndarray, perturbations: dict[str, tuple[object, float]]
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """u_input by finite differences: ``perturbations[name] = (argument for predict, scale)``, where
    ``predict(argument)`` is the prediction with input ``name`` moved by ``delta`` and ``scale`` =
    u_x / delta (1 when the move is one standard uncertainty). Returns (u_input, per-input
    parts)."""
    parts = {}
    for name, (arg, scale) in perturbations.items():
        parts[name] = (np.asarray(predict(arg)) - np.asarray(nominal)) * scale
    total = np.sqrt(sum(p**2 for p in parts.values())) if parts else np.zeros_like(nominal)
    return total, parts
