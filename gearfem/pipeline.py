"""The whole chain for one case: geometry → contact cycle → heat sources → thermal → baselines.

Each stage has one product and a cache: the pair mesh (``meshes/cache``), the structural cycle per
torque (``cache/cycles``; speed-independent), and the thermal run per operating point (written to
the output directory). :func:`run` is what ``gearfem run`` and ``./dev.sh run`` execute; it writes
``summary.json`` (last, so a failed run leaves none), the resolved case and versions
(``case.toml``, ``versions.json``), the cycle histories and plots, the thermal history, plots and
fields, and the instruments' readings: the gears' fields kept for them
(``instruments/snapshot.npz``) and the camera's thermograms. :func:`observe` reads the
instruments again on a finished run (``gearfem observe``).
"""

from __future__ import annotations

import dataclasses
import logging
import math
import time
from pathlib import Path
from typing import Any

import numpy as np
from mpi4py import MPI

from gearfem.baselines import baseline_summary, max_rack_fillet_coef
from gearfem.config import Case, load_case, write_case
from gearfem.core.errors import ConvergenceError, ParameterError
from gearfem.core.io import prepare_output, read_json, write_json
from gearfem.core.kept import Kept, members
from gearfem.core.log import ProgressBar
from gearfem.core.material_library import library_material, library_names
from gearfem.core.materials import ZERO_CELSIUS_K, TemperatureTable
from gearfem.core.provenance import versions
from gearfem.core.results import JsonRecord
from gearfem.core.tasks import run_split
from gearfem.coupling.friction_report import (
    branch_starts,
    evaluate_at,
    flank_maps,
    friction_model,
    plot_flank_maps,
)
from gearfem.coupling.friction_report import summary as friction_summary
from gearfem.coupling.heat_sources import cycle_heat_sources
from gearfem.cycle.cache import (
    cache_root,
    cached_cycle,
    compliance_context,
    compliance_store,
    cycle_key,
)
from gearfem.cycle.cache import load as load_cycle
from gearfem.cycle.friction_field import FrictionField
from gearfem.cycle.measures import pitch_point_band_pressure_Pa
from gearfem.cycle.model import GearContactModel
from gearfem.cycle.modulus_field import GearTemperature, ModulusField
from gearfem.cycle.report import write_cycle_outputs
from gearfem.geometry.involute import GearPair
from gearfem.geometry.mesh import build_gear_mesh, cache_gear_mesh
from gearfem.geometry.options import BODIES
from gearfem.geometry.placement import placement
from gearfem.instruments.camera import CameraGeometry, gear_window
from gearfem.instruments.evaluate import INSTRUMENTS, InstrumentReadings, evaluate
from gearfem.instruments.gather import FieldRecorder
from gearfem.instruments.options import InstrumentOptions
from gearfem.instruments.snapshot import BodyField, CycleTorques, FieldSnapshot
from gearfem.instruments.torque import read_torque
from gearfem.thermal.boundary import ThermalBoundary
from gearfem.thermal.branches import steady_states
from gearfem.thermal.domain import ThermalDomain
from gearfem.thermal.lumped import gear_radii, lumped_estimate
from gearfem.thermal.outputs import solve_and_write
from gearfem.thermal.problem import ThermalProblem
from gearfem.thermal.source_terms import prescribed_heat_sources
from gearfem.uncertainty import RunUncertainty, provenance, run_uncertainty

log = logging.getLogger(__name__)

#: How many times :func:`steady_after_transient` continues a transient (doubling each time).
STEADY_CONTINUATIONS = 6


# ------------------------------------------------------------------------------------------------
# results
# ------------------------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class CycleCache(JsonRecord):
    """Where the run's structural cycle is stored and whether it came from there."""

    directory: str
    from_cache: bool


@dataclasses.dataclass(frozen=True)
class CycleAtSpeed(JsonRecord):
    """The structural cycle of a run at its operating speed (``summary.json`` "cycle")."""

    effective_contact_ratio: float
    theoretical_contact_ratio: float
    max_contact_pressure_MPa: float
    pitch_point_pressure_MPa: float
    max_root_stress_MPa: dict[str, float]
    transmission_error_um: dict[str, float]  # mean, peak_to_peak
    friction_power_W: float
    pinion_torque_mean_Nm: float
    positions: int
    newton_iterations: int
    cycle_wall_time_s: float
    info: dict[str, Any]
    cache: CycleCache | None = None
    # the pitch point's contact band as a Hertz profile of its load and spread, 2 w / (π a): the
    # converged measure beside the largest pointwise pressure (gearfem.cycle.measures; None
    # without a contact history)
    pitch_point_band_pressure_MPa: float | None = None

    @classmethod
    def of(cls, cyc, speed_rpm: float, cache: CycleCache | None = None) -> CycleAtSpeed:
        omega = 2.0 * math.pi * speed_rpm / 60.0
        band = pitch_point_band_pressure_Pa(cyc)
        return cls(
            effective_contact_ratio=cyc.effective_contact_ratio(),
            theoretical_contact_ratio=cyc.theoretical_contact_ratio,
            max_contact_pressure_MPa=float(np.max(cyc.p_max_Pa)) / 1e6,
            pitch_point_pressure_MPa=float(cyc.p_max_mid_Pa[0]) / 1e6,
            max_root_stress_MPa={b: float(np.max(v)) / 1e6 for b, v in cyc.root_stress_Pa.items()},
            transmission_error_um={
                "mean": float(np.mean(cyc.te_m)) * 1e6,
                "peak_to_peak": float(np.ptp(cyc.te_m)) * 1e6,
            },
            friction_power_W=cyc.mean_friction_power_W_per_rad_s() * omega,
            pinion_torque_mean_Nm=float(np.mean(cyc.pinion_torque_Nm)),
            positions=len(cyc.phi_rad),
            newton_iterations=int(np.sum(cyc.newton_iterations)),
            cycle_wall_time_s=float(np.sum(cyc.wall_time_s)),
            info=dict(cyc.info),
            cache=cache,
            pitch_point_band_pressure_MPa=band / 1e6 if band is not None else None,
        )


@dataclasses.dataclass(frozen=True)
class Headline(JsonRecord):
    """The numbers a person reads first (``summary.json`` "headline"); None where not computed."""

    time_s: float | None
    max_surface_temperature_C: float | None
    mean_bulk_temperature_C: float | None
    steady_max_surface_temperature_C: float | None
    at_times_max_surface_C: dict[str, float | None]
    friction_power_W: float | None = None
    effective_contact_ratio: float | None = None
    # the analytic baselines of the gear whose temperature is computed ([thermal] body; None for
    # a metal gear, which VDI 2736 does not rate)
    vdi2736_flank_C: float | None = None
    vdi2736_root_C: float | None = None
    mao_bulk_C: float | None = None
    flash_max_K: float | None = None
    # numerical standard uncertainty (K, W, -) of the fields above that have one, by field name,
    # from the refinement studies stored for the case's resolution (gearfem.uncertainty)
    u_num: dict[str, float] | None = None
    # the friction law's heat into the modelled gear at the end of the run (W per gear) and the
    # steady states the branch search found (None: not searched, the heat cannot rise with T)
    friction_heat_per_gear_W: float | None = None
    steady_states_found: int | None = None
    camera_max_C: float | None = None  # the IR camera's reading at the end of the run
    camera_max_steady_C: float | None = None
    camera_max_at_times_C: dict[str, float] | None = None
    torque_loss_Nm: float | None = None
    # the surface maximum of the quadratic field, between the nodes (max_surface_temperature_C is
    # the hottest node; None: no field recorded)
    max_surface_field_C: float | None = None


@dataclasses.dataclass(frozen=True)
class CycleMuPass(JsonRecord):
    """One pass of the cycle ↔ heat fixed point in the cycle's mu (:func:`thermal_stages`): the
    cycle solved at ``mu_cycle`` (with a mu per contact: the mu of contacts without a band),
    the case's thermal runs on it, and the friction law's effective mu at their end value,
    ``mu_effective = mu_cycle_mean P_law / P_cycle`` (the constant mu that dissipates the law's
    friction power, as the torque meters read it). ``mu_cycle_mean`` is the constant mu that
    dissipates the cycle's own friction power (:meth:`CycleResult.mean_friction_coefficient
    <gearfem.cycle.result.CycleResult.mean_friction_coefficient>`): ``mu_cycle`` with one mu,
    the heat-weighted mean of the band field with a mu per contact."""

    mu_cycle: float
    mu_effective: float
    friction_power_law_W: float
    friction_power_cycle_W: float
    cycle_key: str
    wall_time_s: float
    # with a mu per contact ([friction] cycle_mu = "law"): how far the law's mu at the bands
    # moved from the mu the cycle had there, heat-weighted mean and largest at a loaded band
    # (FrictionField.change_from), and the range of the law's band mu (None: the cycle takes
    # one mu, cycle_mu = "effective")
    field_change: float | None = None
    field_change_max: float | None = None
    mu_band_range: tuple[float, float] | None = None
    mu_cycle_mean: float | None = None

    @property
    def change(self) -> float:
        """How far the law moves the cycle's mu in this pass: the heat-weighted mean move at the
        contact bands (a mu per contact), or mu_effective − mu_cycle (one mu)."""
        if self.field_change is not None:
            return self.field_change
        return self.mu_effective - self.mu_cycle


