"""Experiment design: which next measurement would best separate the explanations still standing.

After a diagnosis, the explanations still standing are the ranked models within ``standing``
(6) of the best in AICc/AIC, each with its fitted parameters and a prior probability from its
Akaike weight, p_i ∝ exp(-Δ_i / 2). A *proposal* is a set of rows one could add to the data:

* an **operating point** of the bench grid (:func:`bench_grid`): the data's quantities at that
  (speed, torque), end values;
* a **time** along the warm-up curve: the data's quantities at that time, at every operating point
  of the data;
* an **instrument**: one quantity the data do not have (the camera's ``camera_max``, a
  thermocouple ``probe:NAME`` in the web, a side-face probe, the torque meters'
  ``torque_loss_Nm``), end values at every operating point of the data.

Each proposal is scored by simulation (:func:`suggest`): for every standing explanation i taken
as the truth, ``draws`` data sets are made from its prediction at the proposal's rows (the
surrogate at its fitted parameters) with the rows' measurement noise; every standing
explanation is refitted on the old data plus these rows, and the model probabilities after the
measurement are the Akaike weights q_j ∝ exp(-criterion_j / 2). Scores: the expected
information gain on which explanation holds, EIG = H(p) - Σ_i p_i E[H(q) | i] (bits; at most
H(p)), and the probability that the measurement decides, P = Σ_i p_i Pr(i ranks first and every
rival lies more than ``tie`` (2) behind | i). Both are computed with the surrogate (the rows'
predictions) and, for the top proposals, the explanations' predictions are checked on the full
model (:attr:`Proposal.full_max_difference`).

Measurement uncertainties of proposed rows: the camera's stated accuracy with the 2 K of a judged
equilibrium (:func:`~gearfem.diagnose.data.camera_uncertainty_K`), 1.0 K for a thermocouple or a
side-face probe (type K class 1, +-1.5 K, as one standard uncertainty rounded down; assumed), the
torque meters' ``uncertainty_Nm`` x sqrt(1 + i^2) (:mod:`gearfem.instruments.torque`), 1 K for a
field temperature.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import numpy as np

from gearfem.core.errors import ParameterError
from gearfem.core.params import require_positive
from gearfem.core.results import JsonRecord
from gearfem.diagnose.candidates import LIBRARY, Candidate
from gearfem.diagnose.data import Dataset, Measurement, camera_uncertainty_K, unit_of
from gearfem.diagnose.select import (
    Diagnosis,
    ModelError,
    Predict,
    fit,
    ranking_error,
)

#: Speeds of the bench grid, rpm: the thesis bench ran 1000 and 2000 rpm (6.1-6.2); 500 and 1500
#: in between and below. Its servo motors' limits are not stated in the thesis (6.1.1); nothing
#: above the 2000 rpm it ran is proposed (Mao's dry polymer gear tests of thesis 2.6 went to
#: 2500 rpm).
BENCH_SPEEDS_RPM = (500.0, 1000.0, 1500.0, 2000.0)
#: Torques of the bench grid, N m: the thesis bench ran 4 and 8 N m (6.2); 6 in between. Higher
#: torques are not proposed: 8 N m at 1000 rpm already read 110 C, 33 K below the glass
#: transition (143 C, DMA), where a dry PEEK pair is expected to fail (thesis 4.2).
BENCH_TORQUES_NM = (4.0, 6.0, 8.0)
#: Warm-up times, s: the bench ran about 15 min (6.1.1) and recorded the camera video throughout.
WARMUP_TIMES_S = (60.0, 180.0, 300.0, 600.0, 900.0)
PROBE_UNCERTAINTY_K = 1.0


@dataclasses.dataclass(frozen=True)
class Grid(JsonRecord):
    """What the bench can run and read: operating points, warm-up times, instruments."""

    speeds_rpm: tuple[float, ...]
    torques_Nm: tuple[float, ...]
    times_s: tuple[float, ...]
    instruments: tuple[str, ...]
    source: str = (
        "speeds and torques: the thesis bench's runs (1000 rpm / 8 N m, 2000 rpm / 4 N m, thesis "
        "6.2) and points between and below them; limits not stated by the thesis (6.1.1), so "
        "none beyond what it ran; times: its 15 min runs (6.1.1)"
    )

    @property
    def points(self) -> tuple[tuple[float, float], ...]:
        return tuple((s, t) for s in self.speeds_rpm for t in self.torques_Nm)


def bench_grid(instruments: tuple[str, ...], times_s: tuple[float, ...] = WARMUP_TIMES_S) -> Grid:
    """The thesis bench's grid (:data:`BENCH_SPEEDS_RPM` x :data:`BENCH_TORQUES_NM`, warm-up
    times :data:`WARMUP_TIMES_S`) with the instrument quantities the case offers."""
    return check_grid(Grid(BENCH_SPEEDS_RPM, BENCH_TORQUES_NM, tuple(times_s), tuple(instruments)))


@dataclasses.dataclass(frozen=True)
class Explanation(JsonRecord):
    """A standing explanation: a model of the diagnosis, its fitted parameters and its
    probability before the next measurement."""

    candidates: tuple[str, ...]
    params: dict[str, float]
    probability: float

    @property
    def label(self) -> str:
        return "+".join(self.candidates) or "baseline"


@dataclasses.dataclass(frozen=True)
class Proposal(JsonRecord):
    """A candidate next measurement and how well it would separate the explanations.

    ``predicted``: per explanation (label), the predicted value of every row (rows' unit);
    ``uncertainty``: the rows' measurement standard uncertainties; ``full_predicted`` and
    ``full_max_difference``: the same on the full model and its largest difference from the
    surrogate (top proposals only)."""

    kind: str  # "operating point", "time", "instrument"
    label: str
    rows: tuple[str, ...]
    quantities: tuple[str, ...]  # per row
    expected_information_gain_bits: float
    decide_probability: float
    predicted: dict[str, list[float]]
    uncertainty: list[float]
    full_predicted: dict[str, list[float]] | None = None
    full_max_difference: float | None = None

    @property
    def separation(self) -> float:
        """Largest difference between two explanations' predictions over the rows, in units
        of the rows' uncertainty."""
        return float(np.max(self._row_spread(self.predicted))) if self.predicted else 0.0

    def _row_spread(self, vals: dict[str, list[float]]) -> np.ndarray:
        """Per row, the largest difference between two explanations' ``vals``, in units of the
        row's uncertainty."""
        arr = np.array(list(vals.values()))
        return (arr.max(axis=0) - arr.min(axis=0)) / np.array(self.uncertainty)

    @property
    def readings(self) -> dict[str, list[float]]:
        """Each explanation's predicted rows: the full model's where re-run, else the
        surrogate's."""
        return self.full_predicted or self.predicted

    def deciding_row(self) -> int:
        """Index of the row where the explanations' :attr:`readings` differ most, in units of
        the row's uncertainty."""
        return int(np.argmax(self._row_spread(self.readings)))


@dataclasses.dataclass(frozen=True)
class Suggestion(JsonRecord):
    """The ranked proposals (``suggestion.json``)."""

    explanations: tuple[Explanation, ...]
    prior_entropy_bits: float
    grid: Grid
    draws: int
    ranked: tuple[Proposal, ...]
    decisive: tuple[Proposal, ...]
    text: str

    @property
    def separates(self) -> bool:
        """Whether there is anything to separate: two or more standing explanations (with one,
        every proposal's expected gain is zero and the ranking says nothing)."""
        return len(self.explanations) > 1


def reading_uncertainty(quantity: str, value: float, torque_u_Nm: float) -> float:
    """The measurement standard uncertainty of a proposed reading of ``quantity`` that reads
    about ``value`` (see the module docstring; ``torque_u_Nm``: each torque meter's)."""
    if quantity == "camera_max":
        return camera_uncertainty_K(value)
    if quantity == "torque_loss_Nm":
        return torque_u_Nm * math.sqrt(2.0)  # speed ratio 1 (equal gears, thesis 6.1.1)
    if quantity == "efficiency":
        return 0.01
    return PROBE_UNCERTAINTY_K


#: Models within this criterion difference of the best still stand as explanations.
STANDING_DELTA = 6.0


def standing_explanations(
    result: Diagnosis, standing: float = STANDING_DELTA, max_explanations: int = 4
) -> tuple[Explanation, ...]:
    """The ranked models within ``standing`` of the best (at most ``max_explanations``), with
    their Akaike weights renormalised over them."""
    models = [m for m in result.models if m.delta <= standing][:max_explanations]
    w = np.array([math.exp(-0.5 * m.delta) for m in models])
    w /= w.sum()
    return tuple(
        Explanation(m.candidates, dict(m.params), float(p)) for m, p in zip(models, w, strict=True)
    )


def proposals(data: Dataset, grid: Grid) -> list[tuple[str, str, Dataset]]:
    """(kind, label, rows) of every proposal (see the module docstring); values are
    placeholders."""
    quantities = tuple(dict.fromkeys(m.quantity for m in data.measurements))
    have_points = {(m.speed_rpm, m.torque_Nm) for m in data.measurements}
    ambient = float(np.mean([m.ambient_C for m in data.measurements]))
    out = []

    def rows(items):
        return Dataset(tuple(Measurement(s, t, tm, q, 0.0, 1.0, a) for s, t, tm, q, a in items))

    for sp, tq in grid.points:
        if (sp, tq) in have_points:
            continue
        out.append(
            (
                "operating point",
                f"{sp:g} rpm {tq:g} N m: {', '.join(quantities)} (end)",
                rows([(sp, tq, None, q, ambient) for q in quantities]),
            )
        )
    have = {(m.point, m.quantity, m.time_s) for m in data.measurements}
    for t in grid.times_s:
        items = [
            (*pt[:2], t, q, pt[2])
            for pt in data.points
            for q in quantities
            if (pt, q, t) not in have
        ]
        if items:
            out.append(("time", f"{', '.join(quantities)} at {t:g} s of each run", rows(items)))
    for q in grid.instruments:
        if q in quantities:
            continue
        out.append(
            (
                "instrument",
                f"{q} (end) at each run",
                rows([(*pt[:2], None, q, pt[2]) for pt in data.points]),
            )
        )
    return out


def _entropy_bits(p: np.ndarray) -> float:
    p = p[p > 0]
    return float(-(p * np.log2(p)).sum())


def _criterion(c2: float, k: int, n: float) -> float:
    return c2 + 2 * k + (2 * k * (k + 1) / (n - k - 1) if n - k - 1 > 0 else 0.0)


def _weights(crit: np.ndarray) -> np.ndarray:
    w = np.exp(-0.5 * (crit - crit.min()))
    return w / w.sum()


def suggest(
    predict: Predict,
    data: Dataset,
    result: Diagnosis,
    grid: Grid,
    library: tuple[Candidate, ...] = LIBRARY,
    model_error: ModelError = None,
    draws: int = 8,
    seed: int = 0,
    torque_u_Nm: float = 0.04,
    full_predict: Callable[[Dataset, dict[str, float]], np.ndarray] | None = None,
    full_top: int = 3,
    tie: float = 2.0,
    standing: float = 6.0,
) -> Suggestion:
    """Rank the proposals of ``grid`` by expected information gain (module docstring).

    ``predict`` must cover the data's rows and every proposal's (a surrogate tabulated at the
    data's and the grid's points, with every quantity of the grid's instruments and its times).
    ``full_predict``: the full model, run at the explanations' parameters on the rows of the
    ``full_top`` best proposals (one run per explanation and operating point of those rows).
    """
    require_positive("suggest.draws", draws)
    expl = standing_explanations(result, standing)
    prior = np.array([e.probability for e in expl])
    h0 = _entropy_bits(prior)
    rng = np.random.default_rng(seed)
    u_model_K = result.u_model_K
    rank_error = ranking_error(model_error)
    scored: list[tuple[Proposal, Dataset]] = []
    for kind, label, rows in proposals(data, grid):
        pred = {e.label: predict(rows, e.params) for e in expl}
        u = np.array(
            [
                reading_uncertainty(
                    m.quantity, float(np.mean([pred[e.label][i] for e in expl])), torque_u_Nm
                )
                for i, m in enumerate(rows.measurements)
            ]
        )
        eig, decide = 0.0, 0.0
        if len(expl) > 1:
            for i, e in enumerate(expl):
                h_sum, hits = 0.0, 0
                for _ in range(draws):
                    y = pred[e.label] + rng.normal(0.0, u)
                    new = tuple(
                        dataclasses.replace(m, value=float(v), uncertainty=float(s))
                        for m, v, s in zip(rows.measurements, y, u, strict=True)
                    )
                    both = Dataset(data.measurements + new, data.source)
                    n = both.n_effective()
                    crit = np.array(
                        [
                            _criterion(
                                fit(
                                    predict,
                                    both,
                                    f.candidates,
                                    u_model_K,
                                    library,
                                    model_error=rank_error,
                                )[1],
                                len(f.candidates),
                                n,
                            )
                            for f in expl
                        ]
                    )
                    q = _weights(crit)
                    h_sum += _entropy_bits(q)
                    others = np.delete(crit, i)
                    hits += bool(np.all(others - crit[i] > tie))
                eig += e.probability * (h0 - h_sum / draws)
                decide += e.probability * hits / draws
        scored.append(
            (
                Proposal(
                    kind=kind,
                    label=label,
                    rows=tuple(m.label() for m in rows.measurements),
                    quantities=tuple(m.quantity for m in rows.measurements),
                    expected_information_gain_bits=float(eig),
                    decide_probability=float(decide),
                    predicted={k: v.tolist() for k, v in pred.items()},
                    uncertainty=u.tolist(),
                ),
                rows,
            )
        )
    scored.sort(key=lambda x: (-x[0].expected_information_gain_bits, -x[0].decide_probability))
    if full_predict is not None and len(expl) > 1:
        for j, (p, rows) in enumerate(scored[:full_top]):
            fp = {e.label: np.asarray(full_predict(rows, e.params)) for e in expl}
            diff = max(float(np.max(np.abs(fp[k] - np.array(p.predicted[k])))) for k in fp)
            scored[j] = (
                dataclasses.replace(
                    p,
                    full_predicted={k: v.tolist() for k, v in fp.items()},
                    full_max_difference=diff,
                ),
                rows,
            )
    ranked = [p for p, _ in scored]
    decisive = _decisive(ranked)
    return Suggestion(
        explanations=expl,
        prior_entropy_bits=h0,
        grid=grid,
        draws=draws,
        ranked=tuple(ranked),
        decisive=decisive,
        text=suggestion_text(expl, decisive, library, full_model_p=_full_model_failure(result)),
    )


def _full_model_failure(result: Diagnosis) -> float | None:
    """The full model's p-value at the refined chosen model when it fails the goodness-of-fit
    test (the verdict then names no cause), else None."""
    r = result.refined
    return r.full_p_value if r is not None and r.fails_full_model else None


#: A proposal below this expected information gain (bits) is not listed as deciding anything.
MIN_GAIN_BITS = 0.05


def _decisive(ranked: list[Proposal], n: int = 3) -> tuple[Proposal, ...]:
    """The best proposal of each kind, best first, at most ``n``, those that gain at least
    :data:`MIN_GAIN_BITS`."""
    out, kinds = [], set()
    for p in ranked:
        if p.kind in kinds or p.expected_information_gain_bits < MIN_GAIN_BITS:
            continue
        kinds.add(p.kind)
        out.append(p)
    return tuple(out[:n])


def suggestion_text(
    expl: tuple[Explanation, ...],
    decisive: tuple[Proposal, ...],
    library=LIBRARY,
    full_model_p: float | None = None,
) -> str:
    """The measurements that would decide and what each outcome would mean. ``full_model_p``: the
    full model's p-value where the one standing explanation fails on it (no cause named)."""
    if len(expl) < 2 and full_model_p is not None:
        return (
            "nothing of the library to separate, and the one explanation standing on the surrogate"
            + (f" ({expl[0].label})" if expl else "")
            + f" fails on the full model (p = {full_model_p:.2g}): the cause is outside the "
            "library or needs several candidates at once. A measurement of a mechanism itself "
            "(a torque meter reads the flank friction, a probe the bulk) tells more than one "
            "that narrows this parameter"
        )
    if len(expl) >= 2 and not decisive:
        return (
            "no proposal of the grid separates "
            + ", ".join(e.label for e in expl)
            + f" by more than {MIN_GAIN_BITS} bit: they need a measurement outside the grid"
        )
    if len(expl) < 2:
        return (
            "nothing to separate: one explanation stands"
            + (f" ({expl[0].label})" if expl else "")
            + "; a next measurement would narrow its parameter, not change the verdict"
        )
    head = "standing: " + ", ".join(f"{e.label} (p = {e.probability:.2f})" for e in expl)
    lines = [head]
    for k, p in enumerate(decisive, start=1):
        vals = p.readings
        u = np.array(p.uncertainty)
        i = p.deciding_row()
        unit = unit_of(p.quantities[i])
        outcomes = "; ".join(
            f"{v[i]:.3g} {unit} -> {name}"
            for name, v in sorted(vals.items(), key=lambda x: x[1][i])
        )
        lines.append(
            f"{k}. {p.label} ({p.kind}): expected information gain "
            f"{p.expected_information_gain_bits:.2f} bit, decides with probability "
            f"{p.decide_probability:.2f}; at {p.rows[i]} (u = {u[i]:.2g} "
            f"{'K' if unit == 'C' else unit}) a reading near "
            f"{outcomes}"
        )
    return "\n".join(lines)


def check_grid(grid: Grid) -> Grid:
    for s in grid.speeds_rpm:
        require_positive("suggest.speed_rpm", s)
    for t in grid.torques_Nm:
        require_positive("suggest.torque_Nm", t)
    if not grid.points:
        raise ParameterError("suggest.grid", grid.points, "at least one operating point")
    return grid


__all__ = [
    "BENCH_SPEEDS_RPM",
    "BENCH_TORQUES_NM",
    "WARMUP_TIMES_S",
    "Explanation",
    "Grid",
    "Proposal",
    "Suggestion",
    "bench_grid",
    "proposals",
    "standing_explanations",
    "suggest",
]
