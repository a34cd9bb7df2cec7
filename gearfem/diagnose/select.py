"""Fitting and selection of candidate extensions against measured data.

Every model (the baseline, each candidate alone, each pair) is fitted by weighted least squares
(``scipy.optimize.least_squares`` from the best point of a coarse grid over the prior, in the
prior's unit coordinates) with residuals r_i = sqrt(w_i) (S_i - D_i) / sigma_i, where
sigma_i = sqrt(u_D,i^2 + u_model^2) and w_i = min(k, 2)/k for a sample of a curve with k samples
(:meth:`~gearfem.diagnose.data.Dataset.series_weights`): a temperature curve counts as at most two
independent data (level and rate), so n = :meth:`~gearfem.diagnose.data.Dataset.n_effective`.

Ranking: AICc = chi2 + 2k + 2k(k+1)/(n-k-1) (plain AIC when n - k - 1 <= 0 for some model; models
with k >= n cannot be tested and are left out). Verdict:

* "baseline adequate": no model beats the baseline by more than ``detect`` (6: strong evidence);
* otherwise the best model, simplified to a nested sub-model when that is within ``tie`` (2);
  "not identifiable" when a non-nested model lies within ``tie`` of it (and the best passes the
  chi-square test: a best fit that fails it is "partial" first, its rivals named), or when a
  parameter's profile-likelihood interval spans its whole prior; the report then names the
  instrument readings (among ``probes``) where the rival fits differ most in units of each
  reading's measurement uncertainty;
* "partial": the best model beats the baseline but still fails a chi-square goodness-of-fit test
  at 1 %; "unexplained": no model beats the baseline, which fails that test.

Intervals: 95 % profile likelihood (chi2 within 3.84 of the minimum, other parameter re-fitted).
Held-out error: leave one operating point out, refit, predict it; RMS over its temperatures (K)
and, apart, over each other instrument's readings in their unit (torque meters: N m).
"""

from __future__ import annotations

import dataclasses
import itertools
from collections.abc import Callable

import numpy as np
from scipy import optimize, stats

from gearfem.core.errors import ParameterError
from gearfem.core.params import require_nonnegative
from gearfem.core.results import JsonRecord
from gearfem.diagnose.candidates import LIBRARY, Candidate, by_name
from gearfem.diagnose.data import Dataset, Measurement

Predict = Callable[[Dataset, dict[str, float]], np.ndarray]
#: Estimated error of a prediction of the model of the given candidates, per measurement (the
#: surrogate's :meth:`~gearfem.diagnose.forward.Surrogate.error`); None = exact.
ModelError = Callable[[Dataset, tuple[str, ...]], np.ndarray] | None
CHI2_95 = 3.841
GOF_LEVEL = 0.01


@dataclasses.dataclass(frozen=True)
class ModelFit(JsonRecord):
    """One fitted model: a set of candidates with their parameters and its evidence."""

    candidates: tuple[str, ...]
    params: dict[str, float]
    chi2: float
    k: int
    criterion: float
    delta: float  # criterion minus the best model's
    intervals: dict[str, list[float]]  # 95 % profile interval per parameter (top models)
    spans_prior: tuple[str, ...]  # parameters whose interval is the whole prior
    loo_rmse_K: float | None  # leave one operating point out RMS error (top models)
    predictions_C: list[float] | None
    # the profile threshold 3.84 is multiplied by this (chi2 / dof when the model fails the
    # chi-square test: its intervals are then not 95 % intervals of a good fit)
    interval_scale: float = 1.0

    @property
    def label(self) -> str:
        return "+".join(self.candidates) or "baseline"


@dataclasses.dataclass(frozen=True)
class Separation(JsonRecord):
    """An instrument reading that would separate the chosen model from a rival: the fits'
    predictions differ by ``difference`` (in ``unit``: K for a temperature, N m for a torque
    meter), ``separation_u`` times the reading's measurement uncertainty."""

    rival: tuple[str, ...]
    measurement: str
    difference: float
    unit: str
    separation_u: float


@dataclasses.dataclass(frozen=True)
class Verdict(JsonRecord):
    """What the data say: ``kind`` is "identified", "partial", "not identifiable", "baseline
    adequate" or "unexplained"."""

    kind: str
    chosen: tuple[str, ...]
    competitors: tuple[tuple[str, ...], ...]
    chi2_p_value: float
    text: str = ""
    unconstrained: tuple[str, ...] = ()
    separate_by: tuple[Separation, ...] = ()


