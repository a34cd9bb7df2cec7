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
  "not identifiable" when a non-nested model lies within ``tie`` of it, or when a parameter's
  profile-likelihood interval spans its whole prior; the report then names the measurement (among
  ``probes``) where the rival fits differ most;
* "partial": the best model beats the baseline but still fails a chi-square goodness-of-fit test
  at 1 %; "unexplained": no model beats the baseline, which fails that test.

Intervals: 95 % profile likelihood (chi2 within 3.84 of the minimum, other parameter re-fitted).
Held-out error: leave one operating point out, refit, predict it (RMS over its measurements, K).
"""

from __future__ import annotations

import dataclasses
import itertools
from collections.abc import Callable

import numpy as np
from scipy import optimize, stats

from gearfem.core.params import require_nonnegative
from gearfem.core.results import JsonRecord
from gearfem.diagnose.candidates import LIBRARY, Candidate, by_name
from gearfem.diagnose.data import Dataset, Measurement

Predict = Callable[[Dataset, dict[str, float]], np.ndarray]
CHI2_95 = 3.841


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

    @property
    def label(self) -> str:
        return "+".join(self.candidates) or "baseline"


@dataclasses.dataclass(frozen=True)
class Separation(JsonRecord):
    """A measurement that would separate the chosen model from a rival."""

    rival: tuple[str, ...]
    measurement: str
    difference_K: float


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
class Gain(JsonRecord):
    """Errors before (baseline) and after (chosen model)."""

    loo_rmse_before_K: float | None
    loo_rmse_after_K: float | None
    rmse_before_K: float | None
    rmse_after_K: float | None


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


def _sigma(data: Dataset, u_model_K: float) -> np.ndarray:
    """sqrt(u_D² + u_model²); u_model (surrogate and time-step error, K) on temperatures only."""
    u_model = np.where(_temperatures(data), u_model_K, 0.0)
    return np.sqrt(np.array([m.uncertainty for m in data.measurements]) ** 2 + u_model**2)


def _values(data: Dataset) -> np.ndarray:
    return np.array([m.value for m in data.measurements])


def _temperatures(data: Dataset) -> np.ndarray:
    """Which measurements are temperatures (RMS errors in K are taken over these)."""
    return np.array([m.is_temperature for m in data.measurements], dtype=bool)


def chi2(predict: Predict, data: Dataset, model: dict[str, float], u_model_K: float) -> float:
    r = _residuals(predict, data, model, u_model_K)
    return float(r @ r)


def _residuals(predict, data, model, u_model_K):
    D = _values(data)
    w = np.sqrt(np.array(data.series_weights()))
    return w * (predict(data, model) - D) / _sigma(data, u_model_K)


def fit(
    predict: Predict,
    data: Dataset,
    names: tuple[str, ...],
    u_model_K: float = 1.0,
    library: tuple[Candidate, ...] = LIBRARY,
    fixed: dict[str, float] | None = None,
) -> tuple[dict[str, float], float]:
    """Least-squares fit of the candidates ``names`` (others in ``fixed`` held): (params, chi2)."""
    fixed = dict(fixed or {})
    free = [n for n in names if n not in fixed]
    pars = [by_name(n, library).parameter for n in free]
    if not free:
        model = {**fixed}
        return {n: model[n] for n in names}, chi2(predict, data, model, u_model_K)

    def model_of(u):
        return {
            **fixed,
            **{n: p.from_unit(float(np.clip(x, 0.0, 1.0))) for n, p, x in zip(free, pars, u)},
        }

    def res(u):
        return _residuals(predict, data, model_of(u), u_model_K)

    g = np.linspace(0.0, 1.0, 11 if len(free) == 1 else 7)
    grid = list(itertools.product(g, repeat=len(free)))
    vals = [float(np.sum(res(np.array(u)) ** 2)) for u in grid]
    u0 = np.array(grid[int(np.argmin(vals))])
    u0 = np.clip(u0, 1e-6, 1.0 - 1e-6)
    sol = optimize.least_squares(res, u0, bounds=(0.0, 1.0), x_scale=0.1, diff_step=1e-4)
    best = sol.x if 2.0 * sol.cost <= min(vals) else u0
    model = model_of(best)
    return {n: model[n] for n in names}, chi2(predict, data, model, u_model_K)


def profile_interval(
    predict: Predict,
    data: Dataset,
    names: tuple[str, ...],
    which: str,
    chi2_min: float,
    u_model_K: float = 1.0,
    library: tuple[Candidate, ...] = LIBRARY,
    points: int = 21,
) -> tuple[float, float, bool]:
    """95 % profile-likelihood interval of ``which`` (clipped to the prior): (lo, hi, spans whole
    prior)."""
    p = by_name(which, library).parameter
    best, _ = fit(predict, data, names, u_model_K, library)
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
        _, c2 = fit(predict, data, names, u_model_K, library, fixed={which: p.from_unit(u)})
        prof.append(c2)
    prof = np.array(prof)
    chi2_min = min(chi2_min, float(prof.min()))
    ok = prof <= chi2_min + CHI2_95
    idx = np.nonzero(ok)[0]
    lo_u, hi_u = us[idx[0]], us[idx[-1]]

    # refine the edges by linear interpolation of the profile between grid points
    def edge(i, j):
        a, b = prof[i] - chi2_min - CHI2_95, prof[j] - chi2_min - CHI2_95
        return us[i] + (us[j] - us[i]) * a / (a - b) if a != b else us[i]

    if idx[0] > 0:
        lo_u = edge(idx[0] - 1, idx[0])
    if idx[-1] < points - 1:
        hi_u = edge(idx[-1], idx[-1] + 1)
    whole = bool(ok[0] and ok[-1])
    return p.from_unit(lo_u), p.from_unit(hi_u), whole


def leave_one_point_out(
    predict: Predict,
    data: Dataset,
    names: tuple[str, ...],
    u_model_K: float = 1.0,
    library: tuple[Candidate, ...] = LIBRARY,
) -> float | None:
    """RMS error (K) of each operating point predicted by the model fitted to the others."""
    errs = []
    if len(data.points) < 2:
        return None
    for pt in data.points:
        train = data.without_point(pt)
        test = data.subset(m.point == pt for m in data.measurements)
        model, _ = fit(predict, train, names, u_model_K, library) if names else ({}, 0.0)
        T = _temperatures(test)
        errs.extend((predict(test, model) - _values(test))[T])
    return float(np.sqrt(np.mean(np.square(errs)))) if errs else None


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
) -> Diagnosis:
    """Fit, rank and judge every model of up to ``max_size`` candidates (see the module docstring).

    Returns the :class:`Diagnosis`: ``models`` (ranked), ``verdict``, ``gain``, counts.
    """
    require_nonnegative("diagnose.u_model_K", u_model_K)
    n = data.n_effective()
    names = [c.name for c in library]
    sets: list[tuple[str, ...]] = [()]
    for size in range(1, max_size + 1):
        sets += [s for s in itertools.combinations(names, size) if size < n]
    kind = "AICc" if all(n - len(s) - 1 > 0 for s in sets) else "AIC"
    results = []
    for s in sets:
        params, c2 = fit(predict, data, s, u_model_K, library)
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
        gof = float(stats.chi2.sf(base["chi2"], max(n, 1)))
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
        gof = float(stats.chi2.sf(chosen["chi2"], max(n - chosen["k"], 1)))
        verdict["chi2_p_value"] = gof
        if rivals:
            verdict["kind"] = "not identifiable"
        elif gof < 0.01:
            verdict["kind"] = "partial"
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
    if intervals:
        for r in top:
            for name in r["candidates"]:
                lo, hi, whole = profile_interval(
                    predict, data, tuple(r["candidates"]), name, r["chi2"], u_model_K, library
                )
                r["intervals"][name] = [lo, hi]
                if whole:
                    r["spans_prior"].append(name)
    if verdict["kind"] == "identified" and chosen["spans_prior"]:
        verdict["kind"] = "not identifiable"
        verdict["unconstrained"] = chosen["spans_prior"]
    for r in results:
        r["loo_rmse_K"] = (
            leave_one_point_out(predict, data, tuple(r["candidates"]), u_model_K, library)
            if any(r is t for t in top)
            else None
        )
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
                Separation(tuple(x["rival"]), x["measurement"], x["difference_K"])
                for x in verdict.get("separate_by", ())
            ),
        ),
        chosen=tuple(chosen["candidates"]),
        gain=Gain(
            loo_rmse_before_K=base["loo_rmse_K"],
            loo_rmse_after_K=chosen["loo_rmse_K"],
            rmse_before_K=_rmse(base, data),
            rmse_after_K=_rmse(chosen, data),
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
    )


def _rmse(r: dict, data: Dataset) -> float | None:
    if r.get("predictions_C") is None:
        return None
    T = _temperatures(data)
    if not np.any(T):
        return None
    err = np.array(r["predictions_C"]) - _values(data)
    return float(np.sqrt(np.mean(err[T] ** 2)))


def separating_measurements(
    predict: Predict, probes: Dataset, chosen: dict, rivals: list[dict], top: int = 3
) -> list[dict]:
    """The probe measurements where the fitted rivals' predictions differ most (K)."""
    a = predict(probes, chosen["params"])
    out = []
    for r in rivals:
        d = np.abs(predict(probes, r["params"]) - a)
        for i in np.argsort(-d)[:top]:
            m: Measurement = probes.measurements[int(i)]
            out.append(
                {"rival": r["candidates"], "measurement": m.label(), "difference_K": float(d[i])}
            )
    return out


