"""The diagnosis of one data set: V&V 20 comparison, fit and selection, full-model confirmation,
and its outputs (``diagnosis.json`` written last and atomically, ``report.md``, plots)."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

import numpy as np
from mpi4py import MPI

from gearfem.config import Case, write_case
from gearfem.core.doctables import markdown_table
from gearfem.core.io import prepare_output, write_json
from gearfem.core.material_library import library_material
from gearfem.core.results import JsonRecord
from gearfem.cycle.cache import cache_root
from gearfem.diagnose.candidates import LIBRARY, apply_all, by_name
from gearfem.diagnose.data import FIELD_QUANTITIES, Dataset, Measurement, unit_of
from gearfem.diagnose.design import (
    STANDING_DELTA,
    Grid,
    Suggestion,
    bench_grid,
    reading_uncertainty,
    standing_explanations,
    suggest,
)
from gearfem.diagnose.forward import BRANCH_TRANSIENT_S, FullModel, Surrogate
from gearfem.diagnose.margins import FoldMargin, fold_margins
from gearfem.diagnose.margins import markdown as margins_markdown
from gearfem.diagnose.select import Diagnosis, diagnose, refine
from gearfem.diagnose.vv20 import TABLE_HEAD, Comparison, ComparisonTable, input_uncertainty
from gearfem.geometry.involute import GearPair
from gearfem.instruments.options import ProbeOptions
from gearfem.uncertainty import DIAGNOSIS_CODE, provenance, run_uncertainty


def _replace_thermal(**kw):
    return lambda c: dataclasses.replace(c, thermal=dataclasses.replace(c.thermal, **kw))


def _replace_camera(**kw):
    def change(c: Case) -> Case:
        ins = c.instruments
        cam = dataclasses.replace(ins.camera, **kw)
        return dataclasses.replace(c, instruments=dataclasses.replace(ins, camera=cam))

    return change


def _replace_geometry(**kw):
    return lambda c: dataclasses.replace(c, geometry=dataclasses.replace(c.geometry, **kw))


def _replace_material(body: str | None = None, **kw):
    """A change of the material: the case's one material (``body`` None; both gears), or that of
    ``body`` alone in a pair of two materials."""

    def change(c: Case) -> Case:
        if body is None:
            return dataclasses.replace(
                c, material=dataclasses.replace(c.material, **kw), material_wheel=None
            )
        mats = dict(c.materials)
        mats[body] = dataclasses.replace(mats[body], **kw)
        return dataclasses.replace(c, material=mats["pinion"], material_wheel=mats["wheel"])

    return change


def uniform_step(value: float, lo: float, hi: float, upper: float | None = None):
    """(delta, scale) of a one-sided finite difference for an input uniform on [lo, hi] (given
    about ``value``): the step is the interval's wider side (upwards on a tie, downwards when that
    would pass ``upper``), the scale u_x / |delta| with u_x = (hi - lo) / sqrt(12). A symmetric
    ``value -+ d`` steps by d, scale 1/sqrt(3); a range with ``value`` at one end steps across it,
    scale 1/sqrt(12)."""
    below, above = value - lo, hi - value
    delta = above if above >= below else -below
    if upper is not None and value + delta > upper:
        delta = -below
    return delta, (hi - lo) / math.sqrt(12.0) / abs(delta)


def material_perturbations(case: Case) -> dict[str, tuple[Any, float]]:
    """The material inputs of the V&V 20 input uncertainty: thermal conductivity, heat capacity
    and emissivity, each uniform over its interval in the materials library
    (gearfem/data/materials, the case material's ``name``), shifted to the case's value where the
    case overrides the library's. The emissivity is the thermal model's (``[thermal] emissivity``
    or the material's). A pair of two materials (``[material_wheel]``, a steel pinion against a
    POM wheel, say) has each gear's inputs apart, named by the gear; ``[thermal] emissivity``,
    which sets both gears', is one input.

    Density and specific heat act on the thermal model only through their product rho c_p (the
    enthalpy of a transient, the diffusivity of the flash temperature, the effusivity of the heat
    split), so they are one input: the product moved by c_p's library step (upwards across the
    interval's wider side), applied to the density so that a c_p(T) table moves alike, and
    scaled to the product's relative standard uncertainty sqrt((u_rho/rho)^2 + (u_cp/c_p)^2)
    with u = (hi - lo)/sqrt(12). It moves a steady state of one material with a constant
    friction coefficient and a fixed heat split by nothing; a transient's samples, a pair of two
    materials and a flash-temperature law by their sensitivity.

    Not inputs: Young's modulus (each step a structural cycle per torque, minutes each; the
    modulus of the thermal state, 19 % below 3.7 GPa, moved the camera by 1.0 K at 1000 rpm /
    8 N m, docs/materials.md, against PEEK 450G's library interval of 3.6-4.0 GPa) and the
    friction coefficient (a candidate of the diagnosis, not an input)."""
    mats = case.materials
    pair = mats["wheel"] != mats["pinion"]
    pert = {}
    for body in ("pinion", "wheel") if pair else (None,):
        mat = mats[body or "pinion"]
        lib = library_material(
            mat.name, "material.name" if body != "wheel" else "material_wheel.name"
        )
        whose = f"{body}: {lib.name}" if pair else lib.name
        k = lib["thermal_conductivity_W_mK"]
        lo, hi = k.interval()
        delta, scale = uniform_step(k.value, lo, hi)
        pert[f"thermal_conductivity_W_mK ({lo:.3g}-{hi:.3g}, uniform; {whose} library)"] = (
            _replace_material(
                body, thermal_conductivity_W_mK=mat.thermal_conductivity_W_mK + delta
            ),
            scale,
        )
        # rho and c_p enter the thermal model only as their product (the enthalpy, the diffusivity
        # of the flash temperature, the effusivity of the heat split): one step of the product,
        # taken on the density so that a c_p(T) table moves with it, carries both intervals
        rho, cp = lib["density_kg_m3"], lib["specific_heat_J_kgK"]
        (rho_lo, rho_hi), (cp_lo, cp_hi) = rho.interval(), cp.interval()
        step, _ = uniform_step(cp.value, cp_lo, cp_hi)
        rel = step / cp.value
        u_rel = math.hypot(rho_hi - rho_lo, (cp_hi - cp_lo) * rho.value / cp.value)
        u_rel /= math.sqrt(12.0) * rho.value
        pert[
            f"heat capacity rho c_p ({rho_lo:.4g}-{rho_hi:.4g} kg/m^3 x {cp_lo:.4g}-{cp_hi:.4g} "
            f"J/(kg K), uniform; {whose} library)"
        ] = (
            _replace_material(body, density_kg_m3=mat.density_kg_m3 * (1.0 + rel)),
            u_rel / abs(rel),
        )
        if pair and case.thermal.emissivity is not None and body == "wheel":
            continue  # one emissivity for both gears: perturbed once, below the pinion's
        e = lib["emissivity"]
        lo, hi = e.interval()
        value = case.thermal.emissivity or mat.emissivity
        delta, scale = uniform_step(
            value, value - (e.value - lo), value + (hi - e.value), upper=1.0
        )
        own = pair and case.thermal.emissivity is None
        pert[
            f"emissivity ({e.value:.2f} -{e.value - lo:.2g}/+{hi - e.value:.2g}, uniform; "
            f"{whose} library)"
        ] = (
            _replace_material(body, emissivity=value + delta)
            if own
            else _replace_thermal(emissivity=value + delta),
            scale,
        )
    return pert


def studied_u_num(case: Case, data: Dataset, S: np.ndarray) -> tuple[np.ndarray | None, str]:
    """u_num of every prediction from the refinement studies filed for the case's resolution
    (``gearfem converge``, :func:`gearfem.uncertainty.run_uncertainty`: the kinds combined in
    quadrature, scaled by the rise at other operating points and times), or (None, reason) when a
    measured quantity has no study."""
    u = np.zeros(len(S))
    kinds: set[str] = set()
    for i, m in enumerate(data.measurements):
        point = case.with_operating(m.speed_rpm, m.torque_Nm)
        point = dataclasses.replace(
            point, thermal=dataclasses.replace(point.thermal, ambient_C=m.ambient_C)
        )
        run = run_uncertainty(point, {m.quantity: float(S[i])})
        q = run.quantities.get(m.quantity) if run is not None else None
        if q is None:
            return None, f"no refinement study of {m.quantity!r} at the case's resolution"
        u[i] = q.u_num
        kinds |= set(q.parts)
    return u, "refinement studies of the case's resolution (" + ", ".join(sorted(kinds)) + ")"


def run_diagnosis(
    data: Dataset,
    case: Case,
    out_dir: str | Path,
    comm: MPI.Comm | None = None,
    max_size: int = 2,
    cache_dir: str | Path | None = None,
    u_model_K: float = 1.0,
    suggest_next: bool = False,
    grid: Grid | None = None,
) -> DiagnosisReport:
    """Diagnose ``data`` against ``case`` (collective); writes the outputs to ``out_dir``, returns
    the result. ``suggest_next``: also rank the next measurements (:func:`suggest_measurements`)
    on ``grid`` (default: :func:`~gearfem.diagnose.design.bench_grid` with the case's instruments
    and a web thermocouple and a side-face probe added where the case has no probes)."""

    comm = comm or MPI.COMM_WORLD
    out = prepare_output(out_dir, "diagnosis.json", comm)
    quantities = tuple(dict.fromkeys(m.quantity for m in data.measurements))
    full = FullModel(case, comm, times_s=data.times, work_dir=None, quantities=quantities)
    pts = tuple(dict.fromkeys((m.speed_rpm, m.torque_Nm) for m in data.measurements))
    sur = Surrogate(full, pts, cache_dir=cache_dir if cache_dir is not None else cache_root())
    D = np.array([m.value for m in data.measurements])
    # V&V 20 of the baseline on the full model
    S, u_aim = full.predict_with_aim(data, {})
    u_D = np.array([m.uncertainty for m in data.measurements])
    u_num, num_note = studied_u_num(case, data, S)
    if u_num is None and case.thermal.degree == 1:
        # numerical: P1 against P2 on the same mesh (conservative: the whole difference)
        S2 = full.predict(data, {}, transform=_replace_thermal(degree=2))
        u_num = np.abs(S2 - S)
        num_note = "|S(P2) - S(P1)| on the case mesh (no refinement study of its resolution)"
    elif u_num is None:
        S1 = full.predict(data, {}, transform=_replace_thermal(degree=1))
        u_num = 1.25 * np.abs(S - S1) / 3.0
        num_note = "1.25 |S(P2) - S(P1)| / (2^2 - 1) (no refinement study of its resolution)"
    pert = material_perturbations(case)
    # the tip rounds' radius is not measured: the case's ± 0.05 m (uniform; 0.1-0.3 mm for the
    # thesis's 0.2 mm, m = 2 mm); the entering pair's first contact and the hot spot at the flank
    # foot sit on it (a cycle of the changed geometry per torque)
    g = case.geometry
    r_lo, r_hi = ((g.tip_round_coefficient + d) * g.module_mm for d in (-0.05, 0.05))
    pert[f"tip round radius ({r_lo:.2g}-{r_hi:.2g} mm, uniform)"] = (
        _replace_geometry(tip_round_coefficient=g.tip_round_coefficient + 0.05),
        1.0 / math.sqrt(3.0),
    )
    if "camera_max" in quantities:
        # the camera's optics are known only roughly: blur FWHM 1 +- 0.5 px (uniform); its
        # reading of a hot spot two pixels wide moves by kelvins with it (docs/instruments.md)
        cam = case.instruments.camera
        pert["camera blur FWHM (1 +- 0.5 px, uniform)"] = (
            _replace_camera(blur_fwhm_px=cam.blur_fwhm_px + 0.5),
            1.0 / math.sqrt(3.0),
        )
    u_in, parts = input_uncertainty(lambda tr: full.predict(data, {}, transform=tr), S, pert)
    if np.any(u_aim > 0.0):
        # where the bench camera's pixel grid fell on the gears is unknown within a pixel: the
        # spread of the reading over the sub-pixel aims (CameraOptions.aim_offsets)
        parts["camera aim (uniform within a pixel)"] = u_aim
        u_in = np.sqrt(u_in**2 + u_aim**2)
    comp = Comparison(S=S, D=D, u_num=u_num, u_input=u_in, u_D=u_D)
    probes = _probes(sur, data, case.instruments.torque.uncertainty_Nm)
    result = diagnose(
        sur.predict,
        data,
        max_size=max_size,
        probes=probes,
        u_model_K=u_model_K,
        model_error=sur.error,
    )
    # confirmation of the chosen model on the full model (and removal of the surrogate's bias
    # there), interval edges checked on the full model where the surrogate's error could move them
    result = refine(
        full.predict,
        sur.predict,
        data,
        result,
        iterations=1,
        final_check=True,
        model_error=sur.error,
    )
    base_sur = sur.predict(data, {})
    margins = verdict_margins(case, data, result, comm, full)
    suggestion = None
    if suggest_next:
        suggestion = suggest_measurements(data, case, result, comm, grid, cache_dir)
    report = DiagnosisReport(
        diagnosis=result,
        data={
            "source": data.source,
            "measurements": [dataclasses.asdict(m) for m in data.measurements],
        },
        case=case.name,
        vv20=ComparisonTable(
            rows=comp.rows(
                [m.label() for m in data.measurements], [m.unit for m in data.measurements]
            ),
            k=comp.k,
            u_num_method=num_note,
            u_input_parts={k: tuple(float(x) for x in v) for k, v in parts.items()},
        ),
        surrogate={
            "full_model_solves": full.solves,
            "baseline_max_abs_difference_K": float(np.max(np.abs(base_sur - S))),
            "tol_K": sur.tol_K,
            "nodes": {c.name: max(sur.nodes_of(c.name).values()) for c in sur.candidates},
            "error_estimate_max_K": {
                c.name: float(np.max(sur.error(data, (c.name,)))) for c in sur.candidates
            },
        },
        candidates={
            c.name: {
                "parameter": c.parameter.name,
                "unit": c.parameter.unit,
                "null": c.parameter.null,
                "prior": [c.parameter.lo, c.parameter.hi],
                "doc": " ".join((c.__doc__ or "").split()),
            }
            for c in LIBRARY
        },
        suggestion=suggestion,
        fold_margins=tuple(margins),
        provenance=dataclasses.asdict(provenance(case, DIAGNOSIS_CODE)),
    )
    if comm.rank == 0:
        clear_earlier_outputs(out)
        _plots(result, data, out, suggestion)
        if suggestion is not None:
            write_json(out / "suggestion.json", suggestion)
        for name, c in winner_cases(case, data, result).items():
            write_case(c, out / name)
        (out / "report.md").write_text(markdown(report, data))
        write_json(out / "diagnosis.json", report)  # last: marks a complete diagnosis
    comm.barrier()
    return report


#: The uncertainty of the bench's ambient (K): what the fold margins in the ambient are compared
#: with (the recorded air temperature near two gears running at up to 150 C).
AMBIENT_U_K = 2.0


def clear_earlier_outputs(out: Path) -> None:
    """Remove from ``out`` what an earlier diagnosis into it wrote and a new one may not write
    again (a suggestion only with ``--suggest`` and two explanations standing, the winner's case
    files only with a winner), so that none is left to look like the new one's."""
    for old in (out / "suggestion.png", out / "suggestion.json", *out.glob("winner*.toml")):
        old.unlink(missing_ok=True)


def verdict_margins(
    case: Case, data: Dataset, result: Diagnosis, comm: MPI.Comm, full: FullModel
) -> list[FoldMargin]:
    """The fold margins of every data point for the chosen model when its friction law may have
    several steady states (:func:`gearfem.diagnose.margins.fold_margins`; empty otherwise): in
    the fitted parameters (compared with their interval), the torque (with the torque meter's
    uncertainty) and the ambient (with :data:`AMBIENT_U_K`)."""
    params = winner_params(result)
    if not params or not apply_all(case, params).friction_law().may_rise_with_temperature:
        return []
    intervals = (
        result.refined.intervals if result.refined is not None else result.chosen_fit.intervals
    )
    half = {
        n: max(abs(params[n] - iv[0]), abs(iv[1] - params[n]))
        for n, iv in intervals.items()
        if n in params
    }
    out: list[FoldMargin] = []
    for point in data.points:
        out += fold_margins(
            margin_case(case, full, point, params),
            (point,),
            params,
            comm,
            interval_half_width=half,
            torque_u_Nm=case.instruments.torque.uncertainty_Nm,
            temperature_u_K=AMBIENT_U_K,
            cycle=full.cycle,
        )
    return out


def margin_case(
    case: Case, full: FullModel, point: tuple[float, float, float], params: dict[str, float]
) -> Case:
    """The case whose gears the fold margins trace at ``point`` (speed, torque, ambient):
    ``case`` itself, or, where it splits the friction heat by contact temperature (both gears'
    runs solved together, :func:`gearfem.pipeline.split_by_contact_temperature`), ``case`` with
    the pinion's share held at the one the model ``params`` reaches there (a run of the full
    model): a margin traced on one gear with the split held is first-order, as the torque's
    and the ambient's are (near a fold the split would move with the state)."""
    src = case.sources
    if not (src.mode == "cycle" and src.friction and src.heat_partition == "contact_temperature"):
        return case
    speed, torque, ambient = point
    share = full.evaluate_state(speed, torque, ambient, params).heat_fraction_pinion
    held = dataclasses.replace(src, heat_partition="fixed", heat_fraction_pinion=share)
    return dataclasses.replace(case, sources=held)


def winner_params(result: Diagnosis) -> dict[str, float]:
    """The chosen model's parameters: refined on the full model where that was done."""
    if not result.chosen:
        return {}
    if result.refined is not None:
        return dict(result.refined.params)
    return dict(result.chosen_fit.params)


def winner_cases(case: Case, data: Dataset, result: Diagnosis) -> dict[str, Case]:
    """The chosen extension at its fitted value, as case files a user runs with ``gearfem run``:
    ``winner.toml`` (the case with the extension applied) and, per operating point of the data,
    ``winner_<speed>rpm_<torque>Nm.toml`` with that point's speed, torque and recorded ambient and
    the diagnosis's run (a transient from ambient of :data:`BRANCH_TRANSIENT_S`, then the steady
    state from its end: an end value of the data is that steady state, ``camera_max_steady_C`` in
    the run's summary, on the branch the transient reached). Empty when no extension was chosen."""
    params = winner_params(result)
    if not params:
        return {}
    label = ", ".join(f"{k} = {v:.4g}" for k, v in params.items())
    base = apply_all(case, params)
    out = {"winner.toml": dataclasses.replace(base, name=f"{case.name} + {label}")}
    for m in data.measurements:
        name = f"winner_{m.speed_rpm:g}rpm_{m.torque_Nm:g}Nm.toml"
        if name in out:
            continue
        c = base.with_operating(speed_rpm=m.speed_rpm, torque_Nm=m.torque_Nm)
        times = tuple(t for t in c.thermal.output_times_s if t < BRANCH_TRANSIENT_S)
        th = dataclasses.replace(
            c.thermal,
            mode="transient",
            ambient_C=m.ambient_C,
            duration_s=BRANCH_TRANSIENT_S,
            output_times_s=times,
        )
        out[name] = dataclasses.replace(
            c,
            name=f"{case.name} + {label}, {m.speed_rpm:g} rpm / {m.torque_Nm:g} N m",
            thermal=th,
        )
    return out


def design_case(case: Case) -> Case:
    """The case with the probes a next measurement may add, when it has none: a thermocouple
    ``web`` in the pinion's body halfway between bore and root circle, on the tooth's centre line,
    mid-face, and a side-face probe ``rim`` on the front side face halfway between root and
    reference circle (in the tooth ring)."""
    ins = case.instruments
    if ins.probes:
        return case
    g = case.geometry
    pinion = GearPair(g).pinion  # the root circle of a shifted pinion too
    r_ref, r_root = 1e3 * pinion.reference_radius_m, 1e3 * pinion.root_radius_m
    probes = {
        "web": ProbeOptions(kind="thermocouple", radius_mm=0.5 * (g.bore_radius_mm + r_root)),
        "rim": ProbeOptions(kind="side_face", radius_mm=0.5 * (r_root + r_ref)),
    }
    return dataclasses.replace(case, instruments=dataclasses.replace(ins, probes=probes))


def suggest_measurements(
    data: Dataset,
    case: Case,
    result: Diagnosis,
    comm: MPI.Comm,
    grid: Grid | None = None,
    cache_dir: str | Path | None = None,
    forward=FullModel,
) -> Suggestion:
    """``gearfem diagnose --suggest``: the next measurements ranked (:mod:`.design`), with
    surrogates of the standing explanations' candidates (every instrument quantity of
    :func:`design_case`): transient to the last warm-up time at the data's points, steady at the
    grid's other points; the top proposals are checked on the full model. Cost: 1 + sum(nodes -
    1) full-model runs per point for those candidates, and a structural cycle per new torque.
    ``forward(case, comm, times_s=, quantities=)`` makes the forward models (the tests pass a
    cheap one)."""
    dcase = design_case(case)
    quantities = tuple(q for q in dcase.instruments.quantities if q != "efficiency")
    grid = grid or bench_grid(quantities)
    expl = standing_explanations(result)
    names = tuple(dict.fromkeys(n for e in expl for n in e.candidates))
    lib = tuple(by_name(n) for n in names)
    if len(expl) < 2:  # nothing to separate: no tables needed
        return suggest(lambda d, m: np.zeros(len(d)), data, result, grid, library=lib)
    wanted = tuple(dict.fromkeys((*quantities, *(m.quantity for m in data.measurements))))
    cache = cache_dir if cache_dir is not None else cache_root()
    pts = tuple(dict.fromkeys([(m.speed_rpm, m.torque_Nm) for m in data.measurements]))
    # the data's points: transient runs to the last warm-up time (time proposals); the grid's
    # other points: steady runs only (their proposals are end values)
    times = tuple(sorted({*data.times, *grid.times_s}))
    runs = forward(dcase, comm, times_s=times, quantities=wanted)
    steady = forward(dcase, comm, times_s=(), quantities=wanted)
    at_data = Surrogate(runs, pts, candidates=lib, cache_dir=cache)
    new = tuple(p for p in grid.points if p not in pts)
    at_grid = Surrogate(steady, new, candidates=lib, cache_dir=cache) if new else None
    both = _Split(at_data, at_grid)
    return suggest(
        both.predict,
        data,
        result,
        grid,
        library=lib,
        model_error=both.error,
        torque_u_Nm=dcase.instruments.torque.uncertainty_Nm,
        full_predict=_Split(runs, steady).predict,
    )


class _Split:
    """Two forward models as one: rows at the first's operating points go to the first, the
    others to the second (``predict`` and, for surrogates, ``error``)."""

    def __init__(self, first, second) -> None:
        self.first, self.second = first, second

    def _points(self):
        f = self.first
        return set(f.tables) if isinstance(f, Surrogate) else None

    def _route(self, data: Dataset, call):
        pts = self._points()
        mine = np.array(
            [
                (m.speed_rpm, m.torque_Nm) in pts
                if pts is not None
                else m.time_s is not None or self.second is None
                for m in data.measurements
            ]
        )
        out = np.empty(len(data))
        for mask, model in ((mine, self.first), (~mine, self.second)):
            if np.any(mask):
                out[mask] = call(model, data.subset(mask))
        return out

    def predict(self, data: Dataset, model: dict[str, float]) -> np.ndarray:
        return self._route(data, lambda f, d: f.predict(d, model))

    def error(self, data: Dataset, names) -> np.ndarray:
        return self._route(data, lambda f, d: f.error(d, names))


def _probes(sur: Surrogate, data: Dataset, torque_u_Nm: float) -> Dataset:
    """Measurements one could add at the data's operating points, every tabulated time: the
    readings of the instruments the data use (camera, probes, torque meters), and the model's
    field temperatures only when the data themselves are such (what no bench instrument reads is
    not proposed to a bench). Each reads the baseline's value with the measurement uncertainty a
    proposed reading has (:func:`~gearfem.diagnose.design.reading_uncertainty`; ``torque_u_Nm``:
    each torque meter's)."""
    fields_in_data = any(m.quantity in FIELD_QUANTITIES for m in data.measurements)
    rows, seen = [], set()
    for m in data.measurements:
        if m.point in seen:
            continue
        seen.add(m.point)
        table = sur.tables[(float(m.speed_rpm), float(m.torque_Nm))]
        base = table.base
        times = sorted({r[1] for r in base}, key=lambda t: math.inf if t is None else t)
        quantities = tuple(
            q
            for q in dict.fromkeys(r[0] for r in base)
            if fields_in_data or q not in FIELD_QUANTITIES
        )
        for q in quantities:
            for t in times:
                if (q, t) not in base:
                    continue
                v = base[(q, t)] + (table.ambient_C if unit_of(q) == "C" else 0.0)
                u = reading_uncertainty(q, v, torque_u_Nm)
                rows.append(Measurement(m.speed_rpm, m.torque_Nm, t, q, v, u, m.ambient_C))
    return Dataset(tuple(rows), "probes")


def _plots(
    result: Diagnosis, data: Dataset, out: Path, suggestion: Suggestion | None = None
) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    D = np.array([m.value for m in data.measurements])
    u = np.array([m.uncertainty for m in data.measurements])
    labels = [m.label() for m in data.measurements]
    base, chosen = result.baseline_fit, result.chosen_fit
    x = np.arange(len(D))
    fig, ax = plt.subplots(1, 2, figsize=(13, 5))
    ax[0].errorbar(x, D, yerr=2 * u, fmt="ko", label="measured (±2u)")
    ax[0].plot(x, base.predictions_C, "rs", label="baseline")
    if chosen is not base:
        ax[0].plot(x, chosen.predictions_C, "b^", label=chosen.label)
    # the other explanations still standing (within the design's window of the best)
    others = [
        m
        for m in result.models
        if m.delta <= STANDING_DELTA
        and m is not chosen
        and m.predictions_C is not None
        and m.candidates
    ][:4]
    for j, m in enumerate(others):
        ax[0].plot(x + 0.08 * (j + 1), m.predictions_C, "x", ms=7, label=m.label)
    ax[0].set_xticks(x, labels, rotation=80, fontsize=6)
    ax[0].set_ylabel("temperature (C)")
    ax[0].legend()
    ax[0].set_title("prediction vs data, before and after")
    ax[1].axhline(0.0, color="k", lw=0.5)
    ax[1].plot(x, (np.array(base.predictions_C) - D) / u, "rs", label="baseline")
    if chosen is not base:
        ax[1].plot(x, (np.array(chosen.predictions_C) - D) / u, "b^", label="chosen")
    ax[1].set_xticks(x, labels, rotation=80, fontsize=6)
    ax[1].set_ylabel("(S - D) / u_D")
    ax[1].set_title("residual signature")
    ax[1].legend()
    fig.tight_layout()
    fig.savefig(out / "prediction_vs_data.png", dpi=110)
    plt.close(fig)
    top = result.models[:12]
    fig, ax = plt.subplots(figsize=(8, 5))
    ax.barh(range(len(top)), [m.delta for m in top], color="tab:blue")
    ax.set_yticks(range(len(top)), [m.label for m in top], fontsize=7)
    ax.invert_yaxis()
    ax.set_xlabel(f"Δ{result.criterion} to the best")
    ax.set_title("ranking")
    fig.tight_layout()
    fig.savefig(out / "ranking.png", dpi=110)
    plt.close(fig)
    if suggestion is not None and suggestion.ranked and suggestion.separates:
        _suggestion_plot(suggestion, out / "suggestion.png", plt)


def _suggestion_plot(sug: Suggestion, path: Path, plt, top: int = 12) -> None:
    """Left: the ranked proposals' expected information gain (bars) and probability of deciding
    (dots). Right: at the best proposal's most separating row, each explanation's predicted
    reading (full model where re-run) with the row's +-2u band."""
    ranked = sug.ranked[:top]
    colours = {"operating point": "tab:blue", "time": "tab:orange", "instrument": "tab:green"}
    fig, ax = plt.subplots(1, 2, figsize=(13, 5), gridspec_kw={"width_ratios": [1.6, 1]})
    y = np.arange(len(ranked))
    ax[0].barh(
        y,
        [p.expected_information_gain_bits for p in ranked],
        color=[colours.get(p.kind, "grey") for p in ranked],
    )
    ax[0].axvline(sug.prior_entropy_bits, color="k", ls="--", lw=0.8, label="prior entropy")
    ax[0].plot([p.decide_probability for p in ranked], y, "k.", label="P(decides)")
    ax[0].set_yticks(y, [f"{p.label} ({p.kind})" for p in ranked], fontsize=7)
    ax[0].invert_yaxis()
    ax[0].set_xlabel("expected information gain (bit); P(decides) as dots")
    ax[0].set_title("what to measure next")
    ax[0].legend(fontsize=7, loc="lower right")
    best = ranked[0]
    i = best.deciding_row()
    names = list(best.readings)
    v = [best.readings[n][i] for n in names]
    ax[1].errorbar(range(len(names)), v, yerr=2 * best.uncertainty[i], fmt="o", capsize=4)
    ax[1].set_xticks(range(len(names)), names, rotation=30, ha="right", fontsize=7)
    ax[1].set_ylabel(f"predicted reading ({unit_of(best.quantities[i])})")
    ax[1].set_xlim(-0.5, len(names) - 0.5)
    ax[1].set_title(f"best proposal, most separating row:\n{best.rows[i]} (±2u)", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def markdown(report: DiagnosisReport, data: Dataset) -> str:
    result = report.diagnosis
    v = result.verdict
    lines = [
        f"# Diagnosis of {data.source or 'data'} against case {report.case!r}",
        "",
        f"**Verdict: {v.text}**",
        "",
        *(
            [
                "**The verdict is fragile**: a data point lies within its parameter's "
                "uncertainty of the fold that decides its branch (Fold margins, below).",
                "",
            ]
            if report.fragile
            else []
        ),
        f"{result.n_measurements} measurements, {result.n_effective} independent "
        f"(a curve counts as at most two), ranked by {result.criterion}.",
        "",
        "## V&V 20 comparison of the baseline (full model)",
        "",
        markdown_table(TABLE_HEAD, [r.cells() for r in report.vv20.rows]),
    ]
    lines += [
        "",
        f"u_num: {report.vv20.u_num_method}.",
        "",
        "## Ranking (surrogate)",
        "",
        "| model | parameters (95 % profile interval) | chi2 | Δ | held-out RMS (K) |",
        "|---|---|---|---|---|",
    ]
    for m in result.models[:15]:
        ps = ", ".join(
            f"{n} = {m.params[n]:.4g}"
            + (f" [{m.intervals[n][0]:.3g}, {m.intervals[n][1]:.3g}]" if n in m.intervals else "")
            + (f" (scaled x{m.interval_scale:.3g})" if m.interval_scale > 1 and m.intervals else "")
            for n in m.candidates
        )
        loo = "" if m.loo_rmse_K is None else f"{m.loo_rmse_K:.1f}"
        lines.append(f"| {m.label} | {ps} | {m.chi2:.1f} | {m.delta:.1f} | {loo} |")
    g = result.gain
    fmt = lambda x: "n/a" if x is None else f"{x:.1f} K"
    lines += [
        "",
        "## Gain",
        "",
        f"Held-out (leave one operating point out) RMS error: {fmt(g.loo_rmse_before_K)} "
        f"before, {fmt(g.loo_rmse_after_K)} after; in-sample RMS {fmt(g.rmse_before_K)} "
        f"before, {fmt(g.rmse_after_K)} after on the surrogate"
        + (
            f", {fmt(result.refined.full_rmse_K)} on the full model at the refined value"
            if result.refined is not None and result.refined.full_rmse_K is not None
            else ""
        )
        + g.other_units_text(held_out=True)
        + g.other_units_text(held_out=False)
        + ".",
    ]
    if result.refined is not None:
        c = result.refined
        ps = ", ".join(
            f"{n} = {c.params[n]:.4g} [{c.intervals[n][0]:.4g}, {c.intervals[n][1]:.4g}]"
            for n in c.params
        )
        lines += [
            "",
            f"Full-model confirmation of the chosen model (surrogate corrected by the full model "
            f"at the "
            f"optimum, refitted): {ps}; full-model RMS error {c.full_rmse_K:.2f} K; "
            f"correction applied {c.max_correction_K[0]:.2f} K, remaining full-vs-corrected "
            f"difference {c.full_vs_corrected_max_K:.2f} K.",
        ]
        if c.interval_scale > 1.0:
            lines += [
                "",
                f"The chosen model fails the chi-square test: its ranges use the threshold "
                f"3.84 x chi2/dof = {3.841 * c.interval_scale:.3g}; they are not 95 % "
                "intervals of a model that explains the data.",
            ]
        checked = [e for e in c.edges if e.checked]
        if checked:
            lines += ["", "Interval edges on the full model:", ""]
            lines += [
                f"- {e.parameter} {e.side}: surrogate {e.surrogate_edge:.4g}, full model "
                f"{e.full_edge:.4g} (chi2 there {e.full_excess_chi2:+.2f} from the threshold; "
                f"{e.full_runs} full-model runs)"
                for e in checked
            ]
        elif c.edges:
            lines += [
                "",
                "Interval edges not re-checked on the full model: the surrogate's error estimate "
                "cannot move chi2 there by more than 0.5.",
            ]
    if report.fold_margins:
        lines += [
            "",
            "## Fold margins (the branch each point lands on)",
            "",
            "A run from ambient ends on the cool steady state wherever it exists; each point's "
            "margin is the distance to the fold where its gear's cool branch ends "
            "(gearfem.diagnose.margins), in the fitted parameter, the torque and the ambient.",
            "",
            margins_markdown(report.fold_margins),
        ]
    if v.separate_by:
        lines += ["", "## Measurements that would separate the rivals (predicted differences)", ""]
        lines += [
            f"- {s.measurement}: {'+'.join(s.rival)} differs by {s.difference:.3g} {s.unit} "
            f"({s.separation_u:.1f} times the reading's uncertainty)"
            for s in v.separate_by
        ]
    if report.suggestion is not None:
        lines += suggestion_markdown(report.suggestion)
    lines += [
        "",
        "![prediction vs data](prediction_vs_data.png)",
        "",
        "![ranking](ranking.png)",
        "",
    ]
    sug = report.suggestion
    if sug is not None and sug.ranked and sug.separates:
        lines += ["![what to measure next](suggestion.png)", ""]
    return "\n".join(lines)


def suggestion_markdown(sug: Suggestion, top: int = 12) -> list[str]:
    """The ranked next measurements as a markdown section."""
    g = sug.grid
    lines = [
        "",
        "## What to measure next (`--suggest`)",
        "",
        f"Grid: speeds {', '.join(f'{x:g}' for x in g.speeds_rpm)} rpm x torques "
        f"{', '.join(f'{x:g}' for x in g.torques_Nm)} N m, warm-up times "
        f"{', '.join(f'{x:g}' for x in g.times_s)} s, instruments {', '.join(g.instruments)} "
        f"({g.source}). "
        + (
            f"Standing explanations (prior entropy {sug.prior_entropy_bits:.2f} bit): "
            + ", ".join(f"{e.label} (p = {e.probability:.2f})" for e in sug.explanations)
            + f"; {sug.draws} simulated outcomes per explanation and proposal."
            if sug.separates
            else "One explanation standing ("
            + ", ".join(e.label for e in sug.explanations)
            + "): nothing to separate, so no measurement of the grid is ranked."
        ),
    ]
    if sug.separates:
        lines += [
            "",
            "| rank | kind | measurement | expected information gain (bit) | P(decides) | "
            "largest separation (u) | full vs surrogate (max) |",
            "|---|---|---|---|---|---|---|",
        ]
    for i, p in enumerate(sug.ranked[:top] if sug.separates else (), start=1):
        full = "" if p.full_max_difference is None else f"{p.full_max_difference:.2g}"
        lines.append(
            f"| {i} | {p.kind} | {p.label} | {p.expected_information_gain_bits:.2f} | "
            f"{p.decide_probability:.2f} | {p.separation:.1f} | {full} |"
        )
    lines += ["", "**Measurements that would decide:**", "", "```", sug.text, "```"]
    return lines


@dataclasses.dataclass(frozen=True)
class DiagnosisReport(JsonRecord):
    """A diagnosis with what it was made of (``diagnosis.json``: the diagnosis' fields, then the
    data, the case name, the V&V 20 table, the surrogate check and the candidate library)."""

    diagnosis: Diagnosis
    data: dict[str, Any]
    case: str
    vv20: ComparisonTable
    surrogate: dict[str, Any]
    candidates: dict[str, Any]
    suggestion: Suggestion | None = None
    # the winner's law may be bistable: each data point's distance to the folds that decide its
    # branch (gearfem.diagnose.margins)
    fold_margins: tuple[FoldMargin, ...] = ()
    # what the diagnosis was computed with (gearfem.claims)
    provenance: dict[str, Any] | None = None

    @property
    def fragile(self) -> bool:
        """Whether a fold of the verdict lies within its parameter's uncertainty."""
        return any(m.fragile for m in self.fold_margins)

    def to_json(self) -> dict[str, Any]:
        out = self.diagnosis.to_json()
        out.update({k: v for k, v in super().to_json().items() if k != "diagnosis"})
        return out

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> DiagnosisReport:
        own = ("data", "case", "vv20", "surrogate", "candidates")
        extra = ("suggestion", "fold_margins", "provenance")
        rest = {k: v for k, v in data.items() if k not in (*own, *extra)}
        sug = data.get("suggestion")
        return cls(
            Diagnosis.from_json(rest),
            data["data"],
            data["case"],
            ComparisonTable.from_json(data["vv20"]),
            data["surrogate"],
            data["candidates"],
            suggestion=None if sug is None else Suggestion.from_json(sug),
            fold_margins=tuple(FoldMargin.from_json(m) for m in data.get("fold_margins", ())),
            provenance=data.get("provenance"),
        )


__all__ = [
    "DiagnosisReport",
    "clear_earlier_outputs",
    "design_case",
    "markdown",
    "run_diagnosis",
    "suggest_measurements",
    "suggestion_markdown",
]