@dataclasses.dataclass(frozen=True)
class UnitGain(JsonRecord):
    """RMS errors of the data's readings of one unit other than temperature (``unit``: "N m"
    for the torque meters' torque loss, "1" for an efficiency), before (baseline) and after
    (chosen model): held out (each operating point predicted by the model fitted to the others)
    and in-sample; None where there is nothing to compute (fewer than two operating points)."""

    unit: str
    loo_rmse_before: float | None
    loo_rmse_after: float | None
    rmse_before: float | None
    rmse_after: float | None


@dataclasses.dataclass(frozen=True)
class Gain(JsonRecord):
    """Errors before (baseline) and after (chosen model): the temperatures' in K, and in
    ``other_units`` those of every other instrument of the data (torque meters in N m)."""

    loo_rmse_before_K: float | None
    loo_rmse_after_K: float | None
    rmse_before_K: float | None
    rmse_after_K: float | None
    other_units: tuple[UnitGain, ...] = ()

    def of_unit(self, unit: str) -> UnitGain | None:
        """The gain of the readings in ``unit`` (None: the data have none)."""
        return next((g for g in self.other_units if g.unit == unit), None)

    def other_units_text(self, held_out: bool = True) -> str:
        """The held-out (or in-sample) errors of the other units in words, each "; X before, Y
        after" ("" when the data are temperatures only)."""

        def f(x: float | None, unit: str) -> str:
            return "n/a" if x is None else f"{x:.3g} {unit}"

        return "".join(
            f"; {'held-out' if held_out else 'in-sample'} RMS error of the readings in {g.unit}: "
            + (
                f"{f(g.loo_rmse_before, g.unit)} before, {f(g.loo_rmse_after, g.unit)} after"
                if held_out
                else f"{f(g.rmse_before, g.unit)} before, {f(g.rmse_after, g.unit)} after"
            )
            for g in self.other_units
        )


@dataclasses.dataclass(frozen=True)
class EdgeCheck(JsonRecord):
    """One end of a refined profile interval checked on the full model: the corrected
    surrogate's edge, the full model's chi2 there minus the profile threshold (0 on the exact
    edge), the edge the full model gives and how many full-model runs (of every operating point)
    it took; ``checked`` False: the surrogate's error estimate was too small to move the edge
    (see :func:`refine`)."""

    parameter: str
    side: str  # "lo" or "hi"
    surrogate_edge: float
    full_edge: float
    full_excess_chi2: float | None
    full_runs: int
    checked: bool


@dataclasses.dataclass(frozen=True)
class Refinement(JsonRecord):
    """The chosen model confirmed on the full model (surrogate corrected at the optimum)."""

    params: dict[str, float]
    intervals: dict[str, list[float]]
    chi2: float
    max_correction_K: list[float]
    full_rmse_K: float | None = None
    full_vs_corrected_max_K: float | None = None
    full_C: list[float] | None = None
    edges: tuple[EdgeCheck, ...] = ()
    interval_scale: float = 1.0
    #: chi2 of the full model at the refined parameters (sigma without the surrogate's error) and
    #: its goodness-of-fit p-value: below GOF_LEVEL the chosen model fails on the full model
    #: whatever the corrected surrogate says (seen: a branch the surrogate interpolates across)
    full_chi2: float | None = None
    full_p_value: float | None = None

    @property
    def fails_full_model(self) -> bool:
        """The full model at the refined parameters fails the goodness-of-fit test (p below
        GOF_LEVEL): the chosen model is then no explanation, whatever the surrogate says."""
        return self.full_p_value is not None and self.full_p_value < GOF_LEVEL


@dataclasses.dataclass(frozen=True)
class Diagnosis(JsonRecord):
    """The ranked models, the verdict and the gain of one diagnosis."""

    n_measurements: int
    n_effective: float
    criterion: str  # "AICc" or "AIC"
    u_model_K: float
    thresholds: dict[str, float]
    models: tuple[ModelFit, ...]
    verdict: Verdict
    chosen: tuple[str, ...]
    gain: Gain
    refined: Refinement | None = None

    def fit_of(self, candidates) -> ModelFit:
        """The fitted model of exactly these candidates."""
        want = tuple(candidates)
        return next(m for m in self.models if m.candidates == want)

    @property
    def chosen_fit(self) -> ModelFit:
        return self.fit_of(self.chosen)

    @property
    def baseline_fit(self) -> ModelFit:
        return self.fit_of(())


def _sigma(
    data: Dataset,
    u_model_K: float,
    names: tuple[str, ...] = (),
    model_error: ModelError = None,
) -> np.ndarray:
    """sqrt(u_D² + u_model² + u_sur²): u_model (time-step and other model error, K) on
    temperatures only, u_sur the forward model's own error estimate for the model of ``names``
    (the surrogate's interpolation error)."""
    u_model = np.where(_temperatures(data), u_model_K, 0.0)
    u_sur = 0.0 if model_error is None else np.asarray(model_error(data, tuple(names)))
    return np.sqrt(
        np.array([m.uncertainty for m in data.measurements]) ** 2 + u_model**2 + u_sur**2
    )


