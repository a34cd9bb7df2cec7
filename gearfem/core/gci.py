"""Numerical uncertainty of a computed quantity from three systematically refined solutions.

The grid convergence index (Roache; procedure of Celik et al., J. Fluids Eng. 130 (2008) 078001).
For solutions φ1, φ2, φ3 on meshes of representative sizes h1 < h2 < h3 (fine to coarse;
h = (V/N)^(1/3) for N unknowns in a volume V), with r21 = h2/h1, r32 = h3/h2,
ε21 = φ2 − φ1, ε32 = φ3 − φ2 and s = sign(ε32/ε21), the observed order p solves

    p = | ln|ε32/ε21| + ln((r21^p − s)/(r32^p − s)) | / ln r21

(fixed-point iteration; exact for φ_h = φ + C h^p). Then

    φ_ext = (r21^p φ1 − φ2)/(r21^p − 1),        GCI21 = Fs |ε21| / (r21^p − 1),

with the safety factor Fs = 1.25 for three meshes in the asymptotic range. The numerical standard
uncertainty of φ1 reported with it is u_num = GCI21/1.15 (the conversion ASME V&V 20-2009 uses
with Fs = 1.25). When the convergence is oscillatory (s < 0), or the differences do not shrink
under refinement (faster than order 0.5 would make them), or the observed order is below 0.5 or
above ``formal_order`` (when given), the estimate is not in the asymptotic range: the order
used is clipped to [0.5, formal_order], Fs = 3, and the result says ``asymptotic = False``.

Four or more solutions (:func:`least_squares_convergence`; Eça & Hoekstra, J. Comput. Phys. 262
(2014) 104-130): the three-solution formula would use only three of them, and a study whose
differences are comparable with the scatter of the solutions cannot tell its order from three.
The power law is fitted in the least-squares sense,

    φ_i ≈ φ0 + α h_i^p        (p by a bounded scalar search, φ0 and α linear for each p),

with the standard deviation of the fit σ = sqrt(Σ (φ_i − φ_fit,i)² / (n − 3)). In the asymptotic
range (monotone solutions, 0.5 <= p <= formal order, and σ below the mean difference between
successive solutions Δ_M/(n − 1), Δ_M the data range: Eça & Hoekstra's test of a good fit),
Fs = 1.25; otherwise p is clipped to [0.5, formal order], the fit repeated at that order
(σ with n − 2) and Fs = 3. The uncertainty of the solution on level i is that of the procedure,

    U_i = Fs |φ_i − φ0| + σ + |φ_i − φ_fit,i|,

which for three solutions (an exact fit, σ = 0) is Roache's GCI of that level. u_num = U / 1.15
as above. Where no order in range fits, gearfem departs from the 2014 procedure, which refits at
fixed orders instead (1, 2 and α h + β h² below 0.5; 1 and 2 above 2; each also weighted by
1/h), keeps the fit of least scatter, and when σ is not below Δ_M/(n − 1) takes
U_i = 3 σ (n − 1)/Δ_M (|φ_fit,i − φ0| + σ + |φ_i − φ_fit,i|); gearfem clips the order and keeps
Fs = 3. ``benchmarks/verification/uncertainty_method.py`` compares the two. Neither bounds U by
the data range (the largest difference Δ_M belongs to the 2008 procedure, J. Mar. Sci. Technol.
13 (2008)).

**Several steady states** (:func:`branch_convergence`). A model with several steady states (a
friction law that steps up at the glass transition) can land on different branches on different
levels: the level's solution jumps, and no power law of h describes the jump. The levels are then
compared branch by branch: when every level reached the same branch the usual estimate holds;
when they did not, the discretisation decides the branch, and the numerical uncertainty of the
reading is the gap between the branches (the larger of the gap at the levels where both were found
and the spread of the levels' values, which holds the jump), reported with ``branches_differ`` and
``asymptotic = False``. A study that stayed on one branch cannot show this: that is why the
branch is compared, not assumed.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Sequence

import numpy as np
from scipy.optimize import minimize_scalar

from gearfem.core.errors import ParameterError

SAFETY_FACTOR = 1.25
SAFETY_FACTOR_OUTSIDE = 3.0
GCI_TO_STANDARD = 1.15  # V&V 20: u_num = GCI / 1.15 with Fs = 1.25


@dataclasses.dataclass(frozen=True)
class Convergence:
    """Observed order, extrapolated value and numerical uncertainty of the finest solution."""

    values: tuple[float, ...]  # φ1 (fine), φ2, ... (coarse)
    sizes: tuple[float, ...]  # h1 < h2 < ...
    observed_order: float  # p from the solutions (nan when they are equal)
    order_used: float
    extrapolated: float
    gci: float  # absolute, same unit as the values
    u_num: float  # standard uncertainty of φ1
    asymptotic: bool  # monotone and 0.5 <= p <= formal order (and a good fit: 4+ solutions)
    safety_factor: float = SAFETY_FACTOR  # Fs used (1.25 in the asymptotic range, else 3)
    scatter: float = 0.0  # σ, standard deviation of the least-squares fit (0 for 3 solutions)
    fitted: tuple[float, ...] = ()  # the fit at each size (4+ solutions; empty for 3)
    # the levels reached different steady states (branch_convergence): u_num is the branch gap
    branches_differ: bool = False

    def gci_at(self, level: int) -> float:
        """GCI of the solution on ``level`` (0: finest, ..., len(values) − 1: coarsest): Fs
        |φ_level − φ_ext| with the order and Fs of this estimate (Roache's coarse-grid GCI), plus
        for a least-squares fit its scatter and the level's distance from the fit; level 0 gives
        :attr:`gci`. For oscillatory convergence of three solutions the spread bound
        :attr:`gci` holds for every level."""
        n = len(self.values)
        if not (isinstance(level, int) and 0 <= level < n):
            raise ParameterError("refinement level", level, f"0 (finest) ... {n - 1} (coarsest)")
        if self.branches_differ:  # every level: the branch it lands on is not settled
            return self.gci
        if self.fitted:
            return (
                self.safety_factor * abs(self.values[level] - self.extrapolated)
                + self.scatter
                + abs(self.values[level] - self.fitted[level])
            )
        if level == 0 or self.extrapolated == self.values[0]:
            return self.gci
        return self.safety_factor * abs(self.values[level] - self.extrapolated)

    def u_num_at(self, level: int) -> float:
        """Numerical standard uncertainty of the solution on ``level`` (GCI / 1.15)."""
        return self.gci_at(level) / GCI_TO_STANDARD

    @property
    def relative_gci(self) -> float:
        return self.gci / abs(self.values[0]) if self.values[0] != 0.0 else math.inf


def representative_size(dofs: int, volume: float = 1.0, dim: int = 3) -> float:
    """h = (V/N)^(1/dim): the mesh size of ``dofs`` unknowns in ``volume``."""
    if dofs <= 0:
        raise ParameterError("dofs", dofs, "integer > 0")
    return (volume / dofs) ** (1.0 / dim)


def observed_order(
    values: Sequence[float], sizes: Sequence[float], max_it: int = 100
) -> tuple[float, int]:
    """The observed order p and the sign s of ε32/ε21 (see the module docstring)."""
    f1, f2, f3 = values
    h1, h2, h3 = sizes
    e21, e32 = f2 - f1, f3 - f2
    if e21 == 0.0 or e32 == 0.0:
        return math.nan, 1
    s = 1 if e32 / e21 > 0 else -1
    r21, r32 = h2 / h1, h3 / h2
    ratio = abs(e32 / e21)
    p = abs(math.log(ratio)) / math.log(r21)
    for _ in range(max_it):
        q = math.log((r21**p - s) / (r32**p - s)) if r21 != r32 else 0.0
        new = abs(math.log(ratio) + q) / math.log(r21)
        if abs(new - p) <= 1e-12 * max(1.0, p):
            p = new
            break
        p = new
    return p, s


def _sorted_levels(
    values: Sequence[float], sizes: Sequence[float]
) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """Sizes and values sorted fine to coarse; the sizes distinct and positive, the values
    finite."""
    pairs = sorted(zip(sizes, values))
    h = tuple(float(x) for x, _ in pairs)
    f = tuple(float(v) for _, v in pairs)
    if not (h[0] > 0.0 and all(a < b for a, b in itertools.pairwise(h))):
        raise ParameterError("mesh sizes", sizes, f"{len(h)} distinct positive sizes")
    if not all(math.isfinite(v) for v in f):
        raise ParameterError("values", values, "finite numbers")
    return h, f


def grid_convergence(
    values: Sequence[float], sizes: Sequence[float], formal_order: float | None = None
) -> Convergence:
    """Three solutions ``values`` on meshes of sizes ``sizes`` (any order; sorted fine to coarse
    here) → observed order, extrapolation and GCI of the finest."""
    if len(values) != 3 or len(sizes) != 3:
        raise ParameterError("refinement levels", len(values), "exactly 3 solutions and 3 sizes")
    h, f = _sorted_levels(values, sizes)
    if f[0] == f[1] == f[2]:
        return Convergence(f, h, math.nan, math.nan, f[0], 0.0, 0.0, True)
    p, s = observed_order(f, h)
    lo, hi = 0.5, formal_order if formal_order is not None else math.inf
    # converging: the change between the fine pair is smaller than between the coarse pair
    # (scaled by the ratios as for an exact power law of order lo); otherwise the differences grow
    # under refinement and no order is observed, whatever the formula gives
    r21, r32 = h[1] / h[0], h[2] / h[1]
    shrinking = abs(f[1] - f[0]) * (r32**lo - 1.0) < abs(f[2] - f[1]) * (r21**lo - 1.0) * r21**lo
    asymptotic = s > 0 and shrinking and math.isfinite(p) and lo <= p <= hi
    p_used = p if asymptotic else min(max(p if math.isfinite(p) else lo, lo), hi)
    fs = SAFETY_FACTOR if asymptotic else SAFETY_FACTOR_OUTSIDE
    e21 = f[1] - f[0]
    denom = r21**p_used - 1.0
    gci = fs * abs(e21) / denom
    extrapolated = (r21**p_used * f[0] - f[1]) / denom
    if s < 0:  # oscillatory: the spread of the three solutions bounds the error instead
        gci = max(gci, fs * (max(f) - min(f)))
        extrapolated = f[0]
    return Convergence(
        f, h, p, p_used, extrapolated, gci, gci / GCI_TO_STANDARD, asymptotic, safety_factor=fs
    )


def convergence(
    values: Sequence[float], sizes: Sequence[float], formal_order: float | None = None
) -> Convergence:
    """Three solutions: :func:`grid_convergence`; four or more:
    :func:`least_squares_convergence`."""
    if len(values) == 3:
        return grid_convergence(values, sizes, formal_order)
    return least_squares_convergence(values, sizes, formal_order)


def branch_convergence(
    values: Sequence[float],
    sizes: Sequence[float],
    branches: Sequence[int | None],
    gap: float | None = None,
    formal_order: float | None = None,
) -> Convergence:
    """:func:`convergence` of solutions that may lie on different steady states.

    Args:
        values, sizes, formal_order: As for :func:`convergence` (any order of the levels).
        branches: The branch each level's solution is on (same order as ``values``; None: the
            model has one steady state there). Equal labels: the usual estimate.
        gap: The distance between the branches for this quantity (the largest over the levels
            where both were found), or None when no level found both.

    Returns the usual :class:`Convergence` when every level is on one branch; otherwise the
    values with u_num = the gap between the branches or the spread of the values (which holds
    the jump), whichever is larger, observed order NaN, ``asymptotic = False`` and
    ``branches_differ = True``.
    """
    if len(branches) != len(values):
        raise ParameterError("branches", len(branches), f"one label per solution ({len(values)})")
    if len(set(branches)) <= 1:
        return convergence(values, sizes, formal_order)
    h, f = _sorted_levels(values, sizes)
    spread = max(f) - min(f)
    u = max(spread, gap if gap is not None and math.isfinite(gap) else 0.0)
    return Convergence(
        f,
        h,
        math.nan,
        math.nan,
        math.nan,
        u * GCI_TO_STANDARD,
        u,
        False,
        safety_factor=1.0,
        branches_differ=True,
    )


#: the orders the least-squares fit searches (a wider range than any order it would trust); an
#: observed order at the lower end means that no converging power law fits: the steps between
#: successive solutions do not shrink under refinement
ORDER_SEARCH = (0.05, 12.0)


def _fit(x: np.ndarray, f: np.ndarray, p: float) -> tuple[float, float, float]:
    """φ0, α and the sum of squared residuals of the least-squares fit f ≈ φ0 + α x^p."""
    a = np.column_stack([np.ones_like(x), x**p])
    (phi0, alpha), *_ = np.linalg.lstsq(a, f, rcond=None)
    res = f - (phi0 + alpha * x**p)
    return float(phi0), float(alpha), float(res @ res)


def least_squares_convergence(
    values: Sequence[float], sizes: Sequence[float], formal_order: float | None = None
) -> Convergence:
    """Four or more solutions ``values`` on meshes of sizes ``sizes`` (any order) → observed
    order, extrapolation and uncertainty from a least-squares power-law fit (module docstring)."""
    if len(values) < 4 or len(sizes) != len(values):
        raise ParameterError(
            "refinement levels", len(values), "4 or more solutions with as many sizes"
        )
    h, f = _sorted_levels(values, sizes)
    n = len(f)
    spread = max(f) - min(f)
    if spread == 0.0:
        return Convergence(f, h, math.nan, math.nan, f[0], 0.0, 0.0, True, fitted=f)
    x = np.asarray(h) / h[0]  # relative sizes: 1 = the finest
    y = np.asarray(f)
    # the order: the best of a logarithmic scan, refined by a bounded search around it
    grid = np.geomspace(*ORDER_SEARCH, 200)
    sse = [_fit(x, y, p)[2] for p in grid]
    k = int(np.argmin(sse))
    lo_b, hi_b = grid[max(k - 1, 0)], grid[min(k + 1, len(grid) - 1)]
    best = minimize_scalar(
        lambda p: _fit(x, y, p)[2],
        bounds=(lo_b, hi_b),
        method="bounded",
        options={"xatol": 1e-10},
    )
    p = float(best.x)
    lo, hi = 0.5, formal_order if formal_order is not None else math.inf
    steps = np.diff(y)
    monotone = bool(np.all(steps > 0.0) or np.all(steps < 0.0))
    phi0, alpha, sse = _fit(x, y, p)
    sigma = math.sqrt(sse / (n - 3))
    good_fit = sigma < spread / (n - 1)
    asymptotic = monotone and good_fit and lo <= p <= hi
    if asymptotic:
        p_used, fs = p, SAFETY_FACTOR
    else:  # the fit again at the clipped order, which has one free parameter less
        p_used, fs = min(max(p, lo), hi), SAFETY_FACTOR_OUTSIDE
        phi0, alpha, sse = _fit(x, y, p_used)
        sigma = math.sqrt(sse / (n - 2))
    fitted = tuple(float(v) for v in phi0 + alpha * x**p_used)
    gci = fs * abs(f[0] - phi0) + sigma + abs(f[0] - fitted[0])
    return Convergence(
        f,
        h,
        p,
        p_used,
        phi0,
        gci,
        gci / GCI_TO_STANDARD,
        asymptotic,
        safety_factor=fs,
        scatter=sigma,
        fitted=fitted,
    )
