"""ASME V&V 20 comparison: E = S - D per measurement, u_val = sqrt(u_num^2 + u_input^2 + u_D^2).

* u_D: the measurement's standard uncertainty (data file);
* u_num: numerical (discretisation) uncertainty of S, from two discretisations (P1 and P2 on the
  case mesh in :func:`gearfem.diagnose.report.run_diagnosis`);
* u_input: propagated input uncertainty, sqrt(sum_i (dS/dx_i u_x_i)^2) by one-sided finite
  differences of the forward model in each uncertain input (material ranges of the shared data).

Verdict per measurement: the model error is resolved (``|E| > k u_val``, k = 2 by default, about
95 % for a normal u_val) or lies within the validation uncertainty.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from gearfem.core.params import require_positive


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

    def rows(self, labels: list[str]) -> list[dict]:
        return [
            {
                "measurement": lab,
                "S_C": float(s),
                "D_C": float(d),
                "E_K": float(e),
                "u_num_K": float(a),
                "u_input_K": float(b),
                "u_D_K": float(c),
                "u_val_K": float(v),
                "resolved": bool(r),
            }
            for lab, s, d, e, a, b, c, v, r in zip(
                labels,
                self.S,
                self.D,
                self.E,
                self.u_num,
                self.u_input,
                self.u_D,
                self.u_val,
                self.resolved,
            )
        ]


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