def _values(data: Dataset) -> np.ndarray:
    return np.array([m.value for m in data.measurements])


def _temperatures(data: Dataset) -> np.ndarray:
    """Which measurements are temperatures (RMS errors in K are taken over these)."""
    return np.array([m.is_temperature for m in data.measurements], dtype=bool)


def chi2(
    predict: Predict,
    data: Dataset,
    model: dict[str, float],
    u_model_K: float,
    model_error: ModelError = None,
) -> float:
    r = _residuals(predict, data, model, _sigma(data, u_model_K, tuple(model), model_error))
    return float(r @ r)


def _residuals(predict, data, model, sigma):
    D = _values(data)
    w = np.sqrt(np.array(data.series_weights()))
    return w * (predict(data, model) - D) / sigma


def ranking_error(model_error: ModelError) -> ModelError:
    """The error estimate used when models are compared: the part common to every model (the
    ambient axis), not each model's own candidates. With each model's own error in sigma, a
    candidate whose table is poor would lower its model's chi2 by widening its sigma and win the
    ranking for it (seen: a steep glass-transition axis joining every friction law as a pair)."""
    if model_error is None:
        return None
    return lambda data, names: model_error(data, ())


def gof_p_value(chi2_value: float, n: float, k: int) -> float:
    """p-value of the chi-square goodness-of-fit test (n - k degrees of freedom, at least 1)."""
    return float(stats.chi2.sf(chi2_value, max(n - k, 1)))


def interval_scale(chi2_value: float, n: float, k: int) -> float:
    """Factor on the profile threshold: 1 for a fit that passes the chi-square test at 1 %, else
    chi2 / dof (the noise scaled until the fit is acceptable; the interval is then the range the
    data allow if the misfit were noise, not a 95 % interval of a model that explains them)."""
    if gof_p_value(chi2_value, n, k) >= GOF_LEVEL:
        return 1.0
    return max(1.0, chi2_value / max(n - k, 1))


def fit(
    predict: Predict,
    data: Dataset,
    names: tuple[str, ...],
    u_model_K: float = 1.0,
    library: tuple[Candidate, ...] = LIBRARY,
    fixed: dict[str, float] | None = None,
    model_error: ModelError = None,
) -> tuple[dict[str, float], float]:
    """Least-squares fit of the candidates ``names`` (others in ``fixed`` held): (params, chi2)."""
    fixed = dict(fixed or {})
    free = [n for n in names if n not in fixed]
    pars = [by_name(n, library).parameter for n in free]
    sigma = _sigma(data, u_model_K, tuple(names), model_error)
    if not free:
        model = {**fixed}
        r = _residuals(predict, data, model, sigma)
        return {n: model[n] for n in names}, float(r @ r)

    def model_of(u):
        return {
            **fixed,
            **{n: p.from_unit(float(np.clip(x, 0.0, 1.0))) for n, p, x in zip(free, pars, u)},
        }

    def res(u):
        return _residuals(predict, data, model_of(u), sigma)

    g = np.linspace(0.0, 1.0, 11 if len(free) == 1 else 7)
    grid = list(itertools.product(g, repeat=len(free)))
    vals = [float(np.sum(res(np.array(u)) ** 2)) for u in grid]
    u0 = np.array(grid[int(np.argmin(vals))])
    u0 = np.clip(u0, 1e-6, 1.0 - 1e-6)
    sol = optimize.least_squares(res, u0, bounds=(0.0, 1.0), x_scale=0.1, diff_step=1e-4)
    best = sol.x if 2.0 * sol.cost <= min(vals) else u0
    model = model_of(best)
    r = _residuals(predict, data, model, sigma)
    return {n: model[n] for n in names}, float(r @ r)


