"""The whole chain for one case: geometry → contact cycle → heat sources → thermal → baselines.

Each stage has one product and a cache: the pair mesh (``meshes/cache``), the structural cycle per
torque (``cache/cycles``; speed-independent), and the thermal run per operating point (written to
the output directory). :func:`run` is what ``gearfem run`` and ``./dev.sh run`` execute; it writes
``summary.json`` (last, so a failed run leaves none), the resolved case and versions
(``case.toml``, ``versions.json``), the cycle histories and plots, the thermal history, plots and
fields.
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
from gearfem.core.log import ProgressBar
from gearfem.core.materials import ZERO_CELSIUS_K
from gearfem.core.provenance import versions
from gearfem.core.results import JsonRecord
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
from gearfem.cycle.model import GearContactModel
from gearfem.cycle.report import write_cycle_outputs
from gearfem.geometry.involute import GearPair
from gearfem.geometry.mesh import build_gear_mesh
from gearfem.geometry.options import BODIES
from gearfem.thermal.boundary import ThermalBoundary
from gearfem.thermal.branches import steady_states
from gearfem.thermal.domain import ThermalDomain
from gearfem.thermal.lumped import gear_radii, lumped_estimate
from gearfem.thermal.outputs import solve_and_write
from gearfem.thermal.problem import ThermalProblem
from gearfem.thermal.source_terms import prescribed_heat_sources
from gearfem.uncertainty import RunUncertainty, run_uncertainty

log = logging.getLogger(__name__)


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

    @classmethod
    def of(cls, cyc, speed_rpm: float, cache: CycleCache | None = None) -> CycleAtSpeed:
        omega = 2.0 * math.pi * speed_rpm / 60.0
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
    vdi2736_flank1_C: float | None = None
    vdi2736_root1_C: float | None = None
    mao_bulk1_C: float | None = None
    flash_max_K: float | None = None
    # numerical standard uncertainty (K, W, -) of the fields above that have one, by field name,
    # from the refinement studies stored for the case's resolution (gearfem.uncertainty)
    u_num: dict[str, float] | None = None
    # the friction law's heat into the modelled gear at the end of the run (W per gear) and the
    # steady states the branch search found (None: not searched, the heat cannot rise with T)
    friction_heat_per_gear_W: float | None = None
    steady_states_found: int | None = None


@dataclasses.dataclass(frozen=True)
class RunSummary(JsonRecord):
    """What ``gearfem run`` computes for one operating point (``summary.json``, written last).

    ``thermal`` is the thermal stage's summary (``thermal/thermal_summary.json``) and
    ``baselines`` the analytic estimates (:func:`gearfem.baselines.baseline_summary`).
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

    @classmethod
    def read(cls, path: str | Path) -> RunSummary:
        return cls.from_json(read_json(Path(path)))


def pair_mesh(case: Case, comm: MPI.Comm, cache_dir: Path | None = None):
    return build_gear_mesh(case.geometry, case.mesh, comm, cache_dir=cache_dir, bodies=BODIES)


def case_cycle_key(case: Case) -> str:
    return cycle_key(
        case.geometry,
        case.mesh,
        case.materials,
        case.contact,
        case.cycle,
        case.operating.torque_Nm,
    )


def case_compliance_context(case: Case) -> str:
    """The part of the gear-compliance store key that comes from the case (mesh, elastic
    constants, code); the store adds each gear's contact DOFs and supports."""
    return compliance_context(case.geometry, case.mesh, case.materials)