@dataclasses.dataclass(frozen=True)
class CycleMuLoop(JsonRecord):
    """``summary.json`` "cycle_mu": the passes of the cycle ↔ heat fixed point in the cycle's mu
    (``[friction] cycle_mu = "law"``, a mu per contact, or ``"effective"``, one mu). The run's
    readings are the last pass's, whose cycle was solved at ``mu`` (with a mu per contact: the
    mu where a contact has no band, the band field elsewhere); converged: its change is below
    ``tolerance``."""

    passes: tuple[CycleMuPass, ...]
    tolerance: float

    @property
    def mu(self) -> float:
        return self.passes[-1].mu_cycle


@dataclasses.dataclass(frozen=True)
class ModulusPass(JsonRecord):
    """One pass of the cycle ↔ heat fixed point in the modulus (``[cycle] modulus =
    "thermal_state"``, :func:`thermal_stages`): the pinion's and the wheel's mean relative modulus
    (harmonic volume mean of e = E(T)/E over its thermal model) the pass's cycle was solved with
    and the one its thermal state gives, how far the state's field moved from the cycle's
    (largest change of a gear's mean, and of a cell's e: the fixed point's measure), each gear's
    share of the thermal model's volume beyond its E(T) table (its last value taken there), the
    cycle's key and the pass's wall time (s)."""

    relative_cycle: tuple[float, float]
    relative_state: tuple[float, float]
    change: float
    change_max: float
    beyond_table: tuple[float, float]
    cycle_key: str
    wall_time_s: float


@dataclasses.dataclass(frozen=True)
class ModulusLoop(JsonRecord):
    """``summary.json`` "modulus": the passes of the cycle ↔ heat fixed point in the modulus. The
    run's readings are the last pass's; settled: no cell's e moved by ``tolerance`` or more in it
    (``change_max``)."""

    passes: tuple[ModulusPass, ...]
    tolerance: float


@dataclasses.dataclass(frozen=True)
class ThermalStages:
    """The cycle and thermal stages of a run (:func:`thermal_stages`): the case of the last
    cycle (its ``contact.friction_coefficient`` the mu that cycle was solved with), the cycle,
    where it is stored and whether it came from there, the thermal summaries of ``[thermal] body``
    and of the other gear, the fields' snapshot (rank 0), the fixed point's passes (None: the
    cycle kept the case's mu) and the wall times (s) of all passes together."""

    case: Case
    cycle: Any
    cycle_dir: Path | None
    cycle_cached: bool
    thermal: dict[str, Any]
    others: dict[str, dict[str, Any]]
    snapshot: FieldSnapshot | None
    cycle_mu: CycleMuLoop | None
    cycle_s: float
    thermal_s: float
    modulus: ModulusLoop | None = None


@dataclasses.dataclass(frozen=True)
class RunSummary(JsonRecord):
    """What ``gearfem run`` computes for one operating point (``summary.json``, written last).

    ``thermal`` is the thermal stage's summary of ``[thermal] body``
    (``thermal/thermal_summary.json``), ``thermal_other`` that of the other gear when the
    instruments need both (``thermal_<body>/``), ``baselines`` the analytic estimates
    (:func:`gearfem.baselines.baseline_summary`) and ``instruments`` every configured
    instrument's reading (:class:`gearfem.instruments.evaluate.InstrumentReadings`).
    """

    case: str
    speed_rpm: float
    torque_Nm: float
    thermal: dict[str, Any]
    baselines: dict[str, Any]
    wall_time_s: dict[str, float]
    mpi_size: int
    cycle: CycleAtSpeed | None
    headline: Headline
    numerical_uncertainty: RunUncertainty | None = None
    instruments: InstrumentReadings | None = None
    thermal_other: dict[str, Any] | None = None
    # the cycle <-> heat fixed point in the cycle's mu ([friction] cycle_mu = "law"; else None)
    cycle_mu: CycleMuLoop | None = None
    # the friction heat's split by contact temperature ([sources] heat_partition =
    # "contact_temperature"; else None)
    heat_split: HeatSplit | None = None
    # the cycle <-> heat fixed point in the modulus ([cycle] modulus = "thermal_state"; else None)
    modulus: ModulusLoop | None = None
    # what the run was computed with (gearfem.uncertainty.provenance; a figure quoted from it
    # carries this, gearfem.claims checks it):
    # resolution key, code hash of the run's modules, commit, date
    provenance: dict[str, Any] | None = None

    @classmethod
    def read(cls, path: str | Path) -> RunSummary:
        return cls.from_json(read_json(Path(path)))


def pair_mesh(case: Case, comm: MPI.Comm, cache_dir: Path | None = None):
    return build_gear_mesh(case.geometry, case.mesh, comm, cache_dir=cache_dir, bodies=BODIES)


def case_cycle_key(
    case: Case,
    friction_field: FrictionField | None = None,
    moduli: ModulusField | None = None,
) -> str:
    """The cache key of the case's cycle (solved with ``friction_field``'s mu and the modulus
    per cell of ``moduli`` when given)."""
    return cycle_key(
        case.geometry,
        case.mesh,
        case.materials,
        case.contact,
        case.cycle,
        case.operating.torque_Nm,
        friction_field,
        moduli,
    )


def case_cycle_dir(case: Case) -> Path:
    """Where the cycle of the case's torque is stored (:func:`case_cycle_key` under
    ``<cache>/cycles/``; complete when it holds cycle.json and cycle.npz)."""
    return cache_root() / "cycles" / case_cycle_key(case)


def case_compliance_context(case: Case, moduli: ModulusField | None = None) -> str:
    """The part of the gear-compliance store key that comes from the case (mesh, elastic
    constants, code) and the modulus field; the store adds each gear's contact DOFs and
    supports."""
    return compliance_context(case.geometry, case.mesh, case.materials, moduli)


def cycle(
    case: Case,
    comm: MPI.Comm,
    mesh_cache: Path | None = None,
    cache_dir: Path | None = None,
    rebuild: bool = False,
    progress=None,
    friction_field: FrictionField | None = None,
    moduli: ModulusField | None = None,
):
    """The structural cycle of the case's torque (cached), solved with ``friction_field``'s mu at
    each contact when given (else ``contact.friction_coefficient``) and with the modulus per cell
    of ``moduli`` when given (else each material's constant modulus). Returns (CycleResult,
    directory, from_cache).

    On several ranks with ``[cycle] parallel = "positions"`` (the condensed solver's default)
    every rank builds the whole model on its own (the mesh is meshed once, on rank 0, and read by
    each) and solves its block of the positions (:func:`gearfem.cycle.solve.solve_cycle`);
    otherwise the mesh is distributed over ``comm``."""
    spread = comm.size > 1 and case.cycle.positions_over_ranks

    def factory():
        if spread:
            cache_gear_mesh(case.geometry, case.mesh, comm, cache_dir=mesh_cache, bodies=BODIES)
            gm = pair_mesh(case, MPI.COMM_SELF, mesh_cache)
        else:
            gm = pair_mesh(case, comm, mesh_cache)
        return GearContactModel(
            gm,
            case.materials,
            case.contact,
            case.operating.torque_Nm,
            case.cycle,
            compliance_store=compliance_store(
                case.geometry, case.mesh, case.materials, cache_dir, moduli
            ),
            share=comm if spread else None,
            moduli=moduli,
        )

    return cached_cycle(
        factory,
        case_cycle_key(case, friction_field, moduli),
        comm,
        cache_dir=cache_dir,
        rebuild=rebuild,
        progress=progress,
        world=comm if spread else None,
        friction_field=friction_field,
    )


def thermal(
    case: Case,
    out_dir: str | Path,
    comm: MPI.Comm,
    cycle_result=None,
    mesh_cache: Path | None = None,
    write_fields: bool = True,
    extra: dict[str, Any] | None = None,
    steady: bool = True,
    write_plot: bool = True,
) -> dict[str, Any]:
    """Thermal run of ``case.thermal.body`` with sources from ``cycle_result`` (mode "cycle") or
    prescribed ([sources] mode "prescribed"); writes the thermal outputs to ``out_dir``."""
    summary, _ = thermal_field(
        case, out_dir, comm, cycle_result, mesh_cache, write_fields, extra, steady, write_plot
    )
    return summary


