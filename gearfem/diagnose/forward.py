"""Forward models of the diagnosis: the real gearfem thermal model and a cheap surrogate of it.

:class:`FullModel` runs, for an operating point and a set of candidate extensions, the gearfem
thermal model of one gear with heat sources from the cached structural cycle of the torque
(:func:`gearfem.pipeline.cycle`, one cycle solve per torque, speed-independent) and returns the
requested temperatures: end values from the steady state, time samples from a transient run from
ambient. When the data name instrument quantities (``camera_max``, ``probe:NAME``,
``torque_loss_Nm``, ``efficiency``) it also runs the thermal models the instruments read (both
gears for the camera) and returns the instruments' readings of them
(:func:`gearfem.instruments.evaluate.evaluate`): like is compared with like.

:class:`Surrogate` is for screening: per (speed, torque) it tabulates the full model's rises
theta = T - T_ambient at nodes of each candidate's prior, starting at
:meth:`~gearfem.diagnose.candidates.Candidate.nodes` and bisected where the response curves (a
leave-one-out test), and interpolates them by a monotone piecewise cubic (PCHIP) in the prior's
coordinate; the remaining leave-one-out error is its error estimate, which the fits carry
(:meth:`Surrogate.error`). Approximations (checked against the full model by :func:`confirm`, by
the full-model refinement of the diagnosis and in the tests):

* combinations of candidates compose multiplicatively in theta (exact for a linear problem in
  which one candidate scales the sources and the other the conductances; not exact with
  radiation, k(T), H(T) and mu(T)), additive candidates (ambient offset) add; this composition
  error is not in the error estimate;
* the rise theta is taken as independent of the ambient temperature of a run (tabulated at the
  case's ambient, shifted to each measurement's ambient through the tabulated ambient axis).

Quantities that are not temperatures (torque loss, efficiency) are tabulated as values, not rises.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import logging
import os
import pickle
import shutil
import tempfile
from pathlib import Path

import numpy as np
from mpi4py import MPI
from scipy import interpolate

from gearfem import pipeline
from gearfem.config import Case, case_to_dict
from gearfem.core.errors import ConvergenceError, ParameterError
from gearfem.core.params import require_positive
from gearfem.core.provenance import code_hash
from gearfem.diagnose.candidates import LIBRARY, AmbientOffset, Candidate, apply_all, by_name
from gearfem.diagnose.data import FIELD_QUANTITIES, Dataset, unit_of
from gearfem.instruments.evaluate import TORQUE_QUANTITIES, evaluate

log = logging.getLogger(__name__)

Request = tuple[str, float | None]  # (quantity, time_s or None = end value)


@dataclasses.dataclass(frozen=True)
class ForwardState:
    """What one forward run gives: the temperatures (C) of every request, the friction heat into the
    modelled gear (W per gear, at the end value: the steady state), and, when the friction law's
    heat may rise with temperature, the number of distinct steady states found, the start whose
    state the transient from ambient reached ("transient", or the start it equals) and every start's
    state (:class:`gearfem.thermal.branches.SteadyState` as JSON)."""

    temperatures_C: dict[Request, float]
    friction_per_gear_W: float
    steady_states: int | None = None
    transient_branch: str | None = None
    branches: tuple[dict, ...] = ()
    # per camera_max request: the standard deviation of the reading over the sub-pixel aims (K)
    aim_std_K: dict[Request, float] = dataclasses.field(default_factory=dict)
    # the pinion's share of the friction heat where the case splits it by contact temperature
    # ([sources] heat_partition = "contact_temperature"; None otherwise)
    heat_fraction_pinion: float | None = None


#: Length of the transient from ambient (s) of the case files the diagnosis writes for its winner
#: (:func:`gearfem.diagnose.report.winner_cases`): twice the bench's 15 min run (thesis 6.1.1),
#: after which ``gearfem run`` solves the steady state from its end. The diagnosis itself finds
#: that steady state without the transient (the lowest steady state,
#: :func:`gearfem.thermal.branches.lowest_steady_state`); the two agree because a transient from
#: ambient ends on the lowest steady state above it.
BRANCH_TRANSIENT_S = 1800.0


class FullModel:
    """The real gearfem forward model (collective over ``comm``).

    Args:
        case: The case (mesh, material, contact, cycle, sources, thermal options); its operating
            point and ambient are replaced by each run's.
        comm: Communicator of the thermal and cycle runs.
        times_s: Sample times of the transient runs (s); the runs last until the largest.
        work_dir: Scratch directory for the thermal outputs (default: a temporary one).
        library: The candidates that model names refer to.
        quantities: The instrument quantities wanted besides the field temperatures
            (``camera_max``, ``probe:NAME``, ``torque_loss_Nm``, ``efficiency``); each must be
            read by an instrument of the case.
    """

    def __init__(
        self,
        case: Case,
        comm: MPI.Comm | None = None,
        times_s: tuple[float, ...] = (),
        work_dir: str | Path | None = None,
        library: tuple[Candidate, ...] = LIBRARY,
        quantities: tuple[str, ...] = (),
    ) -> None:
        self.case = case
        self.comm = comm or MPI.COMM_WORLD
        self.times_s = tuple(sorted(set(float(t) for t in times_s)))
        self.library = library
        self.quantities = tuple(dict.fromkeys(q for q in quantities if q not in FIELD_QUANTITIES))
        check_instrument_quantities(case, self.quantities)
        if case.cycle.modulus != "constant":
            # each run takes the case's stored cycle of its torque; the cycle <-> heat fixed
            # point in the modulus is gearfem run's (pipeline.thermal_stages)
            raise ParameterError(
                "cycle.modulus",
                case.cycle.modulus,
                '"constant" in a diagnosis (its runs share one cycle per torque)',
                "set youngs_modulus_Pa to the modulus at the running temperature instead",
            )
        self._tmp = None
        if work_dir is None:
            name = tempfile.mkdtemp(prefix="gearfem-diagnose-") if self.comm.rank == 0 else None
            work_dir = self.comm.bcast(name, root=0)
        self.work_dir = Path(work_dir)
        self._cycles: dict[float, object] = {}
        self.solves = 0

    @property
    def ambient_C(self) -> float:
        """The case's ambient (C): the surrogate tabulates rises above it."""
        return float(self.case.thermal.ambient_C)

    def surrogate_meta(self) -> dict:
        """What the model's values depend on besides the code (the surrogate's cache key)."""
        return {
            "case": case_to_dict(self.case),
            "times": self.times_s,
            "quantities": self.quantities,
        }

    def on(self, comm: MPI.Comm) -> FullModel:
        """The same model on another communicator (its own scratch directory)."""
        return FullModel(
            self.case, comm, self.times_s, None, library=self.library, quantities=self.quantities
        )

    def cycle(self, torque_Nm: float, case: Case | None = None):
        """The structural cycle of the case at ``torque_Nm`` (with the geometry of ``case``: an
        input study may change the tip rounds; what changes only the thermal run, such as a
        conductivity, keeps the case's cycle), computed or read from the cache once per
        process."""
        c = self.case if case is None else dataclasses.replace(self.case, geometry=case.geometry)
        c = c.with_operating(torque_Nm=torque_Nm)
        key = pipeline.case_cycle_key(c)
        if key not in self._cycles:
            cyc, _, _ = pipeline.cycle(c, self.comm)
            self._cycles[key] = cyc
        return self._cycles[key]

    def point_case(
        self, speed_rpm: float, torque_Nm: float, ambient_C: float, model: dict[str, float]
    ) -> Case:
        """The case of one run: operating point, ambient, candidates applied, transient to the last
        sample time (or steady when only end values are wanted; with a friction law whose heat may
        rise with temperature, the steady state a run from ambient reaches)."""
        case = self.case.with_operating(speed_rpm=speed_rpm, torque_Nm=torque_Nm)
        th = case.thermal
        if self.times_s:
            th = dataclasses.replace(
                th,
                mode="transient",
                duration_s=self.times_s[-1],
                output_times_s=self.times_s,
                ambient_C=ambient_C,
                initial_C=None,
                dt_initial_s=min(th.dt_initial_s, self.times_s[0]),
            )
        else:
            th = dataclasses.replace(
                th, mode="steady", output_times_s=(), ambient_C=ambient_C, initial_C=None
            )
        # with a friction law whose heat may rise with temperature, a steady end value is the
        # state a run from ambient reaches: the lowest steady state, found by continuation in the
        # heat (gearfem.thermal.branches.lowest_steady_state), not whichever one Newton finds
        case = apply_all(dataclasses.replace(case, thermal=th), model, self.library)
        return case

    def evaluate(
        self,
        speed_rpm: float,
        torque_Nm: float,
        ambient_C: float,
        model: dict[str, float] | None = None,
        transform=None,
    ) -> dict[Request, float]:
        """Temperatures (C) of every quantity at every sample time and at the end (steady state).

        ``transform(case) -> case`` changes the run (input-uncertainty studies); a change of what
        the structural cycle depends on (the geometry: the tip-round radius) solves the cycle of
        the changed case."""
        return self._evaluate(
            speed_rpm, torque_Nm, ambient_C, model, transform, branch_search=False
        ).temperatures_C

    def evaluate_state(
        self,
        speed_rpm: float,
        torque_Nm: float,
        ambient_C: float,
        model: dict[str, float] | None = None,
        transform=None,
    ) -> ForwardState:
        """As :meth:`evaluate`, with the friction heat and, where the friction law's heat may rise
        with temperature, the steady states found and the one the transient from ambient picked
        (:class:`ForwardState`). The temperatures are those of :meth:`evaluate`, which skips the
        search for the other steady states."""
        return self._evaluate(speed_rpm, torque_Nm, ambient_C, model, transform, branch_search=True)

    def _evaluate(
        self, speed_rpm, torque_Nm, ambient_C, model, transform, branch_search: bool
    ) -> ForwardState:
        case = self.point_case(speed_rpm, torque_Nm, ambient_C, model or {})
        if transform is not None:
            case = transform(case)
        case = dataclasses.replace(case, instruments=self._instruments(case))
        out = self.work_dir / f"run{self.solves}"
        cyc = self.cycle(torque_Nm, case)
        try:
            summ, _, snapshot = pipeline.observed_thermal(
                case,
                out,
                self.comm,
                cyc,
                write_fields=False,
                steady=True,
                write_plot=False,
                branch_search=branch_search,
            )
        except ConvergenceError as e:  # say which run of the diagnosis failed
            where = (
                f"{e.step}; diagnosis run at {speed_rpm:g} rpm / {torque_Nm:g} N m, ambient "
                f"{ambient_C:g} C, model {model or 'baseline'}"
            )
            raise ConvergenceError(e.solver, e.reason, where, e.iteration, e.residual) from e
        self.solves += 1
        res: dict[Request, float] = {}
        aim_std: dict[Request, float] = {}
        end = (
            summ["steady_state_C"]
            if case.thermal.mode == "transient"
            else summ["final_temperatures_C"]
        )
        for q in FIELD_QUANTITIES:
            res[(q, None)] = float(end[q])
        for t in self.times_s:
            rec = summ.get("at_times_C", {}).get(f"{t:g}")
            if rec is None and abs(t - case.thermal.duration_s) <= 1e-6 * t:
                rec = summ["final_temperatures_C"]
            for q in FIELD_QUANTITIES:
                res[(q, t)] = float(rec[q])
        if self.quantities:

            def read() -> tuple[dict[Request, float], dict[Request, float]]:
                times = (None, *self.times_s)
                labels = tuple(dict.fromkeys(snapshot.label_of(t) for t in times))
                got = evaluate(
                    case.instruments,
                    snapshot,
                    labels=labels,
                    views_dir=pipeline.camera_views_dir(),
                )
                values = {
                    (q, t): got.value(q, snapshot.label_of(t))
                    for q in self.quantities
                    for t in times
                }
                aims = {
                    ("camera_max", t): got.camera[snapshot.label_of(t)].aim_std_C
                    for t in times
                    if "camera_max" in self.quantities
                }
                return values, aims

            values, aim_std = pipeline.on_root(self.comm, read)
            res.update(values)
        if self.comm.rank == 0:  # only the numbers are kept
            shutil.rmtree(out, ignore_errors=True)
        self.comm.barrier()
        fr = summ.get("friction", {})
        frac = summ.get("model_fraction") or 1.0
        balance = summ.get("steady_balance_W") or summ["final_balance_W"]
        return ForwardState(
            temperatures_C=res,
            friction_per_gear_W=float(balance["friction_W"]) / frac,
            steady_states=fr.get("distinct_steady_states"),
            transient_branch=fr.get("transient_branch"),
            branches=tuple(fr.get("branches", ())),
            aim_std_K=aim_std,
            heat_fraction_pinion=(
                pipeline.HeatSplit.from_json(summ["heat_split"]).fraction_pinion
                if "heat_split" in summ
                else None
            ),
        )

    def _instruments(self, case: Case):
        """The case's instruments reduced to those the wanted quantities need (no camera, no
        second gear when neither ``camera_max`` nor a torque reading is wanted)."""
        ins = case.instruments
        probes = {n: p for n, p in ins.probes.items() if f"probe:{n}" in self.quantities}
        torque = any(q in TORQUE_QUANTITIES for q in self.quantities)
        return dataclasses.replace(
            ins,
            camera=dataclasses.replace(ins.camera, enabled="camera_max" in self.quantities),
            probes=probes,
            torque=dataclasses.replace(ins.torque, enabled=torque and ins.torque.enabled),
        )

    def predict(
        self, data: Dataset, model: dict[str, float] | None = None, transform=None
    ) -> np.ndarray:
        """Predicted value (C) of every measurement of ``data``."""
        return self.predict_with_aim(data, model, transform)[0]

    def predict_with_aim(
        self, data: Dataset, model: dict[str, float] | None = None, transform=None
    ) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`predict`, and the standard deviation (K) of each camera_max prediction over the
        camera's sub-pixel aims (0 for the other quantities): the input uncertainty the bench
        camera's unknown aim gives it."""
        cache: dict[tuple, ForwardState] = {}
        out, aim = [], []
        for m in data.measurements:
            if m.point not in cache:
                cache[m.point] = self._evaluate(*m.point, model, transform, branch_search=False)
            state = cache[m.point]
            out.append(state.temperatures_C[(m.quantity, m.time_s)])
            aim.append(state.aim_std_K.get((m.quantity, m.time_s), 0.0))
        return np.array(out), np.array(aim)