def cycle(
    case: Case,
    comm: MPI.Comm,
    mesh_cache: Path | None = None,
    cache_dir: Path | None = None,
    rebuild: bool = False,
    progress=None,
):
    """The structural cycle of the case's torque (cached). Returns (CycleResult, directory,
    from_cache)."""

    def factory():
        gm = pair_mesh(case, comm, mesh_cache)
        return GearContactModel(
            gm,
            case.materials,
            case.contact,
            case.operating.torque_Nm,
            case.cycle,
            compliance_store=compliance_store(case.geometry, case.mesh, case.materials, cache_dir),
        )

    return cached_cycle(
        factory,
        case_cycle_key(case),
        comm,
        cache_dir=cache_dir,
        rebuild=rebuild,
        progress=progress,
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

    body = case.thermal.body
    if body not in ("pinion", "wheel"):
        raise ParameterError("thermal.body", body, "'pinion' or 'wheel'")
    # the thermal model meshes only its body: balanced over the ranks
    gm = build_gear_mesh(
        case.geometry, case.thermal_mesh_options, comm, cache_dir=mesh_cache, bodies=(body,)
    )
    src = case.sources
    domain = ThermalDomain.from_gear_mesh(
        gm, body, flux_flanks=src.flanks if src.mode == "prescribed" else "drive"
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
        end = problem.T.x.array.copy() if case.thermal.mode == "transient" else None
        friction = None
        # the friction report (maps, contact temperatures) of gearfem run, or of any other law
        if (
            cycle_result is not None
            and src.friction
            and (write_plot or not case.friction.is_default)
        ):
            friction = friction_outputs(problem, gm, case, cycle_result, out_dir, write_plot)
        if case.thermal.mode == "transient" and steady:
            # the operating temperature if the run went on for ever
            rec, end, settled_s = steady_after_transient(problem, case)
            out["steady_state_C"] = {k: v - ZERO_CELSIUS_K for k, v in rec.temperatures_K.items()}
            out["steady_balance_W"] = rec.balance.as_dict()
            if settled_s is not None:
                out["transient_continued_to_s"] = settled_s
        if friction is not None:
            friction.update(friction_branches(problem, case, end, steady))
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
        )
    return summary


def friction_outputs(
    problem, gear_mesh, case: Case, cyc, out_dir: str | Path, write_plot: bool
) -> dict[str, Any]:
    """The friction of the run at its last state (any law): heat, mu, contact and flash
    temperatures, Peclet numbers; the flank maps (``friction_maps.png``, when plotting)."""
    src, body = case.sources, case.thermal.body
    model = friction_model(
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
    )
    state = evaluate_at(problem, model)
    out = friction_summary(model, state)
    maps = flank_maps(model, state, gear_mesh.center(body))
    if write_plot and problem.comm.rank == 0:
        plot_flank_maps(maps, Path(out_dir) / "friction_maps.png", out["law"])
    return out


def steady_after_transient(problem, case: Case):
    """The steady state from the end of the transient: (record, the transient's end field, the
    time the transient had to be continued to, or None). A friction law whose heat may rise with
    temperature can leave the transient between branches (a runaway under way): Newton from there
    may find no steady state, so the transient is continued (by its duration and at least 1800 s,
    three times at most) until the steady solve from its end converges; the branch it reaches is
    the physical one (collective)."""
    end = problem.T.x.array.copy()
    try:
        return problem.solve_steady(), end, None
    except ConvergenceError:
        if not case.friction_law().may_rise_with_temperature:
            raise
    for _ in range(3):
        # the failed solve changed T only; the transient's history is intact
        log.info("no steady state from t = %g s yet: continuing the transient", problem.time_s)
        problem.integrate(duration_s=problem.time_s + max(case.thermal.duration_s, 1800.0))
        end = problem.T.x.array.copy()
        try:
            return problem.solve_steady(), end, problem.time_s
        except ConvergenceError:
            continue
    raise ConvergenceError(
        "thermal Newton",
        "no steady state from the transient's end",
        step=f"transient continued to t = {problem.time_s:g} s",
    )


def friction_branches(problem, case: Case, transient_end, steady: bool) -> dict[str, Any]:
    """Where the law's heat may rise with temperature: the steady states from a cold, the
    transient's and a hot start, with their stability, and which one the transient picked."""
    law = case.friction_law()
    if not (steady and law.may_rise_with_temperature):
        return {"branch_search": "not needed: the friction heat cannot rise with temperature"}
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
    out = prepare_output(out_dir, "summary.json", comm)
    times: dict[str, float] = {}
    t0 = time.perf_counter()
    cyc = None
    if case.sources.mode == "cycle":
        with ProgressBar(comm) as bar:
            cyc, cdir, cached = cycle(
                case, comm, mesh_cache, cache_dir, progress=bar.update if progress else None
            )
        times["cycle_s"] = time.perf_counter() - t0
        if comm.rank == 0:
            write_cycle_outputs(cyc, out / "cycle")
        comm.barrier()
    t1 = time.perf_counter()
    th = thermal(case, out / "thermal", comm, cyc, mesh_cache, write_fields=write_fields)
    times["thermal_s"] = time.perf_counter() - t1
    base = baselines(case)
    times["total_s"] = time.perf_counter() - t0
    at_speed = None
    if cyc is not None:
        at_speed = CycleAtSpeed.of(cyc, case.operating.speed_rpm, CycleCache(str(cdir), cached))
    unc = run_uncertainty(case, {q: v for q, (v, _) in reported_quantities(th, at_speed).items()})
    summary = RunSummary(
        case=case.name,
        speed_rpm=case.operating.speed_rpm,
        torque_Nm=case.operating.torque_Nm,
        thermal=th,
        baselines=base,
        wall_time_s=times,
        mpi_size=comm.size,
        cycle=at_speed,
        headline=headline(th, base, at_speed, unc, case.thermal.ambient_C),
        numerical_uncertainty=unc,
    )
    vers = versions(comm)
    if comm.rank == 0:
        write_case(case, out / "case.toml")
        write_json(out / "versions.json", vers)
        write_json(out / "summary.json", summary)  # last: marks a complete run
    comm.barrier()
    return summary


def reported_quantities(
    thermal: dict[str, Any], cycle: CycleAtSpeed | None
) -> dict[str, tuple[float, str]]:
    """The quantities a run reports and a refinement study follows, name -> (value, unit): every
    temperature of the thermal summary at the end of the run and, with a cycle, its friction
    power, effective contact ratio, pitch-point and largest pressures and mean transmission
    error."""
    out = {q: (v, "C") for q, v in thermal.get("final_temperatures_C", {}).items()}
    if cycle is not None:
        out.update(
            friction_power_W=(cycle.friction_power_W, "W"),
            effective_contact_ratio=(cycle.effective_contact_ratio, "-"),
            pitch_point_pressure_MPa=(cycle.pitch_point_pressure_MPa, "MPa"),
            max_contact_pressure_MPa=(cycle.max_contact_pressure_MPa, "MPa"),
            transmission_error_mean_um=(cycle.transmission_error_um["mean"], "um"),
        )
    return out


def headline(
    thermal: dict[str, Any],
    baselines: dict[str, Any],
    cycle: CycleAtSpeed | None,
    uncertainty: RunUncertainty | None = None,
    ambient_C: float | None = None,
) -> Headline:
    """The headline numbers of a run from its stage summaries (with u_num where a refinement
    study of the case's resolution is stored)."""
    final = thermal.get("final_temperatures_C", {})
    u_num = None
    if uncertainty is not None:
        u_num = {}
        for field, q in (
            ("max_surface_temperature_C", "max_surface"),
            ("mean_bulk_temperature_C", "mean_bulk"),
            ("friction_power_W", "friction_power_W"),
            ("effective_contact_ratio", "effective_contact_ratio"),
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
    return Headline(
        time_s=thermal.get("time_s"),
        max_surface_temperature_C=final.get("max_surface"),
        mean_bulk_temperature_C=final.get("mean_bulk"),
        steady_max_surface_temperature_C=thermal.get("steady_state_C", {}).get("max_surface"),
        at_times_max_surface_C={
            t: v.get("max_surface") for t, v in thermal.get("at_times_C", {}).items()
        },
        friction_power_W=cycle.friction_power_W if cycle is not None else None,
        effective_contact_ratio=cycle.effective_contact_ratio if cycle is not None else None,
        vdi2736_flank1_C=baselines.get("vdi2736_flank1_C"),
        vdi2736_root1_C=baselines.get("vdi2736_root1_C"),
        mao_bulk1_C=baselines.get("mao_bulk1_C"),
        flash_max_K=baselines.get("flash_max_K"),
        u_num=u_num,
        friction_heat_per_gear_W=_per_gear(thermal, "friction_W"),
        steady_states_found=thermal.get("friction", {}).get("distinct_steady_states"),
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
        directory = cache_root() / "cycles" / case_cycle_key(case)
        if not comm.bcast((directory / "cycle.json").exists(), root=0):
            raise ParameterError(
                "sources.mode",
                "cycle",
                f"a stored cycle for this case ({directory}); run "
                "`gearfem cycle CASE.toml` or `gearfem run` first, or set mode = 'prescribed'",
            )
        cyc = load_cycle(directory)
    return thermal(case, out_dir, comm, cyc, mesh_cache=Path(cache_dir) if cache_dir else None)
