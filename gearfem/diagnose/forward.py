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
theta = T - T_ambient at a few parameter values of each candidate (the nodes of
:meth:`~gearfem.diagnose.candidates.Candidate.nodes`) and interpolates them by a polynomial through
the nodes in the prior's coordinate. Approximations (checked against the full model by
:func:`confirm` and in the tests):

* combinations of candidates compose multiplicatively in theta (exact for a linear problem in
  which one candidate scales the sources and the other the conductances; not exact with
  radiation, k(T), H(T) and mu(T)), additive candidates (ambient offset) add;
* the rise theta is taken as independent of the ambient temperature of a run (tabulated at the
  case's ambient, shifted to each measurement's ambient: radiation and k(T) make this approximate
  by a few tenths of a kelvin for a few kelvin of ambient difference).
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

from gearfem import pipeline
from gearfem.config import Case, case_to_dict
from gearfem.core.errors import ParameterError
from gearfem.core.provenance import source_hash
from gearfem.diagnose.candidates import LIBRARY, AmbientOffset, Candidate, apply_all, by_name
from gearfem.diagnose.data import FIELD_QUANTITIES, Dataset
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
        self._tmp = None
        if work_dir is None:
            name = tempfile.mkdtemp(prefix="gearfem-diagnose-") if self.comm.rank == 0 else None
            work_dir = self.comm.bcast(name, root=0)
        self.work_dir = Path(work_dir)
        self._cycles: dict[float, object] = {}
        self.solves = 0

    def cycle(self, torque_Nm: float):
        if torque_Nm not in self._cycles:
            cyc, _, _ = pipeline.cycle(self.case.with_operating(torque_Nm=torque_Nm), self.comm)
            self._cycles[torque_Nm] = cyc
        return self._cycles[torque_Nm]

    def point_case(
        self, speed_rpm: float, torque_Nm: float, ambient_C: float, model: dict[str, float]
    ) -> Case:
        """The case of one run: operating point, ambient, candidates applied, transient to the last
        sample time (or steady when only end values are wanted)."""
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
        case = dataclasses.replace(case, thermal=th)
        return apply_all(case, model, self.library)

    def evaluate(
        self,
        speed_rpm: float,
        torque_Nm: float,
        ambient_C: float,
        model: dict[str, float] | None = None,
        transform=None,
    ) -> dict[Request, float]:
        """Temperatures (C) of every quantity at every sample time and at the end (steady state).

        ``transform(case) -> case`` changes the thermal run only (input-uncertainty studies); the
        structural cycle stays that of the unchanged case."""
        return self.evaluate_state(speed_rpm, torque_Nm, ambient_C, model, transform).temperatures_C

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
        (:class:`ForwardState`)."""

        case = self.point_case(speed_rpm, torque_Nm, ambient_C, model or {})
        if transform is not None:
            case = transform(case)
        case = dataclasses.replace(case, instruments=self._instruments(case))
        out = self.work_dir / f"run{self.solves}"
        cyc = self.cycle(torque_Nm)
        summ, _, snapshot = pipeline.observed_thermal(
            case, out, self.comm, cyc, write_fields=False, steady=True, write_plot=False
        )
        self.solves += 1
        res: dict[Request, float] = {}
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

            def read() -> dict[Request, float]:
                times = (None, *self.times_s)
                fields = [q for q in self.quantities if q not in TORQUE_QUANTITIES]
                labels = (
                    tuple(dict.fromkeys(snapshot.label_of(t) for t in times))
                    if fields
                    else snapshot.labels
                )
                got = evaluate(case.instruments, snapshot, labels=labels)
                return {
                    (q, t): got.value(q, snapshot.label_of(t) if q in fields else labels[0])
                    for q in self.quantities
                    for t in times
                }

            res.update(pipeline.on_root(self.comm, read))
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
        )

    def _instruments(self, case: Case):
        """The case's instruments reduced to those the wanted quantities need (no camera, no
        second gear when no ``camera_max`` is wanted)."""
        ins = case.instruments
        probes = {n: p for n, p in ins.probes.items() if f"probe:{n}" in self.quantities}
        return dataclasses.replace(
            ins,
            camera=dataclasses.replace(ins.camera, enabled="camera_max" in self.quantities),
            probes=probes,
        )

    def predict(
        self, data: Dataset, model: dict[str, float] | None = None, transform=None
    ) -> np.ndarray:
        """Predicted value (C) of every measurement of ``data``."""
        cache: dict[tuple, dict[Request, float]] = {}
        out = []
        for m in data.measurements:
            if m.point not in cache:
                cache[m.point] = self.evaluate(*m.point, model, transform)
            out.append(cache[m.point][(m.quantity, m.time_s)])
        return np.array(out)


@dataclasses.dataclass
class _Table:
    ambient_C: float
    base: dict[Request, float]  # theta at the null model
    nodes: dict[
        str, tuple[np.ndarray, dict[Request, np.ndarray]]
    ]  # candidate -> (u nodes, theta at nodes)


class Surrogate:
    """Tabulated full-model rises with interpolation (see the module docstring).

    Built from ``full`` at the (speed, torque) pairs of ``points`` for the ``candidates``; costs
    1 + sum(nodes - 1) full-model runs per (speed, torque). ``predict`` costs microseconds.
    """

    def __init__(
        self,
        full: FullModel,
        points: tuple[tuple[float, float], ...],
        candidates: tuple[Candidate, ...] = LIBRARY,
        cache_dir: str | Path | None = None,
    ) -> None:
        self.full = full
        self.candidates = tuple(candidates)
        self.tables: dict[tuple[float, float], _Table] = {}
        self._prep: dict = {}
        amb = full.case.thermal.ambient_C
        points = tuple(dict.fromkeys((float(s), float(t)) for s, t in points))
        path = None
        if cache_dir is not None:
            path = Path(cache_dir) / "surrogates" / f"{self._key(points)}.pkl"
            if path.is_file():
                self.tables = pickle.loads(path.read_bytes())
                return
        for sp, tq in points:
            base = full.evaluate(sp, tq, amb, {})
            theta0 = {k: v - amb for k, v in base.items()}
            nodes = {}
            axes = [c for c in self.candidates if c.name != _AMBIENT.name] + [_AMBIENT]
            for c in axes:
                p = c.parameter
                vals = c.nodes()
                thetas = {k: [] for k in theta0}
                for v in vals:
                    r = (
                        theta0
                        if v == p.null
                        else {
                            k: t - amb for k, t in full.evaluate(sp, tq, amb, {c.name: v}).items()
                        }
                    )
                    for k in thetas:
                        thetas[k].append(r[k])
                nodes[c.name] = (
                    np.array([p.to_unit(v) for v in vals]),
                    {k: np.array(t) for k, t in thetas.items()},
                )
            self.tables[(sp, tq)] = _Table(amb, theta0, nodes)
        if path is not None and full.comm.rank == 0:  # atomic: a failed build leaves no table
            path.parent.mkdir(parents=True, exist_ok=True)
            tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
            tmp.write_bytes(pickle.dumps(self.tables))
            os.replace(tmp, path)

    def _key(self, points) -> str:
        """Hash of everything the tables depend on: case (instruments included), points, times,
        instrument quantities, candidates' nodes, and the source of every gearfem module a table
        value is computed by (this module and what it imports, transitively: pipeline,
        instruments, thermal, coupling, cycle, contact, geometry, core)."""
        h = hashlib.sha256()
        h.update(source_hash("gearfem.diagnose.forward", "gearfem.diagnose.candidates").encode())
        meta = {
            "case": case_to_dict(self.full.case),
            "points": points,
            "times": self.full.times_s,
            "quantities": self.full.quantities,
            "candidates": [(c.name, c.nodes()) for c in self.candidates],
            "ambient": _AMBIENT.nodes(),
        }
        h.update(json.dumps(meta, sort_keys=True, default=str).encode())
        return h.hexdigest()[:16]

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(c.name for c in self.candidates)

    def _prepared(self, data: Dataset):
        key = tuple(
            (m.speed_rpm, m.torque_Nm, m.quantity, m.time_s, m.ambient_C) for m in data.measurements
        )
        got = self._prep.get(key)
        if got is None:
            rows = [
                (self.tables[(float(m.speed_rpm), float(m.torque_Nm))], (m.quantity, m.time_s))
                for m in data.measurements
            ]
            base = np.array([t.base[r] for t, r in rows])
            nodes = {
                name: (rows[0][0].nodes[name][0], np.array([t.nodes[name][1][r] for t, r in rows]))
                for name in rows[0][0].nodes
            }
            amb = np.array([m.ambient_C for m in data.measurements])
            got = (base, nodes, amb, rows[0][0].ambient_C)
            self._prep[key] = got
        return got

    def predict(self, data: Dataset, model: dict[str, float] | None = None) -> np.ndarray:
        """Predicted temperatures (C) of every measurement of ``data`` with the candidates of
        ``model``.

        theta = theta_0 prod_c theta_c(p_c)/theta_0; an additive candidate (and the difference
        between a measurement's ambient and the case's) enters through the tabulated response to
        the ambient: a shift plus its (small) ratio.
        """
        model = model or {}
        base, nodes, amb, amb_case = self._prepared(data)
        safe = np.where(base != 0.0, base, 1.0)
        theta = base.copy()
        shift = amb - amb_case
        for name, value in model.items():
            c = by_name(name, self.candidates)
            if c.additive:
                shift = shift + value
                continue
            u, vals = nodes[name]
            theta = theta * (_lagrange_weights(u, c.parameter.to_unit(value)) @ vals.T) / safe
        u, vals = nodes[_AMBIENT.name]
        y = (
            _lagrange_weights_many(u, np.array([_AMBIENT.parameter.to_unit(s) for s in shift]))
            * vals
        )
        theta = theta * (y.sum(axis=1) - shift) / safe
        return amb_case + shift + theta


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


def _lagrange_weights(x: np.ndarray, t: float) -> np.ndarray:
    """Weights w_i(t) of the polynomial through the nodes x (value = w @ y)."""
    w = np.ones(len(x))
    for i in range(len(x)):
        for j in range(len(x)):
            if j != i:
                w[i] *= (t - x[j]) / (x[i] - x[j])
    return w


def _lagrange_weights_many(x: np.ndarray, t: np.ndarray) -> np.ndarray:
    return np.array([_lagrange_weights(x, float(ti)) for ti in t])


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