def profile_interval(
    predict: Predict,
    data: Dataset,
    names: tuple[str, ...],
    which: str,
    chi2_min: float,
    u_model_K: float = 1.0,
    library: tuple[Candidate, ...] = LIBRARY,
    points: int = 21,
    model_error: ModelError = None,
    scale: float = 1.0,
) -> tuple[float, float, bool]:
    """95 % profile-likelihood interval of ``which`` (clipped to the prior): (lo, hi, spans whole
    prior). ``scale`` multiplies the threshold 3.84 (:func:`interval_scale`)."""
    p = by_name(which, library).parameter
    best, _ = fit(predict, data, names, u_model_K, library, model_error=model_error)
    threshold = CHI2_95 * scale
    u_best = p.to_unit(best[which])
    us = np.unique(
        np.concatenate(
            [
                np.linspace(0.0, 1.0, points),
                np.clip(u_best + np.linspace(-0.06, 0.06, 13), 0.0, 1.0),
                [u_best],
            ]
        )
    )
    points = len(us)
    prof = []
    for u in us:
        _, c2 = fit(
            predict,
            data,
            names,
            u_model_K,
            library,
            fixed={which: p.from_unit(u)},
            model_error=model_error,
        )
        prof.append(c2)
    prof = np.array(prof)
    chi2_min = min(chi2_min, float(prof.min()))
    ok = prof <= chi2_min + threshold
    idx = np.nonzero(ok)[0]
    lo_u, hi_u = us[idx[0]], us[idx[-1]]

    # refine the edges by linear interpolation of the profile between grid points
    def edge(i, j):
        a, b = prof[i] - chi2_min - threshold, prof[j] - chi2_min - threshold
        return us[i] + (us[j] - us[i]) * a / (a - b) if a != b else us[i]

    if idx[0] > 0:
        lo_u = edge(idx[0] - 1, idx[0])
    if idx[-1] < points - 1:
        hi_u = edge(idx[-1], idx[-1] + 1)
    whole = bool(ok[0] and ok[-1])
    return p.from_unit(lo_u), p.from_unit(hi_u), whole


def held_out_errors(
    predict: Predict,
    data: Dataset,
    names: tuple[str, ...],
    u_model_K: float = 1.0,
    library: tuple[Candidate, ...] = LIBRARY,
    model_error: ModelError = None,
) -> np.ndarray | None:
    """Prediction minus value of every measurement, each predicted by the model fitted to the
    other operating points (in the measurement's unit; None: fewer than two points)."""
    if len(data.points) < 2:
        return None
    err = np.empty(len(data))
    for pt in data.points:
        at = np.array([m.point == pt for m in data.measurements])
        train = data.without_point(pt)
        test = data.subset(at)
        model, _ = (
            fit(predict, train, names, u_model_K, library, model_error=model_error)
            if names
            else ({}, 0.0)
        )
        err[at] = predict(test, model) - _values(test)
    return err


def _rms(err: np.ndarray | None, data: Dataset, unit: str) -> float | None:
    """RMS of ``err`` over the measurements in ``unit`` (None: no errors or no such reading)."""
    if err is None:
        return None
    mask = np.array([m.unit == unit for m in data.measurements], dtype=bool)
    return float(np.sqrt(np.mean(np.square(err[mask])))) if np.any(mask) else None


def _criterion(c2: float, k: int, n: int, kind: str) -> float:
    if kind == "AICc":
        return c2 + 2 * k + 2 * k * (k + 1) / (n - k - 1)
    return c2 + 2 * k


