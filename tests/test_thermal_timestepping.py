"""BDF2 coefficients, extrapolation and the local error estimator on scalar ODEs (numpy only)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gearfem.core.errors import ParameterError
from gearfem.thermal.timestepping import (
    StepController,
    bdf2_coefficients,
    bdf2_error_constant,
    estimator_factor,
    extrapolation_weights,
)


@pytest.mark.parametrize("w", [0.3, 1.0, 2.0])
def test_bdf2_exact_for_quadratics(w):
    """(a0 y1 + a1 y0 + a2 y_-1)/h = y'(t1) for any quadratic y and step ratio w."""
    h = 0.7
    h1 = h / w
    a = bdf2_coefficients(h, h1)
    y = np.polynomial.Polynomial([1.3, -0.4, 2.1])
    t1, t0, tm = 5.0, 5.0 - h, 5.0 - h - h1
    assert (a[0] * y(t1) + a[1] * y(t0) + a[2] * y(tm)) / h == pytest.approx(
        y.deriv()(t1), rel=1e-12
    )
    assert bdf2_coefficients(h, None) == (1.0, -1.0, 0.0)
    assert bdf2_error_constant(1.0, 1.0) == pytest.approx(2.0 / 9.0)


def test_extrapolation_exact_for_quadratics():
    y = np.polynomial.Polynomial([0.5, 1.0, -3.0])
    ts = (2.0, 1.5, 0.7)
    w = extrapolation_weights(ts, 2.6)
    assert sum(wi * y(ti) for wi, ti in zip(w, ts)) == pytest.approx(y(2.6), rel=1e-12)


def _bdf2_step_linear(lam, y0, ym, h, h1):
    """One BDF2 step of y' = -lam y from exact history (closed form of the implicit equation)."""
    a0, a1, a2 = bdf2_coefficients(h, h1)
    return -(a1 * y0 + a2 * ym) / (a0 + lam * h)


@pytest.mark.parametrize("ratios", [(1.0, 1.0), (1.8, 0.6), (0.5, 1.5)])
def test_estimator_matches_true_local_error(ratios):
    """For y' = -y from exact history, estimate / true local error -> 1 as h -> 0, with error
    O(h)."""
    lam = 1.0
    y = lambda t: math.exp(-lam * t)
    devs = []
    for h in (0.04, 0.02, 0.01):
        h1 = h / ratios[0]
        h2 = h1 / ratios[1]
        t1 = 1.0
        t0, tm, tmm = t1 - h, t1 - h - h1, t1 - h - h1 - h2
        yb = _bdf2_step_linear(lam, y(t0), y(tm), h, h1)
        w = extrapolation_weights((t0, tm, tmm), t1)
        yp = w[0] * y(t0) + w[1] * y(tm) + w[2] * y(tmm)
        est = estimator_factor(h, h1, h2) * (yb - yp)
        true = yb - y(t1)
        devs.append(abs(est / true - 1.0))
    assert devs[-1] < 0.05
    assert devs[0] / devs[-1] == pytest.approx(
        4.0, rel=0.35
    )  # first order in h: halving twice -> /4


def test_controller_grows_and_shrinks_within_limits():
    c = StepController(tol_K=0.1, dt_min_s=1e-3, dt_max_s=100.0)
    assert c.accept(0.1) and not c.accept(0.11)
    assert c.next_dt(10.0, 0.0) == 20.0  # max growth 2
    assert c.next_dt(80.0, 1e-9) == 100.0  # dt_max
    assert c.next_dt(10.0, 0.1) == pytest.approx(9.0)  # safety 0.9
    assert c.next_dt(10.0, 1e6) == pytest.approx(2.0)  # min shrink 0.2
    with pytest.raises(ParameterError):
        StepController(tol_K=0.1, dt_min_s=1.0, dt_max_s=0.5)
    with pytest.raises(ParameterError):
        StepController(tol_K=0.1, dt_min_s=1e-3, dt_max_s=1.0, max_growth=2.5)  # not zero-stable