def verdict_text(verdict: dict, chosen: dict, library: tuple[Candidate, ...]) -> str:
    def fmt(r):
        parts = []
        for name in r["candidates"]:
            p = by_name(name, library).parameter
            iv = r.get("intervals", {}).get(name)
            s = f"{name} ({p.name} = {r['params'][name]:.4g} {p.unit}"
            if iv:
                s += f", 95 % profile interval [{iv[0]:.4g}, {iv[1]:.4g}]"
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
        return (
            f"no candidate explains the data: the best, {fmt(chosen)}, still fails the "
            f"chi-square test "
            f"(chi2 = {chosen['chi2']:.3g}, p = {verdict['chi2_p_value']:.2g}); the cause is "
            f"outside the library "
            "or needs more candidates at once than these data can test"
        )
    rivals = " vs ".join("+".join(c) for c in [chosen["candidates"], *verdict["competitors"]])
    text = f"not identifiable with these data: {rivals}"
    if verdict.get("unconstrained"):
        text += f" (parameter of {', '.join(verdict['unconstrained'])} spans its whole prior)"
    sep = verdict.get("separate_by")
    if sep:
        best = max(sep, key=lambda s: s["difference_K"])
        text += (
            f"; measure {best['measurement']} to separate them "
            f"(fits differ by {best['difference_K']:.1f} K)"
        )
    return text