def reported_quantities(
    thermal: dict[str, Any],
    cycle: CycleAtSpeed | None,
    readings: InstrumentReadings | None = None,
    surface_field_max_C: float | None = None,
) -> dict[str, tuple[float, str]]:
    """The quantities a run reports and a refinement study follows, name -> (value, unit): every
    temperature of the thermal summary at the end of the run, ``max_surface_field`` (the
    surface maximum of the field between the nodes, :func:`surface_field_max`) when given, the
    instruments' readings at the end (``camera_max``, ``probe:NAME``, ``torque_loss_Nm``) and,
    with a cycle, its friction power, effective contact ratio, pitch-point pressures (the largest
    pointwise one and its band's Hertz-profile peak) and largest pressure and mean transmission
    error."""
    out = {q: (v, "C") for q, v in thermal.get("final_temperatures_C", {}).items()}
    if surface_field_max_C is not None:
        out["max_surface_field"] = (surface_field_max_C, "C")
    if readings is not None:
        if "end" in readings.camera:
            out["camera_max"] = (readings.camera["end"].max_C, "C")
        for name, probe in readings.probes.get("end", {}).items():
            out[f"probe:{name}"] = (probe.value_C, "C")
        if readings.torque is not None:
            out["torque_loss_Nm"] = (readings.torque.torque_loss_Nm, "N m")
    if cycle is not None:
        out.update(
            friction_power_W=(cycle.friction_power_W, "W"),
            effective_contact_ratio=(cycle.effective_contact_ratio, "-"),
            pitch_point_pressure_MPa=(cycle.pitch_point_pressure_MPa, "MPa"),
            max_contact_pressure_MPa=(cycle.max_contact_pressure_MPa, "MPa"),
            transmission_error_mean_um=(cycle.transmission_error_um["mean"], "um"),
        )
        if cycle.pitch_point_band_pressure_MPa is not None:
            out["pitch_point_band_pressure_MPa"] = (cycle.pitch_point_band_pressure_MPa, "MPa")
    return out


def surface_field_max(
    snapshot: FieldSnapshot | None, body: str, comm: MPI.Comm, label: str = "end"
) -> float | None:
    """The largest temperature (C) of ``body``'s finite-element field on its surface (teeth, side
    faces and bore, as ``max_surface``) at snapshot time ``label``, where the quadratic field may
    peak between the nodes (:meth:`BodyField.hottest_point`); never below the hottest node
    ``max_surface``. None when no snapshot was recorded (no instrument reads a field) or it lacks
    ``body`` or ``label``. Collective: the snapshot lives on rank 0, the value is broadcast."""

    def on_rank0() -> float | None:
        if body not in snapshot.bodies or label not in snapshot.labels:
            return None
        t_K, _ = snapshot.bodies[body].hottest_point(snapshot.label_index(label))
        return t_K - ZERO_CELSIUS_K

    if not comm.bcast(snapshot is not None, root=0):
        return None
    return on_root(comm, on_rank0)


# ------------------------------------------------------------------------------------------------
# instruments
# ------------------------------------------------------------------------------------------------


def instrument_bodies(case: Case) -> tuple[str, ...]:
    """The gears whose fields the case's instruments read: the camera sees both, and the torque
    meters read the heat both gears' models make (the friction law's share of each, and the
    hysteresis) when the sources come from a cycle."""
    ins = case.instruments
    wanted = {case.thermal.body}
    if ins.camera.enabled or (ins.torque.enabled and case.sources.mode == "cycle"):
        wanted |= set(BODIES)
    wanted |= {p.body for p in ins.probes.values()}
    return tuple(b for b in BODIES if b in wanted)


def needs_fields(instruments: InstrumentOptions) -> bool:
    """True when an instrument reads what the thermal runs record: temperature fields (camera,
    probes) or the heat of each gear at the reported times (torque meters)."""
    return instruments.camera.enabled or bool(instruments.probes) or instruments.torque.enabled


def check_instruments(case: Case) -> None:
    """Checks of the instruments against the geometry, before anything is solved: the camera
    must see the gears (an error names ``instruments.camera.view``)."""
    cam = case.instruments.camera
    if not cam.enabled:
        return
    pair = GearPair(case.geometry)
    centers = [np.zeros(3), np.array([pair.center_distance_m, 0.0, 0.0])]
    radii = [pair.pinion.tip_radius_m, pair.wheel.tip_radius_m]
    b = case.geometry.face_width_mm * 1e-3
    target = (
        np.asarray(cam.target_mm) * 1e-3
        if cam.target_mm is not None
        else np.array([0.5 * pair.center_distance_m, 0.0, 0.5 * b])
    )
    gear_window(cam, CameraGeometry.of(cam, target), centers, radii, (0.0, b))


def on_root(comm: MPI.Comm, fn):
    """``fn()`` evaluated on rank 0 and its result broadcast (collective); an exception raised
    there is raised on every rank (the other ranks must not wait for a result that never comes)."""
    result, error = None, None
    if comm.rank == 0:
        try:
            result = fn()
        except Exception as err:  # re-raised below on every rank
            error = err
    result, error = comm.bcast((result, error), root=0)
    if error is not None:
        raise error
    return result


def observed_thermal(
    case: Case,
    out: Path,
    comm: MPI.Comm,
    cycle_result=None,
    mesh_cache: Path | None = None,
    write_fields: bool = True,
    steady: bool = True,
    write_plot: bool = True,
    branch_search: bool = True,
) -> tuple[dict[str, Any], dict[str, dict[str, Any]], FieldSnapshot | None]:
    """The thermal runs the instruments need: ``[thermal] body`` into ``out/thermal`` and, when
    the instruments read the other gear too, that gear into ``out/thermal_<body>``. Returns the
    main summary, the other summaries by body, and the fields' snapshot (rank 0; None on the other
    ranks and when no instrument reads a field). ``branch_search``: see :func:`thermal_field`.

    With ``[sources] heat_partition = "contact_temperature"`` both gears are run, again, with
    the pinion's share f of the friction heat solved for (:func:`split_by_contact_temperature`);
    the main summary then holds the passes under ``"heat_split"`` (a :class:`HeatSplit`)."""
    args = (comm, cycle_result, mesh_cache, write_fields, steady, write_plot, branch_search)
    src = case.sources
    if src.mode != "cycle" or not src.friction or src.heat_partition != "contact_temperature":
        return _observed_once(case, out, *args)
    return split_by_contact_temperature(case, out, *args)


@dataclasses.dataclass(frozen=True)
class HeatSplitPass(JsonRecord):
    """One pass of :func:`split_by_contact_temperature`: the pinion's share of the friction heat
    and each gear's heat-weighted mean contact temperature (flank + flash, C) with it."""

    fraction_pinion: float
    contact_pinion_C: float
    contact_wheel_C: float

    @property
    def difference_K(self) -> float:
        return self.contact_pinion_C - self.contact_wheel_C


@dataclasses.dataclass(frozen=True)
class HeatSplit(JsonRecord):
    """The friction heat's split that equates the gears' contact temperatures: the passes, the
    last one the run's (its ``difference_K`` below ``tolerance_K``)."""

    passes: tuple[HeatSplitPass, ...]
    tolerance_K: float

    @property
    def fraction_pinion(self) -> float:
        return self.passes[-1].fraction_pinion


#: Thermal runs of both gears :func:`split_by_contact_temperature` may take.
SPLIT_PASSES = 12
#: The pinion's share is kept within [SPLIT_MARGIN, 1 − SPLIT_MARGIN] while it is searched.
SPLIT_MARGIN = 1e-3