#: The error estimate is this times the largest leave-one-out error of an axis. A leave-one-out
#: error is that of an interpolant on twice the final spacing; for a smooth response the final
#: (third-order) interpolant's error is about 1/8 of it. Measured on the lumped test model
#: (tests/diagnose_lumped.py): true error / leave-one-out error 0.08-0.33 on smooth axes; a
#: steep glass step that exhausted the node budget was under-estimated (1.4 x): 1/2 keeps a
#: margin on smooth axes and is not a bound at a kink.
ERROR_FACTOR = 0.5


@dataclasses.dataclass
class _Table:
    ambient_C: float
    base: dict[Request, float]  # theta at the null model
    nodes: dict[
        str, tuple[np.ndarray, dict[Request, np.ndarray]]
    ]  # candidate -> (u nodes, theta at nodes)
    errors: dict[str, dict[Request, float]]  # candidate -> leave-one-out error estimate


def _is_temperature(request: Request) -> bool:
    return unit_of(request[0]) == "C"


def _loo_errors(u: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Leave-one-out errors of the monotone (PCHIP) interpolant at the interior nodes: for each
    interior node i, |interpolant of the other nodes at u_i - y_i| (len(u) - 2 values, per column
    of ``y``, shape (nodes, ...))."""
    out = []
    for i in range(1, len(u) - 1):
        keep = np.arange(len(u)) != i
        out.append(np.abs(_interp(u[keep], y[keep])(u[i]) - y[i]))
    return np.array(out)


def _interp(u: np.ndarray, y: np.ndarray):
    """Monotone piecewise-cubic (PCHIP) interpolant through the nodes (linear with two)."""
    if len(u) == 2:
        return lambda t: y[0] + (np.asarray(t)[..., None] - u[0]) * (y[1] - y[0]) / (u[1] - u[0])
    return interpolate.PchipInterpolator(u, y, axis=0, extrapolate=True)


class Surrogate:
    """Tabulated full-model rises with interpolation and an error estimate (module docstring).

    Built from ``full`` at the (speed, torque) pairs of ``points`` for the ``candidates``. Per
    candidate and point the nodes start at :meth:`Candidate.nodes` and are refined adaptively: an
    interval next to an interior node whose leave-one-out error (the monotone interpolant of the
    other nodes, evaluated at that node) exceeds ``tol_K`` on any tabulated temperature (or 1 % of
    the largest value of another quantity) is bisected, until no such node is left or the axis has
    ``max_nodes`` nodes. The largest remaining leave-one-out error is kept per candidate and
    measurement, times :data:`ERROR_FACTOR`, as the surrogate's error estimate (:meth:`error`).

    ``full`` is any forward model with ``evaluate(speed_rpm, torque_Nm, ambient_C, model)`` ->
    {(quantity, time_s): value}, ``ambient_C``, ``comm`` and ``surrogate_meta()`` (what its
    values depend on, for the cache key); :class:`FullModel` is one. ``predict`` costs
    microseconds per operating point. Under MPI (``full.comm`` of more than one rank and a
    model with ``on(comm)``), the points are shared out over the ranks, each tabulating its own
    on ``MPI.COMM_SELF``, and the tables gathered on every rank.
    """

    def __init__(
        self,
        full,
        points: tuple[tuple[float, float], ...],
        candidates: tuple[Candidate, ...] = LIBRARY,
        cache_dir: str | Path | None = None,
        tol_K: float = 0.25,
        max_nodes: int = 9,
    ) -> None:
        require_positive("surrogate.tol_K", tol_K)
        if max_nodes < 3:
            raise ParameterError("surrogate.max_nodes", max_nodes, ">= 3")
        self.full = full
        self.candidates = tuple(candidates)
        self.tol_K = float(tol_K)
        self.max_nodes = int(max_nodes)
        self.tables: dict[tuple[float, float], _Table] = {}
        self.solves = 0
        self._prep: dict = {}
        points = tuple(dict.fromkeys((float(s), float(t)) for s, t in points))
        path = None
        if cache_dir is not None:
            path = Path(cache_dir) / "surrogates" / f"{self._key(points)}.pkl"
            if path.is_file():
                self.tables = pickle.loads(path.read_bytes())
                return
        comm = getattr(full, "comm", MPI.COMM_SELF)
        if comm.size > 1 and hasattr(full, "on"):
            # the points are independent: each rank tabulates its share on its own (COMM_SELF),
            # the structural cycles first computed (or read) together and cached
            for tq in dict.fromkeys(t for _, t in points):
                full.cycle(tq)
            local = full.on(MPI.COMM_SELF)
            mine = {pt: self._tabulate(*pt, local) for pt in points[comm.rank :: comm.size]}
            parts = comm.allgather((mine, self.solves))
            got = {pt: t for part, _ in parts for pt, t in part.items()}
            self.tables = {pt: got[pt] for pt in points}
            self.solves = sum(n for _, n in parts)
        else:
            for sp, tq in points:
                self.tables[(sp, tq)] = self._tabulate(sp, tq)
        if path is not None and comm.rank == 0:
            # atomic: a failed build leaves no table
            path.parent.mkdir(parents=True, exist_ok=True)
            tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
            tmp.write_bytes(pickle.dumps(self.tables))
            os.replace(tmp, path)

    def _tabulate(self, sp: float, tq: float, forward=None) -> _Table:
        full = forward or self.full
        amb = float(full.ambient_C)

        def theta(model):
            self.solves += 1
            res = full.evaluate(sp, tq, amb, model)
            return {k: v - (amb if _is_temperature(k) else 0.0) for k, v in res.items()}

        theta0 = theta({})
        keys = list(theta0)
        temp = np.array([_is_temperature(k) for k in keys])
        nodes, errors = {}, {}
        axes = [c for c in self.candidates if c.name != _AMBIENT.name] + [_AMBIENT]
        for c in axes:
            p = c.parameter
            got = {p.to_unit(v): (theta0 if v == p.null else theta({c.name: v})) for v in c.nodes()}
            while True:
                u = np.array(sorted(got))
                y = np.array([[got[x][k] for k in keys] for x in u])
                loo = _loo_errors(u, y)
                scale = np.where(temp, self.tol_K, 0.01 * np.max(np.abs(y), axis=0) + 1e-300)
                bad = [i + 1 for i in range(len(loo)) if np.any(loo[i] > scale)]
                new = sorted({0.5 * (u[j] + u[j + 1]) for i in bad for j in (i - 1, i)} - set(got))
                if not new or len(u) >= self.max_nodes:
                    break
                for x in new[: self.max_nodes - len(u)]:
                    got[x] = theta({c.name: p.from_unit(float(x))})
            nodes[c.name] = (u, {k: y[:, j] for j, k in enumerate(keys)})
            worst = ERROR_FACTOR * loo.max(axis=0) if len(loo) else np.zeros(len(keys))
            errors[c.name] = {k: float(worst[j]) for j, k in enumerate(keys)}
        return _Table(amb, theta0, nodes, errors)

    def _key(self, points) -> str:
        """Hash of everything the tables depend on: the forward model's own description (for
        :class:`FullModel`: case with instruments, times, instrument quantities), points,
        candidates' starting nodes, tolerance and node budget, and the source of every gearfem
        module a table value is computed by (this module and what it imports, transitively:
        pipeline, instruments, thermal, coupling, cycle, contact, geometry, core)."""
        h = hashlib.sha256()
        h.update(code_hash("gearfem.diagnose.forward", "gearfem.diagnose.candidates").encode())
        meta = {
            "model": self.full.surrogate_meta(),
            "points": points,
            "candidates": [(c.name, c.nodes()) for c in self.candidates],
            "ambient": _AMBIENT.nodes(),
            "tol_K": self.tol_K,
            "max_nodes": self.max_nodes,
        }
        h.update(json.dumps(meta, sort_keys=True, default=str).encode())
        return h.hexdigest()[:16]

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(c.name for c in self.candidates)

    def nodes_of(self, name: str) -> dict[tuple[float, float], int]:
        """Number of nodes of a candidate's axis per (speed, torque)."""
        return {pt: len(t.nodes[name][0]) for pt, t in self.tables.items()}

    def _prepared(self, data: Dataset):
        key = tuple(
            (m.speed_rpm, m.torque_Nm, m.quantity, m.time_s, m.ambient_C) for m in data.measurements
        )
        got = self._prep.get(key)
        if got is None:
            groups: dict[tuple, list[int]] = {}
            for i, m in enumerate(data.measurements):
                groups.setdefault(m.point, []).append(i)
            got = []
            for (sp, tq, amb), idx in groups.items():
                table = self.tables[(float(sp), float(tq))]
                reqs = [(data.measurements[i].quantity, data.measurements[i].time_s) for i in idx]
                base = np.array([table.base[r] for r in reqs])
                interps = {
                    name: _interp(u, np.array([vals[r] for r in reqs]).T)
                    for name, (u, vals) in table.nodes.items()
                }
                errs = {name: np.array([e[r] for r in reqs]) for name, e in table.errors.items()}
                temp = np.array([_is_temperature(r) for r in reqs])
                got.append((np.array(idx), base, interps, errs, temp, amb, table.ambient_C))
            self._prep[key] = got
        return got

    def predict(self, data: Dataset, model: dict[str, float] | None = None) -> np.ndarray:
        """Predicted values (C for temperatures) of every measurement of ``data`` with the
        candidates of ``model``.

        theta = theta_0 prod_c theta_c(p_c)/theta_0; an additive candidate (and the difference
        between a measurement's ambient and the case's) enters through the tabulated response to
        the ambient: a shift plus its (small) ratio.
        """
        model = model or {}
        out = np.empty(len(data))
        for idx, base, interps, _, temp, amb, amb_case in self._prepared(data):
            safe = np.where(base != 0.0, base, 1.0)
            theta = base.copy()
            shift = amb - amb_case
            for name, value in model.items():
                c = by_name(name, self.candidates)
                if c.additive:
                    shift += value
                    continue
                theta = theta * interps[name](c.parameter.to_unit(value)) / safe
            y = interps[_AMBIENT.name](_AMBIENT.parameter.to_unit(shift))
            theta = theta * (y - np.where(temp, shift, 0.0)) / safe
            out[idx] = np.where(temp, amb_case + shift, 0.0) + theta
        return out

    def error(self, data: Dataset, names: tuple[str, ...] | list[str] = ()) -> np.ndarray:
        """Estimated error of :meth:`predict` for a model of the candidates ``names`` (same unit as
        the values): the leave-one-out errors of their axes and of the ambient axis, in
        quadrature, at each measurement. Parameter-independent (the largest over the prior), so
        that a fit is not drawn to where the table is poor."""
        out = np.zeros(len(data))
        for idx, _, _, errs, _, _, _ in self._prepared(data):
            e2 = errs[_AMBIENT.name] ** 2
            for name in names:
                if not by_name(name, self.candidates).additive:
                    e2 = e2 + errs[name] ** 2
            out[idx] = np.sqrt(e2)
        return out


_AMBIENT = AmbientOffset()


def check_instrument_quantities(case: Case, quantities) -> None:
    """Each instrument quantity must be read by an instrument of the case (a ParameterError
    names the quantity and what the case offers)."""
    offered = case.instruments.quantities
    for q in quantities:
        if q in FIELD_QUANTITIES:
            continue
        if q not in offered:
            raise ParameterError(
                "data.quantity",
                q,
                "a quantity of the case's instruments: " + ", ".join((*offered, *FIELD_QUANTITIES)),
                "configure it in [instruments] (camera enabled, [instruments.probes.NAME], "
                "torque meters)",
            )


def confirm(full: FullModel, surrogate: Surrogate, data: Dataset, model: dict[str, float]) -> dict:
    """Full-model check of a surrogate prediction: both predictions and their largest difference
    (K)."""
    s = surrogate.predict(data, model)
    f = full.predict(data, model)
    return {
        "surrogate_C": s.tolist(),
        "full_C": f.tolist(),
        "max_abs_difference_K": float(np.max(np.abs(f - s))),
        "model": dict(model),
    }


__all__ = [
    "ForwardState",
    "FullModel",
    "Request",
    "Surrogate",
    "check_instrument_quantities",
    "confirm",
]