def diagnose(
    predict: Predict,
    data: Dataset,
    library: tuple[Candidate, ...] = LIBRARY,
    max_size: int = 2,
    u_model_K: float = 1.0,
    detect: float = 6.0,
    tie: float = 2.0,
    probes: Dataset | None = None,
    intervals: bool = True,
    model_error: ModelError = None,
) -> Diagnosis:
    """Fit, rank and judge every model of up to ``max_size`` candidates (see the module docstring).

    ``model_error(data, names)``: the forward model's error estimate per measurement (the
    surrogate's), added in quadrature to u_D and u_model: in the ranking only its part common to
    every model (:func:`ranking_error`), in the intervals and held-out refits each model's own.
    Returns the :class:`Diagnosis`:
    ``models`` (ranked), ``verdict``, ``gain``, counts.
    """
    require_nonnegative("diagnose.u_model_K", u_model_K)
    n = data.n_effective()
    names = [c.name for c in library]
    sets: list[tuple[str, ...]] = [()]
    for size in range(1, max_size + 1):
        sets += [s for s in itertools.combinations(names, size) if size < n]
    kind = "AICc" if all(n - len(s) - 1 > 0 for s in sets) else "AIC"
    results = []
    rank_error = ranking_error(model_error)
    for s in sets:
        params, c2 = fit(predict, data, s, u_model_K, library, model_error=rank_error)
        results.append(
            {
                "candidates": list(s),
                "params": params,
                "chi2": c2,
                "k": len(s),
                "criterion": _criterion(c2, len(s), n, kind),
            }
        )
    results.sort(key=lambda r: r["criterion"])
    best_c = results[0]["criterion"]
    for r in results:
        r["delta"] = r["criterion"] - best_c
    base = next(r for r in results if not r["candidates"])
    # parsimony: a nested sub-model within `tie` of the best replaces it
    chosen = results[0]
    for r in results:
        if (
            r["delta"] < tie
            and set(r["candidates"]) < set(chosen["candidates"])
            and r["candidates"]
        ):
            chosen = r
    verdict: dict = {}
    if base["delta"] - chosen["delta"] <= detect or chosen is base:
        chosen = base
        gof = gof_p_value(base["chi2"], n, 0)
        verdict = {
            "kind": "baseline adequate",
            "chosen": [],
            "competitors": [],
            "chi2_p_value": gof,
        }
        if gof < 0.01:
            verdict["kind"] = "unexplained"
    else:
        rivals = [
            r
            for r in results
            if r is not chosen
            and r["candidates"]
            and r["delta"] - chosen["delta"] < tie
            and not set(r["candidates"]) <= set(chosen["candidates"])
            and not set(chosen["candidates"]) <= set(r["candidates"])
        ]
        verdict = {
            "kind": "identified",
            "chosen": chosen["candidates"],
            "competitors": [r["candidates"] for r in rivals],
        }
        gof = gof_p_value(chosen["chi2"], n, chosen["k"])
        verdict["chi2_p_value"] = gof
        # a best fit that fails the chi-square test explains nothing, whatever its rivals: that is
        # said first (rivals that fail alike are not "not identifiable", they are all wrong)
        if gof < GOF_LEVEL:
            verdict["kind"] = "partial"
        elif rivals:
            verdict["kind"] = "not identifiable"
    # intervals and held-out errors for the models that matter
    rivals_all = [
        r for r in results if any(r["candidates"] == c for c in verdict.get("competitors", []))
    ]
    top = []
    for r in [base, chosen, *rivals_all, *results[:4]]:
        if not any(r is t for t in top):
            top.append(r)
    for r in results:
        r["intervals"] = {}
        r["spans_prior"] = []
        r["interval_scale"] = interval_scale(r["chi2"], n, r["k"])
    if intervals:
        for r in top:
            # intervals with the model's own surrogate error in sigma
            own = (
                fit(predict, data, tuple(r["candidates"]), u_model_K, library, None, model_error)[1]
                if r["candidates"]
                else r["chi2"]
            )
            for name in r["candidates"]:
                lo, hi, whole = profile_interval(
                    predict,
                    data,
                    tuple(r["candidates"]),
                    name,
                    own,
                    u_model_K,
                    library,
                    model_error=model_error,
                    scale=r["interval_scale"],
                )
                r["intervals"][name] = [lo, hi]
                if whole:
                    r["spans_prior"].append(name)
    if verdict["kind"] == "identified" and chosen["spans_prior"]:
        verdict["kind"] = "not identifiable"
        verdict["unconstrained"] = chosen["spans_prior"]
    for r in results:
        r["loo_errors"] = (
            held_out_errors(predict, data, tuple(r["candidates"]), u_model_K, library, model_error)
            if any(r is t for t in top)
            else None
        )
        r["loo_rmse_K"] = _rms(r["loo_errors"], data, "C")
        r["predictions_C"] = (
            predict(data, r["params"]).tolist() if any(r is t for t in top) else None
        )
    if verdict["kind"] == "not identifiable" and probes is not None:
        verdict["separate_by"] = separating_measurements(
            predict,
            probes,
            chosen,
            [r for r in results if r["candidates"] in verdict["competitors"]],
        )
    verdict["text"] = verdict_text(verdict, chosen, library)
    return Diagnosis(
        n_measurements=len(data),
        n_effective=n,
        criterion=kind,
        u_model_K=u_model_K,
        thresholds={"detect": detect, "tie": tie},
        models=tuple(_model_fit(r) for r in results),
        verdict=Verdict(
            kind=verdict["kind"],
            chosen=tuple(verdict["chosen"]),
            competitors=tuple(tuple(c) for c in verdict["competitors"]),
            chi2_p_value=verdict["chi2_p_value"],
            text=verdict["text"],
            unconstrained=tuple(verdict.get("unconstrained", ())),
            separate_by=tuple(
                Separation(
                    tuple(x["rival"]),
                    x["measurement"],
                    x["difference"],
                    x["unit"],
                    x["separation_u"],
                )
                for x in verdict.get("separate_by", ())
            ),
        ),
        chosen=tuple(chosen["candidates"]),
        gain=Gain(
            loo_rmse_before_K=base["loo_rmse_K"],
            loo_rmse_after_K=chosen["loo_rmse_K"],
            rmse_before_K=_rmse(base, data),
            rmse_after_K=_rmse(chosen, data),
            other_units=tuple(
                UnitGain(
                    unit=u,
                    loo_rmse_before=_rms(base["loo_errors"], data, u),
                    loo_rmse_after=_rms(chosen["loo_errors"], data, u),
                    rmse_before=_rmse(base, data, u),
                    rmse_after=_rmse(chosen, data, u),
                )
                for u in dict.fromkeys(m.unit for m in data.measurements)
                if u != "C"
            ),
        ),
    )