def split_by_contact_temperature(
    case: Case, out: Path, comm: MPI.Comm, *args
) -> tuple[dict[str, Any], dict[str, dict[str, Any]], FieldSnapshot | None]:
    """Both gears' thermal runs with the friction heat split so that their contact temperatures
    agree (collective; arguments after ``out`` and ``comm`` as :func:`observed_thermal`'s).

    Blok's postulate holds at the contact: the two surfaces touching there have one temperature.
    The fixed split (the effusivities' ratio) and Blok's band partition equate the two flashes
    only; where the gears' bulk temperatures differ (a steel gear against a polymer one: the
    steel takes most of the heat and, adiabatic at its bore, runs hotter) the contact
    temperatures, flank + flash, do not. Here the pinion's share f (one number for the pair,
    the wheel's 1 − f) is solved for so that the gears' heat-weighted mean contact temperatures
    at the run's end value (the state the friction report describes: the transient's end, or the
    steady state in steady mode) agree within ``[sources] contact_temperature_tolerance_K``:
    r(f) = T_c,pinion(f) − T_c,wheel(f) rises with f. The first step is Newton's with the flashes'
    share of the slope, dr/df ≈ θ_pinion/f + θ_wheel/(1 − f); then secant steps, kept inside the
    bracket once r has changed sign (a step that leaves it bisects). Not converged after
    :data:`SPLIT_PASSES` runs raises ConvergenceError with the passes. One share for the pair is
    a first-order split: the contact temperatures then agree on average, not at every contact."""
    src = case.sources
    tol = src.contact_temperature_tolerance_K
    f = src.heat_fractions(case.materials)["pinion"]
    passes: list[HeatSplitPass] = []
    lo = hi = None  # the shares with r < 0 and with r > 0
    for _ in range(SPLIT_PASSES):
        c = dataclasses.replace(
            case,
            sources=dataclasses.replace(src, heat_partition="fixed", heat_fraction_pinion=f),
        )
        th, others, snapshot = _observed_once(c, out, comm, *args, both=True, friction_report=True)
        by_body = {case.thermal.body: th, **others}
        fr = {b: by_body[b]["friction"] for b in BODIES}
        passes.append(
            HeatSplitPass(
                fraction_pinion=f,
                contact_pinion_C=float(fr["pinion"]["contact_C_heat_weighted"]),
                contact_wheel_C=float(fr["wheel"]["contact_C_heat_weighted"]),
            )
        )
        r = passes[-1].difference_K
        log.info("heat split: pinion share %.4f, contact temperatures differ by %+.2f K", f, r)
        if abs(r) < tol:
            split = HeatSplit(passes=tuple(passes), tolerance_K=tol)
            th = dict(th) | {"heat_split": split.to_json()}
            return th, others, snapshot
        if r < 0.0:  # r rises with f: the tightest bracket
            lo = f if lo is None else max(lo, f)
        else:
            hi = f if hi is None else min(hi, f)
        if len(passes) >= 2 and passes[-1].difference_K != passes[-2].difference_K:
            x, y = passes[-2], passes[-1]  # secant of the last two runs
            f = y.fraction_pinion - r * (y.fraction_pinion - x.fraction_pinion) / (
                y.difference_K - x.difference_K
            )
        else:  # the first step: the flashes' part of the slope
            slope = fr["pinion"]["flash_K_heat_weighted"] / f + fr["wheel"][
                "flash_K_heat_weighted"
            ] / (1.0 - f)
            f = f - r / slope
        if lo is not None and hi is not None and not min(lo, hi) < f < max(lo, hi):
            f = 0.5 * (lo + hi)  # bracketed, and the secant left the bracket: bisect
        f = min(max(f, SPLIT_MARGIN), 1.0 - SPLIT_MARGIN)
    raise ConvergenceError(
        "friction heat split by contact temperature",
        f"the gears' contact temperatures still differ by {passes[-1].difference_K:+.3g} K "
        f"(tolerance {tol:g} K) after {len(passes)} runs; pinion share per run: "
        + ", ".join(f"{p.fraction_pinion:.4f}" for p in passes),
        step=f"{case.operating.speed_rpm:g} rpm / {case.operating.torque_Nm:g} N m",
        iteration=len(passes),
    )


def _observed_once(
    case: Case,
    out: Path,
    comm: MPI.Comm,
    cycle_result=None,
    mesh_cache: Path | None = None,
    write_fields: bool = True,
    steady: bool = True,
    write_plot: bool = True,
    branch_search: bool = True,
    both: bool = False,
    friction_report: bool = False,
) -> tuple[dict[str, Any], dict[str, dict[str, Any]], FieldSnapshot | None]:
    """:func:`observed_thermal` with the case's split; ``both``: run both gears whatever the
    instruments read; ``friction_report``: the friction report in every summary."""
    # the modulus of the thermal state needs both gears' fields
    follows = modulus_follows_temperature(case)
    record = needs_fields(case.instruments) or follows
    both = both or follows
    main = case.thermal.body
    others = [b for b in (BODIES if both else instrument_bodies(case)) if b != main]
    bodies = [main] + (others if record or both else [])

    def one_gear(body: str, sub: MPI.Comm):
        c = case
        if body != main:
            c = dataclasses.replace(case, thermal=dataclasses.replace(case.thermal, body=body))
        return thermal_field(
            c,
            out / ("thermal" if body == main else f"thermal_{body}"),
            sub,
            cycle_result,
            mesh_cache,
            write_fields=write_fields,
            steady=steady,
            write_plot=write_plot,
            record=record,
            branch_search=branch_search,
            friction_report=friction_report,
        )

    # the gears' thermal models are independent and small (about 10^4 unknowns): on several
    # ranks, each gear on ranks of its own, at the same time
    runs = run_split(comm, bodies, one_gear)
    th = runs[main][0]
    fields = {b: runs[b][1] for b in bodies}
    others: dict[str, dict[str, Any]] = {b: runs[b][0] for b in bodies if b != main}
    snapshot = None
    if comm.rank == 0 and (record or case.instruments.torque.enabled):
        labels, times_s = _labels(fields.get(main), th, case)
        snapshot = FieldSnapshot(
            labels=labels,
            times_s=times_s,
            bodies={b: f for b, f in fields.items() if f is not None},
            pinion_speed_rpm=case.operating.speed_rpm,
            face_width_m=case.geometry.face_width_mm * 1e-3,
            ambient_C=case.thermal.ambient_C,
            torques=CycleTorques.of(cycle_result) if cycle_result is not None else None,
            case=case.name,
        )
    return th, others, snapshot


def _labels(field: BodyField | None, th: dict[str, Any], case: Case):
    """Labels and times of a snapshot: the recorded ones, or (no field kept) the end value."""
    if field is not None:
        return tuple(field.temperatures_C), tuple(
            _time_of(lab, case) for lab in field.temperatures_C
        )
    lab = "steady" if "steady_state_C" in th else "end"
    return (lab,), (_time_of(lab, case),)


def _time_of(label: str, case: Case) -> float | None:
    if label == "steady" or (label == "end" and case.thermal.mode == "steady"):
        return None
    if label == "end":
        return case.thermal.duration_s
    return float(label)


def _read_and_keep(
    instruments: InstrumentOptions, snapshot: FieldSnapshot, out: Path
) -> InstrumentReadings:
    """Save the snapshot and read the instruments on it, writing the thermograms (rank 0)."""
    out.mkdir(parents=True, exist_ok=True)
    if snapshot.bodies:
        snapshot.save(out / SNAPSHOT_NAME)
    return evaluate(instruments, snapshot, out, views_dir=camera_views_dir())


def camera_views_dir() -> Path:
    """Where the camera's phase views are stored between runs (``<cache>/camera_views``: a run
    of another operating point of the same case reads them instead of tracing the rays)."""
    return cache_root() / "camera_views"


SNAPSHOT_NAME = "snapshot.npz"
READINGS_NAME = "readings.json"


def observe(
    result_dir: str | Path,
    comm: MPI.Comm | None = None,
    instruments: InstrumentOptions | None = None,
    only: tuple[str, ...] | None = None,
    out_dir: str | Path | None = None,
) -> InstrumentReadings:
    """Read the instruments again on a finished run (``gearfem observe``), without solving: the
    case's instruments (or ``instruments``, e.g. another camera view) on the run's
    ``instruments/snapshot.npz``; ``only`` restricts to some of camera, probes, torque. Writes the
    thermograms and ``readings.json`` (last) into ``out_dir`` (default
    ``RESULT_DIR/instruments``). Collective; the work is done on rank 0."""
    comm = comm or MPI.COMM_WORLD
    result = Path(result_dir)
    if not comm.bcast((result / "summary.json").is_file(), root=0):
        raise ParameterError(
            "result directory", str(result), "the output directory of a finished gearfem run"
        )
    out = Path(out_dir) if out_dir is not None else result / "instruments"
    for name in only or ():
        if name not in INSTRUMENTS:
            raise ParameterError("--instrument", name, "one of " + ", ".join(INSTRUMENTS))

    def read() -> InstrumentReadings:
        case = load_case(result / "case.toml")
        ins = instruments if instruments is not None else case.instruments
        path = result / "instruments" / SNAPSHOT_NAME
        snapshot = FieldSnapshot.load(path)
        (out / READINGS_NAME).unlink(missing_ok=True)
        readings = evaluate(ins, snapshot, out, only=only, views_dir=camera_views_dir())
        write_json(out / READINGS_NAME, readings)  # last: marks a complete observation
        return readings

    return on_root(comm, read)


class _Recording:
    """Observer of a thermal run that keeps the field at the output times, the end (and, from
    :meth:`steady`, the steady state) for the instruments."""

    def __init__(self, recorder: FieldRecorder, options, model_fraction: float = 1.0) -> None:
        self.recorder, self.options, self.fraction = recorder, options, model_fraction

    def heat(self, balance) -> dict[str, float]:
        """The whole gear's friction and hysteresis heat of a step's balance (W)."""
        return {
            "friction_W": float(balance.friction_W) / self.fraction,
            "hysteresis_W": float(balance.hysteresis_W) / self.fraction,
        }

    def on_step(self, problem, record, write_field: bool) -> None:
        if not write_field:
            return
        temps = {k: v - ZERO_CELSIUS_K for k, v in record.temperatures_K.items()}
        heat = self.heat(record.balance)
        if self.options.mode == "steady":
            self.recorder.record("end", None, temps, heat)
            return
        t = record.time_s
        if t <= 0.0:
            return
        end = abs(t - self.options.duration_s) <= 1e-9 * max(1.0, t)
        self.recorder.record("end" if end else f"{t:g}", t, temps, heat)