__all__ = [
    "Diagnosis",
    "Gain",
    "ModelFit",
    "Refinement",
    "Separation",
    "Verdict",
    "chi2",
    "diagnose",
    "fit",
    "leave_one_point_out",
    "profile_interval",
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
) -> Diagnosis:
    """Confirm the chosen model on the full model and remove the surrogate's bias at the optimum.

    Output space mapping: with delta = S_full(p*) - S_surrogate(p*) per measurement, the corrected
    surrogate S_surrogate(p) + delta equals the full model at p* and keeps the surrogate's
    derivatives; it is refitted (``iterations`` times, each costing one full-model run per
    operating point) and its profile intervals replace the surrogate's. ``final_check`` runs the
    full model once more at the refined parameters. Returns ``result`` with ``refined`` set
    (unchanged when no candidate was chosen).
    """
    if not result.chosen:
        return result
    u_model_K = result.u_model_K if u_model_K is None else u_model_K
    names = result.chosen
    params = dict(result.chosen_fit.params)
    corrections = []
    corrected = surrogate_predict
    for _ in range(iterations):
        delta = full_predict(data, params) - surrogate_predict(data, params)
        corrections.append(float(np.max(np.abs(delta))))

        def corrected(d, m, _delta=delta):  # noqa: F811 - the corrected surrogate of this iteration
            return surrogate_predict(d, m) + _delta

        params, c2 = fit(corrected, data, names, u_model_K, library)
    ivs = {}
    for name in names:
        lo, hi, _ = profile_interval(corrected, data, names, name, c2, u_model_K, library)
        ivs[name] = [lo, hi]
    check = {}
    D = _values(data)
    T = _temperatures(data)
    if final_check:
        F = full_predict(data, params)
        check = {
            "full_rmse_K": float(np.sqrt(np.mean((F - D)[T] ** 2))) if np.any(T) else None,
            "full_vs_corrected_max_K": float(np.max(np.abs(F - corrected(data, params)))),
            "full_C": F.tolist(),
        }
    refined = Refinement(
        params=params, intervals=ivs, chi2=c2, max_correction_K=corrections, **check
    )
    return dataclasses.replace(result, refined=refined)