def _model_fit(r: dict) -> ModelFit:
    return ModelFit(
        candidates=tuple(r["candidates"]),
        params=dict(r["params"]),
        chi2=r["chi2"],
        k=r["k"],
        criterion=r["criterion"],
        delta=r["delta"],
        intervals=dict(r["intervals"]),
        spans_prior=tuple(r["spans_prior"]),
        loo_rmse_K=r["loo_rmse_K"],
        predictions_C=r["predictions_C"],
        interval_scale=r["interval_scale"],
    )


def _rmse(r: dict, data: Dataset, unit: str = "C") -> float | None:
    """In-sample RMS error of model ``r``'s predictions of the readings in ``unit``."""
    if r.get("predictions_C") is None:
        return None
    return _rms(np.array(r["predictions_C"]) - _values(data), data, unit)


def separating_measurements(
    predict: Predict, probes: Dataset, chosen: dict, rivals: list[dict], top: int = 3
) -> list[dict]:
    """The probe readings where the fitted rivals' predictions differ most, in units of each
    reading's measurement uncertainty (the probes' ``uncertainty``: a torque meter's N m and a
    camera's K are compared by what each instrument can resolve)."""
    a = predict(probes, chosen["params"])
    u = np.array([m.uncertainty for m in probes.measurements])
    out = []
    for r in rivals:
        d = np.abs(predict(probes, r["params"]) - a)
        for i in np.argsort(-d / u)[:top]:
            m: Measurement = probes.measurements[int(i)]
            out.append(
                {
                    "rival": r["candidates"],
                    "measurement": m.label(),
                    "difference": float(d[i]),
                    "unit": "K" if m.is_temperature else m.unit,
                    "separation_u": float(d[i] / u[i]),
                }
            )
    return out


def verdict_text(verdict: dict, chosen: dict, library: tuple[Candidate, ...]) -> str:
    """The verdict in words. ``chosen`` may carry ``surrogate_params`` (the surrogate's values
    when the parameters are full-model refined ones: quoted where they differ) and
    ``interval_scale`` (> 1: the fit fails the chi-square test and the intervals are scaled)."""

    def fmt(r):
        parts = []
        scale = r.get("interval_scale", 1.0)
        for name in r["candidates"]:
            p = by_name(name, library).parameter
            iv = r.get("intervals", {}).get(name)
            s = f"{name} ({p.name} = {r['params'][name]:.4g} {p.unit}"
            if iv and scale > 1.0:
                s += (
                    f", range [{iv[0]:.4g}, {iv[1]:.4g}] with the noise scaled by chi2/dof = "
                    f"{scale:.3g}: not a 95 % interval, the fit fails"
                )
            elif iv:
                s += f", 95 % profile interval [{iv[0]:.4g}, {iv[1]:.4g}]"
            sur = r.get("surrogate_params", {}).get(name)
            if sur is not None and abs(p.to_unit(sur) - p.to_unit(r["params"][name])) > 1e-3:
                s += f"; full-model refined, the surrogate alone gave {sur:.4g}"
            parts.append(s + ")")
        return " + ".join(parts)

    kind = verdict["kind"]
    if kind == "baseline adequate":
        return (
            "baseline adequate: no candidate improves the fit by more than the evidence threshold"
        )
    if kind == "unexplained":
        return (
            "discrepancy unexplained: the baseline fails the chi-square test (p = "
            f"{verdict['chi2_p_value']:.2g}) and no candidate in the library explains it"
        )
    if kind == "identified":
        return fmt(chosen)
    if kind == "partial":
        others = verdict.get("competitors") or []
        alike = f" (as poor: {', '.join('+'.join(c) for c in others)})" if others else ""
        if "full_rmse_K" in chosen:
            rmse = chosen["full_rmse_K"]
            rms = f", RMS error {rmse:.3g} K" if rmse is not None else ""
            return (
                f"no candidate explains the data on the full model: the best on the surrogate, "
                f"{fmt(chosen)}, fails the chi-square test on the full model at that value "
                f"(chi2 = {chosen['chi2']:.3g}, p = {verdict['chi2_p_value']:.2g}{rms}){alike}; "
                "the surrogate's fit does not hold on the model it stands for (a branch or a "
                "step of the full model between the surrogate's nodes)"
            )
        return (
            f"no candidate explains the data: the best, {fmt(chosen)}, still fails the "
            f"chi-square test "
            f"(chi2 = {chosen['chi2']:.3g}, p = {verdict['chi2_p_value']:.2g}){alike}; the cause "
            "is outside the library "
            "or needs more candidates at once than these data can test"
        )
    rivals = " vs ".join("+".join(c) for c in [chosen["candidates"], *verdict["competitors"]])
    text = f"not identifiable with these data: {rivals}"
    if verdict.get("unconstrained"):
        text += f" (parameter of {', '.join(verdict['unconstrained'])} spans its whole prior)"
    sep = verdict.get("separate_by")
    if sep:
        best = max(sep, key=lambda s: s["separation_u"])
        text += (
            f"; measure {best['measurement']} to separate them (fits differ by "
            f"{best['difference']:.3g} {best['unit']}, {best['separation_u']:.1f} u)"
        )
    return text