@dataclasses.dataclass(frozen=True)
class ThermalSetup:
    """One gear's thermal problem of a case, with what it was built from
    (:func:`thermal_problem`)."""

    problem: ThermalProblem
    gear_mesh: Any
    domain: ThermalDomain
    boundary: ThermalBoundary
    profile: Any
    speed_rpm: float
    title: str


#: The thermal meshes and domains of the last runs (a diagnosis's runs of one case share them).
KEPT_DOMAINS: Kept[tuple[Any, ThermalDomain]] = Kept(4)


def thermal_domain(
    case: Case, body: str, comm: MPI.Comm, mesh_cache: Path | None, flux_flanks: str
) -> tuple[Any, ThermalDomain]:
    """The thermal mesh of ``body`` (that body only: balanced over the ranks) and its
    :class:`ThermalDomain`, built or kept from an earlier run on the same ranks with the same
    geometry, thermal mesh options, mesh cache and flux flanks (collective)."""
    key = (
        case.geometry,
        case.thermal_mesh_options,
        body,
        flux_flanks,
        None if mesh_cache is None else str(mesh_cache),
        members(comm),
    )

    def build() -> tuple[Any, ThermalDomain]:
        gm = build_gear_mesh(
            case.geometry, case.thermal_mesh_options, comm, cache_dir=mesh_cache, bodies=(body,)
        )
        return gm, ThermalDomain.from_gear_mesh(gm, body, flux_flanks=flux_flanks)

    return KEPT_DOMAINS.get(key, (), build)


def thermal_problem(
    case: Case, comm: MPI.Comm, cycle_result=None, mesh_cache: Path | None = None
) -> ThermalSetup:
    """The thermal problem of ``[thermal] body``: its mesh (that body only), boundary and heat
    sources (from ``cycle_result``, or prescribed), ready to solve (collective; the caller frees
    it, ``with setup.problem:``)."""
    body = case.thermal.body
    if body not in ("pinion", "wheel"):
        raise ParameterError("thermal.body", body, "'pinion' or 'wheel'")
    src = case.sources
    if src.mode == "cycle" and src.friction and src.heat_partition == "contact_temperature":
        # the split is solved over both gears' runs (split_by_contact_temperature), each of
        # which is a problem of this function with the split's share as a fixed fraction
        raise ParameterError(
            "sources.heat_partition",
            src.heat_partition,
            "'fixed' or 'blok' in a thermal problem of one gear (gearfem thermal)",
            "the split by contact temperature solves both gears' runs together: gearfem run",
        )
    gm, domain = thermal_domain(
        case, body, comm, mesh_cache, src.flanks if src.mode == "prescribed" else "drive"
    )
    material = case.materials[body]
    profile = gm.pair.profile(body)
    n1 = case.operating.speed_rpm
    speed = case.geometry.speed_rpm(body, n1)
    boundary = ThermalBoundary.from_options(case.thermal, material, speed, gear_radii(profile))
    if src.mode == "prescribed":
        sources = prescribed_heat_sources(src.prescribed(), domain, material, speed, profile.teeth)
        title = (
            f"{body}, {speed:g} rpm, {src.flank_heat_per_gear_W:g} W prescribed flank heat per gear"
        )
    else:
        if cycle_result is None:
            raise ParameterError(
                "sources.mode",
                "cycle",
                "a cycle result (run `gearfem cycle` or `gearfem run`) or mode = 'prescribed'",
            )
        sources = cycle_heat_sources(
            domain, gm, body, cycle_result, src, case.materials, n1, case.friction
        )
        title = (
            f"{body}, {n1:g} rpm, {case.operating.torque_Nm:g} N m (sources from the contact cycle)"
        )
    problem = ThermalProblem(
        domain, material, sources, boundary, case.thermal, petsc_options_prefix="gearfem_thermal_"
    )
    return ThermalSetup(problem, gm, domain, boundary, profile, speed, title)


def thermal_field(
    case: Case,
    out_dir: str | Path,
    comm: MPI.Comm,
    cycle_result=None,
    mesh_cache: Path | None = None,
    write_fields: bool = True,
    extra: dict[str, Any] | None = None,
    steady: bool = True,
    write_plot: bool = True,
    record: bool = False,
    branch_search: bool = True,
    friction_report: bool = False,
) -> tuple[dict[str, Any], BodyField | None]:
    """:func:`thermal`, and with ``record`` the body's field at the reported times gathered for
    the instruments (a :class:`~gearfem.instruments.snapshot.BodyField` on rank 0, None on the
    other ranks and without ``record``). ``branch_search=False`` skips the search for other steady
    states of a friction law whose heat may rise with temperature (:func:`friction_branches`;
    the temperatures, taken before it, are the same) and, without ``write_plot`` and
    ``friction_report``, the friction report: a caller that needs only the temperatures of the
    branch the transient reached, such as the diagnosis surrogate, saves three extra steady
    solves and the report. ``friction_report``: the friction report (contact temperatures) even
    without plots."""

    setup = thermal_problem(case, comm, cycle_result, mesh_cache)
    problem, gm, domain, boundary = setup.problem, setup.gear_mesh, setup.domain, setup.boundary
    body, src, profile, speed = case.thermal.body, case.sources, setup.profile, setup.speed_rpm
    title = setup.title
    info = {
        "title": title,
        "body": body,
        "speed_rpm": speed,
        "teeth": profile.teeth,
        "teeth_modelled": domain.teeth_modelled,
        "mesh_cache_key": gm.cache_key,
    }
    if src.mode == "cycle":
        info["friction_heat_fraction"] = src.heat_fractions(case.materials)[body]
    info.update(extra or {})

    recording = (
        _Recording(FieldRecorder(problem.T, domain), case.thermal, domain.model_fraction)
        if record
        else None
    )

    def more(records) -> dict[str, Any]:
        gen = records[-1].balance.generated_W
        out = {
            "generated_per_gear_W": gen / domain.model_fraction if math.isfinite(gen) else None,
            "lumped_estimate": lumped_estimate(problem, gen if math.isfinite(gen) else 0.0),
        }
        wanted = tuple(case.thermal.output_times_s)
        out["at_times_C"] = {
            f"{r.time_s:g}": {k: v - ZERO_CELSIUS_K for k, v in r.temperatures_K.items()}
            for r in records
            if any(abs(r.time_s - t) <= 1e-6 * max(1.0, t) for t in wanted)
        }
        # the state a run from ambient reaches: the transient's end, or in steady mode with a law
        # whose heat may rise the lowest steady state (gearfem.thermal.branches)
        reached = case.thermal.mode == "transient" or problem.sources.flank_flux_may_rise
        end = problem.T.x.array.copy() if reached else None
        friction = None
        # the friction report (maps, contact temperatures) of gearfem run, or of any other law;
        # not for a caller that skips the branch search and wants neither plots nor the report
        # (the diagnosis surrogate's runs: about 0.8 s a gear on the built-in case)
        if (
            cycle_result is not None
            and src.friction
            and (write_plot or friction_report or (branch_search and not case.friction.is_default))
        ):
            friction = friction_outputs(problem, gm, case, cycle_result, out_dir, write_plot)
        if case.thermal.mode == "transient" and steady:
            # the operating temperature if the run went on for ever
            rec, end, settled_s = steady_after_transient(problem, case)
            out["steady_state_C"] = {k: v - ZERO_CELSIUS_K for k, v in rec.temperatures_K.items()}
            out["steady_balance_W"] = rec.balance.as_dict()
            if settled_s is not None:
                out["transient_continued_to_s"] = settled_s
            if recording is not None:  # problem.T holds the steady state
                recording.recorder.record(
                    "steady", None, out["steady_state_C"], recording.heat(rec.balance)
                )
        if case.friction.cycle_mu == "law" and cycle_result is not None and src.friction:
            # the law's mu per contact band at the run's end value, for the next cycle
            out["contact_band_mu"] = contact_band_mu(problem, gm, case, cycle_result)
        if friction is not None:
            friction.update(friction_branches(problem, case, end, steady, branch_search))
            out["friction"] = friction
        return out

    with problem:  # frees the solvers collectively, also on failure
        _, summary = solve_and_write(
            problem,
            out_dir,
            extra=info,
            more=more,
            write_fields=write_fields,
            write_plot=write_plot,
            observers=() if recording is None else (recording,),
        )
    field = None
    if recording is not None:
        pl = placement(gm.pair, case.thermal_mesh_options, body)
        field = recording.recorder.body_field(
            body,
            pl.center_m,
            pl.tooth_angles_rad,
            profile.teeth,
            1 if body == "pinion" else -1,
            speed,
            boundary.exchanges()["teeth"].emissivity,
        )
    return summary, field


