"""Variable-step BDF2 with a predictor-based local error estimate and step-size control.

Time discretisation (fully implicit, all terms at t_{n+1}; h = t_{n+1} - t_n, h1 = t_n - t_{n-1},
omega = h / h1)::

    dT/dt(t_{n+1}) ~ (a0 T^{n+1} + a1 T^n + a2 T^{n-1}) / h,
    a0 = (1 + 2 omega)/(1 + omega),  a1 = -(1 + omega),  a2 = omega^2/(1 + omega)

(backward Euler a = (1, -1, 0) for the first step: the damped start). The scheme is A-stable and
zero-stable for omega < 1 + sqrt(2); the controller limits growth to ``max_growth`` <= 2.

Local error estimator (a Milne-device for variable steps). Taylor expansion gives for the BDF2
solution T_B and the exact solution T(t_{n+1}) (given exact history)::

    T_B - T = C h^3 T''' + O(h^4),    C = (1 + omega)^2 / (6 omega (1 + 2 omega)),

(C = 2/9 for constant steps). The quadratic extrapolation T_P through (t_{n-2}, t_{n-1}, t_n)
evaluated at t_{n+1} has ``T - T_P = P T''' + O(h^4)`` with
``P = h (h + h1) (h + h1 + h2) / 6``. Eliminating the unknown T''' gives the estimate

    LTE = T_B - T ~ C h^3 / (C h^3 + P) * (T_B - T_P),

evaluated at every degree of freedom; the step's error is its maximum norm (kelvin). A step is
accepted when LTE <= tol; the next step is h * clip(safety (tol/LTE)^(1/3), min_shrink,
max_growth), clipped to [dt_min, dt_max] and to land on output times. The predictor T_P is also
the Newton initial guess.
"""

from __future__ import annotations

import dataclasses
import math

from gearfem.core.params import require_positive, require_range


def bdf2_coefficients(dt: float, dt_prev: float | None) -> tuple[float, float, float]:
    """(a0, a1, a2) of variable-step BDF2; backward Euler when ``dt_prev`` is None."""
    if dt_prev is None:
        return 1.0, -1.0, 0.0
    w = dt / dt_prev
    return (1.0 + 2.0 * w) / (1.0 + w), -(1.0 + w), w * w / (1.0 + w)


def extrapolation_weights(
    times: tuple[float, float, float], t: float
) -> tuple[float, float, float]:
    """Weights of the quadratic Lagrange extrapolation through ``times`` (t_n, t_{n-1}, t_{n-2}) at
    t."""
    t0, t1, t2 = times
    return (
        (t - t1) * (t - t2) / ((t0 - t1) * (t0 - t2)),
        (t - t0) * (t - t2) / ((t1 - t0) * (t1 - t2)),
        (t - t0) * (t - t1) / ((t2 - t0) * (t2 - t1)),
    )


def bdf2_error_constant(dt: float, dt_prev: float) -> float:
    """C of T_B - T = C h^3 T''' for variable-step BDF2 (2/9 for equal steps)."""
    w = dt / dt_prev
    return (1.0 + w) ** 2 / (6.0 * w * (1.0 + 2.0 * w))


def estimator_factor(dt: float, dt1: float, dt2: float) -> float:
    """Factor f with LTE ~ f (T_B - T_P) for the BDF2 step dt after steps dt1, dt2 (see module
    doc)."""
    c = bdf2_error_constant(dt, dt1) * dt**3
    p = dt * (dt + dt1) * (dt + dt1 + dt2) / 6.0
    return c / (c + p)


@dataclasses.dataclass(frozen=True)
class StepController:
    """Elementary (I-) controller on the BDF2 local error estimate (kelvin, max norm).

    Args:
        tol_K: Accepted local error per step.
        dt_min_s, dt_max_s: Step limits; a step below ``dt_min_s`` is a failure.
        safety: Factor applied to the optimal step.
        max_growth: Largest step ratio (< 1 + sqrt(2) for zero stability of BDF2).
        min_shrink: Smallest step ratio after a rejection.
    """

    tol_K: float
    dt_min_s: float
    dt_max_s: float
    safety: float = 0.9
    max_growth: float = 2.0
    min_shrink: float = 0.2

    def __post_init__(self) -> None:
        require_positive("thermal.time_error_K", self.tol_K)
        require_positive("thermal.dt_min_s", self.dt_min_s)
        require_positive("thermal.dt_max_s", self.dt_max_s)
        require_range(
            "thermal.dt_max_s",
            self.dt_max_s,
            self.dt_min_s,
            math.inf,
            reason="dt_max_s must be at least dt_min_s",
        )
        require_range("step controller safety", self.safety, 0.0, 1.0, lo_open=True)
        require_range(
            "step controller max_growth", self.max_growth, 1.0, 1.0 + math.sqrt(2.0), hi_open=True
        )
        require_range(
            "step controller min_shrink", self.min_shrink, 0.0, 1.0, lo_open=True, hi_open=True
        )

    def ratio(self, error_K: float) -> float:
        """Step ratio suggested by the error estimate (not yet limited by dt_min/dt_max)."""
        if error_K <= 0.0:
            return self.max_growth
        r = self.safety * (self.tol_K / error_K) ** (1.0 / 3.0)
        return min(self.max_growth, max(self.min_shrink, r))

    def accept(self, error_K: float) -> bool:
        return error_K <= self.tol_K

    def next_dt(self, dt: float, error_K: float) -> float:
        return min(self.dt_max_s, dt * self.ratio(error_K))