__all__ = [
    "Diagnosis",
    "EdgeCheck",
    "Gain",
    "ModelFit",
    "Refinement",
    "Separation",
    "UnitGain",
    "Verdict",
    "chi2",
    "diagnose",
    "fit",
    "gof_p_value",
    "interval_scale",
    "profile_interval",
    "ranking_error",
    "refine",
]


def refine(
    full_predict: Predict,
    surrogate_predict: Predict,
    data: Dataset,
    result: Diagnosis,
    iterations: int = 1,
    final_check: bool = True,
    u_model_K: float | None = None,
    library: tuple[Candidate, ...] = LIBRARY,
    model_error: ModelError = None,
    edges: str = "auto",
    edge_tol: float = 0.5,
    edge_runs: int = 3,
) -> Diagnosis:
    """Confirm the chosen model on the full model and remove the surrogate's bias at the optimum.

    Output space mapping: with delta = S_full(p*) - S_surrogate(p*) per measurement, the corrected
    surrogate S_surrogate(p) + delta equals the full model at p* and keeps the surrogate's
    derivatives; it is refitted (``iterations`` times, each costing one full-model run per
    operating point) and its profile intervals replace the surrogate's. ``final_check`` runs the
    full model once more at the refined parameters.

    Interval edges on the full model (``edges``: "always", "never", or "auto": when the
    surrogate's error estimate ``model_error`` could move chi2 at an edge by more than
    ``edge_tol``, i.e. 2 sqrt(chi2_edge) |e/sigma| + |e/sigma|^2 > edge_tol with the weighted
    norm over the data): the full model's chi2 (sigma without the surrogate error) is evaluated
    at each edge of the corrected surrogate's interval (the other parameters of a pair at their
    corrected-surrogate profile values) and, when it misses the threshold min + 3.84 s by more
    than ``edge_tol``, the edge is moved by regula falsi on the full model (at most
    ``edge_runs`` full-model evaluations per edge). The verdict text is rewritten with the
    refined values (the surrogate's quoted where they differ). Returns ``result`` with
    ``refined`` set (unchanged when no candidate was chosen).
    """
    if not result.chosen:
        return result
    if edges not in ("auto", "always", "never"):
        raise ParameterError("refine.edges", edges, "auto, always or never")
    u_model_K = result.u_model_K if u_model_K is None else u_model_K
    names = result.chosen
    n, k = result.n_effective, len(names)
    params0 = dict(result.chosen_fit.params)
    params = params0
    full_runs: dict[tuple, np.ndarray] = {}

    def full(_data, model):
        key = tuple(sorted((a, float(b)) for a, b in model.items()))
        if key not in full_runs:
            full_runs[key] = np.asarray(full_predict(data, dict(model)))
        return full_runs[key]

    corrections = []
    corrected = surrogate_predict
    c2 = result.chosen_fit.chi2
    for _ in range(iterations):
        delta = full(data, params) - surrogate_predict(data, params)
        corrections.append(float(np.max(np.abs(delta))))

        def corrected(d, m, _delta=delta):  # noqa: F811 - the corrected surrogate of this iteration
            return surrogate_predict(d, m) + _delta

        params, c2 = fit(corrected, data, names, u_model_K, library, model_error=model_error)
    scale = interval_scale(c2, n, k)
    ivs = {}
    for name in names:
        lo, hi, _ = profile_interval(
            corrected,
            data,
            names,
            name,
            c2,
            u_model_K,
            library,
            model_error=model_error,
            scale=scale,
        )
        ivs[name] = [lo, hi]
    check = {}
    D = _values(data)
    T = _temperatures(data)
    if final_check:
        F = full(data, params)
        check = {
            "full_rmse_K": float(np.sqrt(np.mean((F - D)[T] ** 2))) if np.any(T) else None,
            "full_vs_corrected_max_K": float(np.max(np.abs(F - corrected(data, params)))),
            "full_C": F.tolist(),
        }
    # the interval edges on the full model
    sigma_full = _sigma(data, u_model_K)
    w = np.array(data.series_weights())

    chi2_seen: dict[tuple, float] = {}

    def chi2_full(model):
        # each model once: the refined one is asked for by the minimum and the final check
        key = tuple(sorted(model.items()))
        if key not in chi2_seen:
            r = _residuals(full, data, model, sigma_full)
            chi2_seen[key] = float(r @ r)
        return chi2_seen[key]

    c_min = min(chi2_full(m) for m in [params0, params] if final_check or m is params0)
    if final_check:
        check["full_chi2"] = chi2_full(params)
        check["full_p_value"] = gof_p_value(check["full_chi2"], n, k)
    target = c_min + CHI2_95 * scale
    if edges == "auto":
        e = np.zeros(len(data)) if model_error is None else np.asarray(model_error(data, names))
        x = float(np.sqrt(np.sum(w * (e / sigma_full) ** 2)))
        do_check = 2.0 * np.sqrt(target) * x + x * x > edge_tol
    else:
        do_check = edges == "always"
    checks = []
    for name in names:
        p = by_name(name, library).parameter
        for side, bound in (("lo", 0.0), ("hi", 1.0)):
            v_e = ivs[name][0 if side == "lo" else 1]
            if not do_check:
                checks.append(EdgeCheck(name, side, v_e, v_e, None, 0, False))
                continue
            edge, excess, runs = _full_edge(
                chi2_full,
                lambda v, _n=name: fit(
                    corrected,
                    data,
                    names,
                    u_model_K,
                    library,
                    fixed={_n: v},
                    model_error=model_error,
                )[0],
                p,
                params[name],
                v_e,
                bound,
                target,
                edge_tol,
                edge_runs,
            )
            checks.append(EdgeCheck(name, side, v_e, edge, excess, runs, True))
            ivs[name][0 if side == "lo" else 1] = edge
    refined = Refinement(
        params=params,
        intervals=ivs,
        chi2=c2,
        max_correction_K=corrections,
        edges=tuple(checks),
        interval_scale=scale,
        **check,
    )
    # the verdict quotes the refined values
    v = result.verdict
    chosen = {
        "candidates": list(names),
        "params": params,
        "intervals": ivs,
        "chi2": c2,
        "interval_scale": scale,
        "surrogate_params": params0,
    }
    vd = {
        "kind": v.kind,
        "competitors": [list(c) for c in v.competitors],
        "chi2_p_value": v.chi2_p_value,
        "unconstrained": list(v.unconstrained),
        "separate_by": [dataclasses.asdict(x) for x in v.separate_by],
    }
    if refined.fails_full_model:
        # the full model is the model: a fit that passes on the (corrected) surrogate only is no
        # explanation, and that is said before any rivalry
        vd["kind"] = "partial"
        vd["chi2_p_value"] = refined.full_p_value
        chosen["chi2"] = refined.full_chi2
        chosen["full_rmse_K"] = refined.full_rmse_K
        chosen["intervals"] = {}  # a profile interval of a model that fails is not quoted
    text = verdict_text(vd, chosen, library)
    verdict = dataclasses.replace(v, text=text, kind=vd["kind"], chi2_p_value=vd["chi2_p_value"])
    return dataclasses.replace(result, refined=refined, verdict=verdict)