def case_friction_model(problem, gear_mesh, case: Case, cyc):
    """The case's friction law's flux on ``problem``'s gear (the sources' own model when they
    have one; collective)."""
    src, body = case.sources, case.thermal.body
    return friction_model(
        problem,
        gear_mesh,
        body,
        cyc,
        case.friction_law(),
        case.materials,
        case.operating.speed_rpm,
        src.heat_partition,
        src.heat_fractions(case.materials)[body],
        case.friction.contact_temperature,
        src.flux_reconstruction,
        case.friction.band_model,
    )


def contact_band_mu(problem, gear_mesh, case: Case, cyc) -> dict[str, list]:
    """The friction law's mu per band of the cycle's contact history that heats the gear of
    ``problem``, at its current temperature (collective): ``{"band": history band indices,
    "mu": [...]}``, what the next cycle of the fixed point in the cycle's mu takes
    (:func:`thermal_stages`)."""
    model = case_friction_model(problem, gear_mesh, case, cyc)
    band, mu = model.history_band_mu(evaluate_at(problem, model))
    return {"band": [int(b) for b in band], "mu": [float(m) for m in mu]}


def friction_outputs(
    problem, gear_mesh, case: Case, cyc, out_dir: str | Path, write_plot: bool
) -> dict[str, Any]:
    """The friction of the run at its last state (any law): heat, mu, contact and flash
    temperatures, Peclet numbers; the flank maps (``friction_maps.png``, when plotting)."""
    body = case.thermal.body
    model = case_friction_model(problem, gear_mesh, case, cyc)
    state = evaluate_at(problem, model)
    out = friction_summary(model, state)
    maps = flank_maps(model, state, gear_mesh.center(body))
    if write_plot and problem.comm.rank == 0:
        plot_flank_maps(maps, Path(out_dir) / "friction_maps.png", out["law"])
    return out


def steady_after_transient(problem, case: Case):
    """The steady state from the end of the transient: (record, the transient's end field, the
    time the transient had to be continued to, or None). A friction law whose heat may rise with
    temperature can leave the transient between branches: just past the fold of the cool branch
    the transient creeps through a bottleneck (seen: 600 rpm / 8 N m, glassy mu 0.2, the hottest
    node rising 106 -> 112 -> 122 -> 142 C over 1860-12660 s) and Newton from there finds no
    steady state.
    The transient is then continued, by max(duration, 1800 s) doubled each time (at most
    :data:`STEADY_CONTINUATIONS` times: 63 durations, 31 h of running at the default), until the
    steady solve from its end converges; the branch it reaches is the physical one. A transient
    still moving after that is a runaway (collective)."""
    end = problem.T.x.array.copy()
    try:
        return problem.solve_steady(), end, None
    except ConvergenceError:
        if not case.friction_law().may_rise_with_temperature:
            raise
    start_s = problem.time_s
    for k in range(STEADY_CONTINUATIONS):
        # the failed solve changed T only; the transient's history is intact
        log.info("no steady state from t = %g s yet: continuing the transient", problem.time_s)
        span = max(case.thermal.duration_s, 1800.0) * 2**k
        problem.integrate(duration_s=problem.time_s + span)
        end = problem.T.x.array.copy()
        try:
            return problem.solve_steady(), end, problem.time_s
        except ConvergenceError:
            continue
    raise ConvergenceError(
        "thermal Newton",
        "no steady state from the transient's end (a runaway, or a transient that had not "
        f"settled after {problem.time_s - start_s:g} s more)",
        step=f"transient continued to t = {problem.time_s:g} s",
    )


def friction_branches(
    problem, case: Case, transient_end, steady: bool, search: bool = True
) -> dict[str, Any]:
    """Where the law's heat may rise with temperature: the steady states from a cold, the
    transient's and a hot start, with their stability, and which one the transient picked
    (``steady`` and ``search``: a steady state was asked for, and the caller wants the search)."""
    law = case.friction_law()
    if not law.may_rise_with_temperature:
        return {"branch_search": "not needed: the friction heat cannot rise with temperature"}
    if not (steady and search):
        return {
            "branch_search": "not done: "
            + ("skipped by the caller" if steady else "no steady state asked for")
        }
    found = steady_states(problem, branch_starts(problem, law, transient_end))
    distinct = [s for s in found if s.converged and s.same_as is None]
    picked = next((s for s in found if s.start == "transient"), None)
    if picked is not None and picked.converged:
        picked_name = picked.same_as or picked.start
    else:
        picked_name = None
    if len(distinct) > 1:
        log.warning(
            "several steady states at %g rpm / %g N m: %s; the transient from ambient picked %s",
            case.operating.speed_rpm,
            case.operating.torque_Nm,
            ", ".join(
                f"{s.start} ({s.temperatures_C['max_surface']:.1f} C, "
                f"{'stable' if s.stable else 'unstable'})"
                for s in distinct
            ),
            picked_name,
        )
    return {
        "branches": [s.to_json() for s in found],
        "distinct_steady_states": len(distinct),
        "transient_branch": picked_name,
    }


def baselines(case: Case) -> dict[str, Any]:
    """VDI 2736, Mao, Blok and Hertz/ISO numbers for the case's operating point."""

    g = case.geometry
    pair = GearPair(g)
    opts = case.baselines
    if opts.rack_fillet_coef is None:  # the gear's own fillet, where the standard rack can carry it
        rho = min(
            g.root_fillet_coefficient,
            max_rack_fillet_coef(g.pressure_angle_deg, opts.rack_dedendum_coef),
        )
        opts = dataclasses.replace(opts, rack_fillet_coef=rho)
    return baseline_summary(
        speed_rpm=case.operating.speed_rpm,
        torque_Nm=case.operating.torque_Nm,
        mu=case.contact.friction_coefficient,
        teeth1=g.teeth_pinion,
        teeth2=g.teeth_wheel,
        module_m=g.module_mm * 1e-3,
        pressure_angle_deg=g.pressure_angle_deg,
        face_width_m=g.face_width_mm * 1e-3,
        tip_radius1_m=pair.pinion.tip_radius_m,
        tip_radius2_m=pair.wheel.tip_radius_m,
        centre_distance_m=pair.center_distance_m,
        ambient_C=case.thermal.ambient_C,
        material1=case.materials["pinion"],
        material2=case.materials["wheel"],
        options=opts,
    )


def run(
    case: Case,
    out_dir: str | Path,
    comm: MPI.Comm | None = None,
    mesh_cache: Path | None = None,
    cache_dir: Path | None = None,
    progress: bool = True,
    write_fields: bool = True,
) -> RunSummary:
    """The whole chain for one operating point; returns the summary (collective).

    ``write_fields``: write the VTX temperature fields (studies switch them off)."""
    comm = comm or MPI.COMM_WORLD
    check_instruments(case)  # a camera that cannot see the gears fails before any solve
    out = prepare_output(out_dir, "summary.json", comm)
    times: dict[str, float] = {}
    t0 = time.perf_counter()
    stages = thermal_stages(
        case, out, comm, mesh_cache, cache_dir, progress=progress, write_fields=write_fields
    )
    cyc, cdir, cached = stages.cycle, stages.cycle_dir, stages.cycle_cached
    th, others, snapshot = stages.thermal, stages.others, stages.snapshot
    if cyc is not None:
        times["cycle_s"] = stages.cycle_s
        if comm.rank == 0:
            write_cycle_outputs(cyc, out / "cycle")
        comm.barrier()
    times["thermal_s"] = stages.thermal_s
    readings = None
    if comm.bcast(snapshot is not None, root=0):  # the snapshot lives on rank 0
        t2 = time.perf_counter()
        readings = on_root(
            comm, lambda: _read_and_keep(case.instruments, snapshot, out / "instruments")
        )
        times["instruments_s"] = time.perf_counter() - t2
    base = baselines(case)
    times["total_s"] = time.perf_counter() - t0
    at_speed = None
    if cyc is not None:
        at_speed = CycleAtSpeed.of(cyc, case.operating.speed_rpm, CycleCache(str(cdir), cached))
    field_max = surface_field_max(snapshot, case.thermal.body, comm)
    reported = reported_quantities(th, at_speed, readings, field_max)
    unc = run_uncertainty(case, {q: v for q, (v, _) in reported.items()})
    summary = RunSummary(
        case=case.name,
        speed_rpm=case.operating.speed_rpm,
        torque_Nm=case.operating.torque_Nm,
        thermal=th,
        baselines=base,
        wall_time_s=times,
        mpi_size=comm.size,
        cycle=at_speed,
        headline=headline(
            th, base, at_speed, unc, case.thermal.ambient_C, readings, field_max, case.thermal.body
        ),
        numerical_uncertainty=unc,
        instruments=readings,
        thermal_other=next(iter(others.values()), None),
        provenance=dataclasses.asdict(provenance(case)),
        cycle_mu=stages.cycle_mu,
        heat_split=HeatSplit.from_json(th["heat_split"]) if "heat_split" in th else None,
        modulus=stages.modulus,
    )
    vers = versions(comm)
    if comm.rank == 0:
        write_case(case, out / "case.toml")
        write_json(out / "versions.json", vers)
        write_json(out / "summary.json", summary)  # last: marks a complete run
    comm.barrier()
    return summary


def case_at_cycle_mu(case: Case, mu: float) -> Case:
    """``case`` with its structural cycle solved at ``mu`` and the same friction law (the law's
    defaults that follow the cycle's mu pinned to the case's, :meth:`FrictionOptions.pinned_to`)."""
    return dataclasses.replace(
        case,
        contact=dataclasses.replace(case.contact, friction_coefficient=float(mu)),
        friction=case.friction.pinned_to(case.contact.friction_coefficient),
    )


def modulus_follows_temperature(case: Case) -> bool:
    """Whether the case's cycle takes its modulus from the thermal state (``[cycle] modulus =
    "thermal_state"`` with heat sources from the cycle)."""
    return case.sources.mode == "cycle" and case.cycle.modulus == "thermal_state"


def modulus_tables(case: Case) -> dict[str, TemperatureTable]:
    """Each polymer gear's E(T): its material's own ``modulus_table``, else the materials library's
    table of its ``name`` (a steel gear keeps its constant modulus). A ParameterError when a
    polymer gear has neither (``[cycle] modulus = "thermal_state"`` needs one) and when a steel
    gear is given a ``modulus_table``; each names the case table to set."""
    tables = {}
    for b in BODIES:
        mat = case.materials[b]
        key = "material_wheel" if b == "wheel" and case.material_wheel is not None else "material"
        lib = library_material(mat.name, f"{key}.name")
        if lib.kind == "steel":
            if mat.modulus_table is not None:
                raise ParameterError(
                    f"{key}.modulus_table",
                    mat.modulus_table,
                    "none",
                    f"the {b}'s {lib.name} keeps its constant youngs_modulus_Pa",
                )
            continue
        own = mat.modulus_of_temperature()
        if own is not None:
            tables[b] = own
            continue
        table = lib.tables.get("youngs_modulus_Pa")
        if table is None:
            with_table = [
                n
                for n in library_names()
                if library_material(n).kind != "steel"
                and "youngs_modulus_Pa" in library_material(n).tables
            ]
            raise ParameterError(
                "cycle.modulus",
                "thermal_state",
                f"an E(T) of the {b}: [{key}] modulus_table = [[T_C...], [E_Pa...]], or a "
                "polymer with an E(T) table in the materials library ("
                + ", ".join(with_table)
                + ")",
                f"the {b}'s {lib.name} has none in the library and [{key}] gives no "
                'modulus_table; or set modulus = "constant" and its youngs_modulus_Pa at the '
                "running temperature",
            )
        tables[b] = table.table()
    return tables


def state_modulus_field(snapshot: FieldSnapshot, tables: dict[str, TemperatureTable]):
    """The modulus field of the gears in ``tables`` at the snapshot's end value (the steady state
    when the run computed one)."""
    i = snapshot.label_index(snapshot.label_of(None))
    states = {}
    for b in tables:
        f = snapshot.bodies[b]
        states[b] = GearTemperature(
            f.nodes_m, f.cells, f.temperature_K[i], f.center_m, f.tooth_angles_rad
        )
    return ModulusField.from_temperatures(states, tables)


def thermal_stages(
    case: Case,
    out: Path,
    comm: MPI.Comm,
    mesh_cache: Path | None = None,
    cache_dir: Path | None = None,
    progress: bool = True,
    write_fields: bool = True,
    steady: bool = True,
    write_plot: bool = True,
    start_mu: float | None = None,
    on_pass=None,
) -> ThermalStages:
    """The structural cycle (cached) and the thermal runs on it (:func:`observed_thermal`), with
    the cycle's mu as ``[friction] cycle_mu`` says (collective).

    ``"constant"``: one cycle at ``contact.friction_coefficient``. ``"effective"`` and ``"law"``:
    the cycle ↔ heat fixed point. Pass k solves the cycle at mu_k (mu_0 = ``start_mu``, default the
    case's mu, everywhere), the thermal runs on it, and reads at their end value (the steady state
    when the run computes one) the law's effective mu, mu_eff = m_k P_law / P_cycle: P_law the
    friction heat of both gears' models at that state (the torque meters' reading), P_cycle the
    cycle's own friction power, m_k the constant mu that dissipates it (mu_k with one mu, the
    heat-weighted mean of the band field with a mu per contact). ``"effective"`` solves the next
    cycle at mu_eff everywhere and stops when |mu_eff − mu_k| < ``cycle_mu_tolerance``.
    ``"law"`` solves it with the law's mu at each contact band
    (:class:`~gearfem.cycle.friction_field.FrictionField`, each gear's pass at that gear's contact
    temperature; ``contact.friction_coefficient`` set to mu_eff, the mu where the field has no
    band) and stops when the law's mu at the bands has moved by less than the
    tolerance, on heat-weighted mean, from the mu the cycle had there. Every mu is rounded to
    :attr:`~gearfem.contact.friction.FrictionOptions.cycle_mu_step`; the last pass is the run's; not
    converged after ``cycle_mu_max_passes`` cycles raises ConvergenceError with the passes' mu. Each
    cycle is stored under its own mu (the cycle's key holds the contact options and the field's
    digest). ``on_pass(k, case_k, stages_k, pass_k)`` is called after every pass (a study reads more
    of each).

    With ``[cycle] modulus = "thermal_state"`` the same passes carry the modulus: pass k's cycle
    takes the modulus field of pass k − 1's thermal state (:mod:`gearfem.cycle.modulus_field`;
    pass 0 the constant modulus), until no cell's relative modulus moves by
    ``modulus_tolerance`` or more (:class:`ModulusLoop`); the run ends when every loop has
    settled, and a loop not settled after its passes raises ConvergenceError."""
    f = case.friction
    loop_mu = case.sources.mode == "cycle" and f.cycle_mu != "constant"
    per_contact = loop_mu and f.cycle_mu == "law"
    mu = case.contact.friction_coefficient if start_mu is None else float(start_mu)
    if loop_mu and start_mu is not None:
        mu = f.rounded_cycle_mu(mu)
    field: FrictionField | None = None
    passes: list[CycleMuPass] = []
    follows = modulus_follows_temperature(case)
    tables = modulus_tables(case) if follows else {}
    moduli: ModulusField | None = None
    moduli_passes: list[ModulusPass] = []
    cycle_s = thermal_s = 0.0  # over every pass
    n_passes = max(
        f.cycle_mu_max_passes if loop_mu else 1, case.cycle.modulus_max_passes if follows else 1
    )
    for k in range(n_passes):
        c = case_at_cycle_mu(case, mu) if loop_mu else case
        t0 = time.perf_counter()
        cyc, cdir, cached = None, None, False
        if c.sources.mode == "cycle":
            with ProgressBar(comm) as bar:
                cyc, cdir, cached = cycle(
                    c,
                    comm,
                    mesh_cache,
                    cache_dir,
                    progress=bar.update if progress else None,
                    friction_field=field,
                    moduli=moduli,
                )
        t1 = time.perf_counter()
        th, others, snapshot = observed_thermal(
            c, out, comm, cyc, mesh_cache, write_fields=write_fields, steady=steady,
            write_plot=write_plot,
        )  # fmt: skip
        t2 = time.perf_counter()
        cycle_s, thermal_s = cycle_s + (t1 - t0), thermal_s + (t2 - t1)
        loop = None
        if loop_mu:
            reading = on_root(
                comm,
                lambda: read_torque(
                    c.instruments.torque,
                    CycleTorques.of(cyc),
                    c.operating.speed_rpm,
                    heat=snapshot.mesh_heat_W(snapshot.label_of(None)),
                ),
            )
            new_field = field_change = field_max = band_range = None
            if per_contact:
                new_field = law_field(cyc, {c.thermal.body: th, **others}, f.cycle_mu_step)
                field_change, field_max = new_field.change_from(field if field is not None else mu)
                band_range = (float(np.min(new_field.mu)), float(np.max(new_field.mu)))
            mu_mean = cyc.mean_friction_coefficient()
            passes.append(
                CycleMuPass(
                    mu_cycle=mu,
                    mu_effective=reading.effective_mu(mu_mean),
                    friction_power_law_W=reading.friction_power_W,
                    friction_power_cycle_W=reading.cycle_friction_power_W,
                    cycle_key=case_cycle_key(c, field, moduli),
                    wall_time_s=t2 - t0,
                    field_change=field_change,
                    field_change_max=field_max,
                    mu_band_range=band_range,
                    mu_cycle_mean=mu_mean,
                )
            )
            loop = CycleMuLoop(passes=tuple(passes), tolerance=f.cycle_mu_tolerance)
            log.info(
                "cycle mu pass %d: cycle mu %.4f (mean %.4f), the law's effective mu %.4f "
                "(change %+.4f)%s",
                k, mu, mu_mean, passes[-1].mu_effective, passes[-1].mu_effective - mu_mean,
                "" if band_range is None else (
                    f"; the law's mu per band {band_range[0]:.4f}-{band_range[1]:.4f}, moved by "
                    f"{field_change:.4f} on heat-weighted mean, at most {field_max:.4f}"
                ),
            )  # fmt: skip
        moduli_loop, new_moduli = None, None
        if follows:
            new_moduli = on_root(comm, lambda: state_modulus_field(snapshot, tables))
            change, change_max = new_moduli.change_from(moduli)
            rel = lambda m: tuple(m.mean_relative(b) if m is not None else 1.0 for b in BODIES)
            moduli_passes.append(
                ModulusPass(
                    relative_cycle=rel(moduli),
                    relative_state=rel(new_moduli),
                    change=change,
                    change_max=change_max,
                    beyond_table=tuple(
                        new_moduli.bodies[b].beyond_table if b in new_moduli.bodies else 0.0
                        for b in BODIES
                    ),
                    cycle_key=case_cycle_key(c, field if loop_mu else None, moduli),
                    wall_time_s=t2 - t0,
                )
            )
            moduli_loop = ModulusLoop(tuple(moduli_passes), case.cycle.modulus_tolerance)
            log.info(
                "modulus pass %d: mean relative modulus pinion, wheel %.4f, %.4f in the cycle, "
                "%.4f, %.4f at its thermal state (change %.4f, a cell's at most %.4f)",
                k, *moduli_passes[-1].relative_cycle, *moduli_passes[-1].relative_state,
                change, change_max,
            )  # fmt: skip
        if loop_mu:
            field = new_field
        stages = ThermalStages(
            c, cyc, cdir, cached, th, others, snapshot, loop, cycle_s, thermal_s, moduli_loop
        )
        if on_pass is not None:
            on_pass(k, c, stages, passes[-1] if passes else None)
        mu_done = not loop_mu or abs(passes[-1].change) < f.cycle_mu_tolerance
        modulus_done = not follows or moduli_passes[-1].change_max < case.cycle.modulus_tolerance
        if mu_done and modulus_done:
            return stages
        if loop_mu and len(passes) >= f.cycle_mu_max_passes and not mu_done:
            break
        if follows and len(moduli_passes) >= case.cycle.modulus_max_passes and not modulus_done:
            break
        if loop_mu:
            mu = f.rounded_cycle_mu(passes[-1].mu_effective)
        moduli = new_moduli
    where = f"{case.operating.speed_rpm:g} rpm / {case.operating.torque_Nm:g} N m"
    if loop_mu and abs(passes[-1].change) >= f.cycle_mu_tolerance:
        raise ConvergenceError(
            "cycle <-> heat fixed point in the cycle's mu",
            f"the law's mu still moved by {passes[-1].change:+.4g} (tolerance "
            f"{f.cycle_mu_tolerance:g}) after {len(passes)} cycles; cycle mu per pass: "
            + ", ".join(f"{p.mu_cycle:.4f}" for p in passes),
            step=where,
            iteration=len(passes),
        )
    raise ConvergenceError(
        "cycle <-> heat fixed point in the modulus",
        f"a cell's relative modulus still moved by {moduli_passes[-1].change_max:.4g} "
        f"(tolerance {case.cycle.modulus_tolerance:g}) after {len(moduli_passes)} cycles; "
        "the gears' mean relative modulus, pinion, wheel per pass: "
        + ", ".join(
            f"({p.relative_state[0]:.4f}, {p.relative_state[1]:.4f})" for p in moduli_passes
        ),
        step=where,
        iteration=len(moduli_passes),
    )