def _full_edge(chi2_full, model_at, p, v_best, v_edge, bound, target, tol, max_runs):
    """One profile edge on the full model (see :func:`refine`): (edge, chi2 - target at the
    surrogate's edge, full-model evaluations)."""
    u_best, u_e = p.to_unit(v_best), p.to_unit(v_edge)
    g_best = chi2_full(model_at(v_best)) - target
    g_e = chi2_full(model_at(v_edge)) - target
    runs = 1
    if abs(g_e) <= tol or g_best >= 0.0:
        return v_edge, g_e, runs
    if g_e < 0.0:  # the surrogate's edge is inside the full model's: look outward
        if abs(u_e - bound) < 1e-9:
            return v_edge, g_e, runs
        g_b = chi2_full(model_at(p.from_unit(bound))) - target
        runs += 1
        if g_b <= 0.0:
            return p.from_unit(bound), g_e, runs
        a, ga, b, gb = u_e, g_e, bound, g_b
    else:
        a, ga, b, gb = u_best, g_best, u_e, g_e
    # regula falsi: ga < 0 < gb
    while True:
        u = a + (b - a) * ga / (ga - gb)
        if runs >= max_runs:
            return p.from_unit(u), g_e, runs
        g = chi2_full(model_at(p.from_unit(u))) - target
        runs += 1
        if abs(g) <= tol:
            return p.from_unit(u), g_e, runs
        if g < 0.0:
            a, ga = u, g
        else:
            b, gb = u, g