def law_field(cyc, summaries: dict[str, dict[str, Any]], step: float) -> FrictionField:
    """The friction field of the law's mu per contact band that the gears' thermal summaries
    hold (``"contact_band_mu"``, :func:`contact_band_mu`) on the cycle ``cyc``'s history."""
    band, mu = [], []
    for body in BODIES:
        if body not in summaries or "contact_band_mu" not in summaries[body]:
            raise ParameterError(
                "friction.cycle_mu",
                "law",
                "thermal runs of both gears with the law's mu per contact band "
                "(the torque meters enabled)",
                f"the {body}'s run has none",
            )
        got = summaries[body]["contact_band_mu"]
        band.extend(got["band"])
        mu.extend(got["mu"])
    centres = {b: np.asarray(v) for b, v in cyc.info["centres_m"].items()}
    return FrictionField.from_bands(cyc.history, centres, np.array(band), np.array(mu), step)


def headline(
    thermal: dict[str, Any],
    baselines: dict[str, Any],
    cycle: CycleAtSpeed | None,
    uncertainty: RunUncertainty | None = None,
    ambient_C: float | None = None,
    readings: InstrumentReadings | None = None,
    surface_field_max_C: float | None = None,
    body: str = "pinion",
) -> Headline:
    """The headline numbers of a run from its stage summaries (with u_num where a refinement
    study of the case's resolution is stored); ``surface_field_max_C``: see
    :func:`surface_field_max`; ``body``: the gear of ``thermal`` (its baselines are quoted)."""
    gear = {"pinion": 1, "wheel": 2}[body]
    final = thermal.get("final_temperatures_C", {})
    u_num = None
    if uncertainty is not None:
        u_num = {}
        for field, q in (
            ("max_surface_temperature_C", "max_surface"),
            ("max_surface_field_C", "max_surface_field"),
            ("mean_bulk_temperature_C", "mean_bulk"),
            ("friction_power_W", "friction_power_W"),
            ("effective_contact_ratio", "effective_contact_ratio"),
            ("camera_max_C", "camera_max"),
            ("torque_loss_Nm", "torque_loss_Nm"),
        ):
            if uncertainty.u_num(q) is not None:
                u_num[field] = uncertainty.u_num(q)
        u_end = uncertainty.u_num("max_surface")
        rise_end = final.get("max_surface", math.nan) - (ambient_C or 0.0)
        if u_end is not None and rise_end > 0.0:  # earlier times: scaled by the rise
            for t, v in thermal.get("at_times_C", {}).items():
                if v.get("max_surface") is not None:
                    rise = v["max_surface"] - (ambient_C or 0.0)
                    u_num[f"at_times_max_surface_C[{t}]"] = u_end * abs(rise) / rise_end
    cam = readings.camera if readings is not None else {}
    return Headline(
        time_s=thermal.get("time_s"),
        max_surface_temperature_C=final.get("max_surface"),
        max_surface_field_C=surface_field_max_C,
        mean_bulk_temperature_C=final.get("mean_bulk"),
        steady_max_surface_temperature_C=thermal.get("steady_state_C", {}).get("max_surface"),
        at_times_max_surface_C={
            t: v.get("max_surface") for t, v in thermal.get("at_times_C", {}).items()
        },
        friction_power_W=cycle.friction_power_W if cycle is not None else None,
        effective_contact_ratio=cycle.effective_contact_ratio if cycle is not None else None,
        vdi2736_flank_C=baselines.get(f"vdi2736_flank{gear}_C"),
        vdi2736_root_C=baselines.get(f"vdi2736_root{gear}_C"),
        mao_bulk_C=baselines.get(f"mao_bulk{gear}_C"),
        flash_max_K=baselines.get("flash_max_K"),
        u_num=u_num,
        friction_heat_per_gear_W=_per_gear(thermal, "friction_W"),
        steady_states_found=thermal.get("friction", {}).get("distinct_steady_states"),
        camera_max_C=cam["end"].max_C if "end" in cam else None,
        camera_max_steady_C=cam["steady"].max_C if "steady" in cam else None,
        camera_max_at_times_C={k: v.max_C for k, v in cam.items() if k not in ("end", "steady")}
        or None,
        torque_loss_Nm=(
            readings.torque.torque_loss_Nm
            if readings is not None and readings.torque is not None
            else None
        ),
    )


def _per_gear(thermal: dict[str, Any], key: str) -> float | None:
    val = thermal.get("final_balance_W", {}).get(key)
    frac = thermal.get("model_fraction")
    return val / frac if val is not None and frac else None


def read_case(path: str | Path | None):
    """The :class:`gearfem.config.Case` of a TOML file (``None``: the built-in thesis case)."""
    return load_case(path)


def run_thermal_case(
    case, out_dir: str | Path, cache_dir: str | Path | None = None, comm=None
) -> dict[str, Any]:
    """Run the thermal stage of a :class:`gearfem.config.Case` and write its outputs; return the
    summary."""
    comm = comm or MPI.COMM_WORLD
    cyc = None
    if case.sources.mode == "cycle":
        directory = case_cycle_dir(case)
        if not comm.bcast((directory / "cycle.json").exists(), root=0):
            raise ParameterError(
                "sources.mode",
                "cycle",
                f"a stored cycle for this case ({directory}); run "
                "`gearfem cycle CASE.toml` or `gearfem run` first, or set mode = 'prescribed'",
            )
        cyc = load_cycle(directory)
    return thermal(case, out_dir, comm, cyc, mesh_cache=Path(cache_dir) if cache_dir else None)
