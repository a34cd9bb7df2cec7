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
import json
import logging
import math
import os
import time
from pathlib import Path
from typing import Any

from mpi4py import MPI

from gearfem.config import Case, write_case
from gearfem.cycle.store import cached_cycle, cycle_key
from gearfem.errors import ParameterError
from gearfem.materials import ZERO_CELSIUS_K

log = logging.getLogger(__name__)


def pair_mesh(case: Case, comm: MPI.Comm, cache_dir: Path | None = None):
    from gearfem.geometry.mesh import build_gear_mesh

    return build_gear_mesh(case.geometry, dataclasses.replace(case.mesh, bodies=("pinion", "wheel")), comm,
                           cache_dir=cache_dir)


def case_cycle_key(case: Case) -> str:
    return cycle_key(case.geometry, dataclasses.replace(case.mesh, bodies=("pinion", "wheel")), case.materials,
                     case.contact, case.cycle, case.operating.torque_Nm)


def cycle(case: Case, comm: MPI.Comm, mesh_cache: Path | None = None, cache_dir: Path | None = None,
          rebuild: bool = False, progress=None):
    """The structural cycle of the case's torque (cached). Returns (CycleResult, directory, from_cache)."""
    from gearfem.cycle.model import GearContactModel

    heat_fraction = case.sources.heat_fraction(case.materials)

    def factory():
        gm = pair_mesh(case, comm, mesh_cache)
        return GearContactModel(gm, case.materials, case.contact, case.operating.torque_Nm, case.cycle)

    return cached_cycle(factory, case_cycle_key(case), comm, cache_dir=cache_dir, rebuild=rebuild,
                        heat_fraction=heat_fraction, progress=progress)


def thermal(case: Case, out_dir: str | Path, comm: MPI.Comm, cycle_result=None, mesh_cache: Path | None = None,
            write_fields: bool = True, extra: dict[str, Any] | None = None, steady: bool = True,
            write_plot: bool = True) -> dict[str, Any]:
    """Thermal run of ``case.thermal.body`` with sources from ``cycle_result`` (mode "cycle") or
    prescribed ([sources] mode "prescribed"); writes the thermal outputs to ``out_dir``."""
    from gearfem.geometry.mesh import build_gear_mesh
    from gearfem.sources import cycle_heat_sources
    from gearfem.thermal.boundary import ThermalBoundary
    from gearfem.thermal.case import gear_radii, lumped_estimate
    from gearfem.thermal.domain import ThermalDomain
    from gearfem.thermal.problem import ThermalProblem
    from gearfem.thermal.run import run_and_write

    body = case.thermal.body
    if body not in ("pinion", "wheel"):
        raise ParameterError("thermal.body", body, "'pinion' or 'wheel'")
    # the thermal model meshes only its body: balanced over the ranks
    gm = build_gear_mesh(case.geometry, dataclasses.replace(case.mesh, bodies=(body,)), comm, cache_dir=mesh_cache)
    src = case.sources
    domain = ThermalDomain.from_gear_mesh(gm, body, flux_flanks=src.flanks if src.mode == "prescribed" else "drive")
    material = case.materials[body]
    profile = gm.pair.profile(body)
    n1 = case.operating.speed_rpm
    speed = n1 if body == "pinion" else n1 * case.geometry.teeth_pinion / profile.teeth
    boundary = ThermalBoundary.from_options(case.thermal, material, speed, gear_radii(profile))
    if src.mode == "prescribed":
        sources = src.prescribed().build(domain, material, speed, profile.teeth)
        title = f"{body}, {speed:g} rpm, {src.flank_heat_per_gear_W:g} W prescribed flank heat per gear"
    else:
        if cycle_result is None:
            raise ParameterError("sources.mode", "cycle", "a cycle result (run `gearfem cycle` or `gearfem run`) "
                                 "or mode = 'prescribed'")
        sources = cycle_heat_sources(domain, gm, body, cycle_result, src, material, n1)
        title = f"{body}, {n1:g} rpm, {case.operating.torque_Nm:g} N m (sources from the contact cycle)"
    problem = ThermalProblem(domain, material, sources, boundary, case.thermal, petsc_options_prefix="gearfem_thermal_")
    info = {"title": title, "body": body, "speed_rpm": speed, "teeth": profile.teeth,
            "teeth_modelled": domain.teeth_modelled, "mesh_cache_key": gm.cache_key}
    info.update(extra or {})

    def more(records) -> dict[str, Any]:
        gen = records[-1].balance.generated_W
        out = {"generated_per_gear_W": gen / domain.model_fraction if math.isfinite(gen) else None,
               "lumped_estimate": lumped_estimate(problem, gen if math.isfinite(gen) else 0.0)}
        wanted = tuple(case.thermal.output_times_s)
        out["at_times_C"] = {f"{r.time_s:g}": {k: v - ZERO_CELSIUS_K for k, v in r.temperatures_K.items()}
                             for r in records if any(abs(r.time_s - t) <= 1e-6 * max(1.0, t) for t in wanted)}
        if case.thermal.mode == "transient" and steady:
            rec = problem.solve_steady()  # the operating temperature if the run went on for ever
            out["steady_state_C"] = {k: v - ZERO_CELSIUS_K for k, v in rec.temperatures_K.items()}
        return out

    with problem:  # frees the solvers collectively, also on failure
        _, summary = run_and_write(problem, out_dir, extra=info, more=more, write_fields=write_fields,
                                   write_plot=write_plot)
    return summary


def baselines(case: Case) -> dict[str, Any]:
    """VDI 2736, Mao, Blok and Hertz/ISO numbers for the case's operating point."""
    from gearfem.baselines import baseline_summary
    from gearfem.geometry.involute import GearPair

    from gearfem.baselines import max_rack_fillet_coef

    g = case.geometry
    pair = GearPair(g)
    opts = case.baselines
    if opts.rack_fillet_coef is None:  # the gear's own fillet, where the standard rack can carry it
        rho = min(g.root_fillet_coefficient, max_rack_fillet_coef(g.pressure_angle_deg, opts.rack_dedendum_coef))
        opts = dataclasses.replace(opts, rack_fillet_coef=rho)
    return baseline_summary(
        speed_rpm=case.operating.speed_rpm, torque_Nm=case.operating.torque_Nm, mu=case.contact.friction_coefficient,
        teeth1=g.teeth_pinion, teeth2=g.teeth_wheel, module_m=g.module_mm * 1e-3,
        pressure_angle_deg=g.pressure_angle_deg, face_width_m=g.face_width_mm * 1e-3,
        tip_radius1_m=pair.pinion.tip_radius_m, tip_radius2_m=pair.wheel.tip_radius_m,
        centre_distance_m=pair.center_distance_m, ambient_C=case.thermal.ambient_C,
        material1=case.materials["pinion"], material2=case.materials["wheel"], options=opts)


def prepare_output(out_dir: str | Path, marker: str, comm: MPI.Comm) -> Path:
    """Create ``out_dir`` and remove its completion marker (collective): a run that fails now must
    not leave an old marker looking current. The marker is written last by the run."""
    out = Path(out_dir)
    if comm.rank == 0:
        out.mkdir(parents=True, exist_ok=True)
        (out / marker).unlink(missing_ok=True)
    comm.barrier()
    return out


def _write_json(path: Path, data: dict[str, Any]) -> None:
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    tmp.write_text(json.dumps(data, indent=2, default=_default))
    os.replace(tmp, path)


def _default(obj):
    import numpy as np

    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(type(obj))


def run(case: Case, out_dir: str | Path, comm: MPI.Comm | None = None, mesh_cache: Path | None = None,
        cache_dir: Path | None = None, progress: bool = True, write_fields: bool = True) -> dict[str, Any]:
    """The whole chain for one operating point; returns the summary (collective).

    ``write_fields``: write the VTX temperature fields (studies switch them off)."""
    from gearfem.cycle.report import write_cycle_outputs
    from gearfem.provenance import versions

    comm = comm or MPI.COMM_WORLD
    out = prepare_output(out_dir, "summary.json", comm)
    times: dict[str, float] = {}
    t0 = time.perf_counter()
    bar = _ProgressBar(comm) if progress else None
    cyc = None
    if case.sources.mode == "cycle":
        cyc, cdir, cached = cycle(case, comm, mesh_cache, cache_dir,
                                  progress=bar.update if bar is not None else None)
        if bar is not None:
            bar.close()
        times["cycle_s"] = time.perf_counter() - t0
        if comm.rank == 0:
            write_cycle_outputs(cyc, out / "cycle")
        comm.barrier()
    t1 = time.perf_counter()
    th = thermal(case, out / "thermal", comm, cyc, mesh_cache, write_fields=write_fields)
    times["thermal_s"] = time.perf_counter() - t1
    base = baselines(case)
    times["total_s"] = time.perf_counter() - t0
    summary: dict[str, Any] = {
        "case": case.name, "speed_rpm": case.operating.speed_rpm, "torque_Nm": case.operating.torque_Nm,
        "thermal": th, "baselines": base, "wall_time_s": times, "mpi_size": comm.size,
    }
    if cyc is not None:
        summary["cycle"] = cycle_summary(cyc, case.operating.speed_rpm)
        summary["cycle"]["cache"] = {"directory": str(cdir), "from_cache": cached}
    summary["headline"] = headline(summary)
    vers = versions(comm)
    if comm.rank == 0:
        write_case(case, out / "case.toml")
        _write_json(out / "versions.json", vers)
        _write_json(out / "summary.json", summary)  # last: marks a complete run
    comm.barrier()
    return summary


def cycle_summary(cyc, speed_rpm: float) -> dict[str, Any]:
    import numpy as np

    omega = 2.0 * math.pi * speed_rpm / 60.0
    return {
        "effective_contact_ratio": cyc.effective_contact_ratio(),
        "theoretical_contact_ratio": cyc.theoretical_contact_ratio,
        "max_contact_pressure_MPa": float(np.max(cyc.p_max_Pa)) / 1e6,
        "pitch_point_pressure_MPa": float(cyc.p_max_mid_Pa[0]) / 1e6,
        "max_root_stress_MPa": {b: float(np.max(v)) / 1e6 for b, v in cyc.root_stress_Pa.items()},
        "transmission_error_um": {"mean": float(np.mean(cyc.te_m)) * 1e6,
                                  "peak_to_peak": float(np.ptp(cyc.te_m)) * 1e6},
        "friction_power_W": cyc.mean_friction_power_W_per_rad_s() * omega,
        "pinion_torque_mean_Nm": float(np.mean(cyc.pinion_torque_Nm)),
        "positions": int(len(cyc.phi_rad)), "newton_iterations": int(np.sum(cyc.newton_iterations)),
        "sweep_wall_time_s": float(np.sum(cyc.wall_time_s)), "info": cyc.info,
    }


def headline(summary: dict[str, Any]) -> dict[str, Any]:
    th = summary["thermal"]
    final = th.get("final_temperatures_C", {})
    h = {"time_s": th.get("time_s"), "max_surface_temperature_C": final.get("max_surface"),
         "mean_bulk_temperature_C": final.get("mean_bulk"),
         "steady_max_surface_temperature_C": th.get("steady_state_C", {}).get("max_surface"),
         "at_times_max_surface_C": {t: v.get("max_surface") for t, v in th.get("at_times_C", {}).items()}}
    if "cycle" in summary:
        h["friction_power_W"] = summary["cycle"]["friction_power_W"]
        h["effective_contact_ratio"] = summary["cycle"]["effective_contact_ratio"]
    b = summary["baselines"]
    for k in ("vdi2736_flank1_C", "vdi2736_root1_C", "mao_bulk1_C", "flash_max_K"):
        if k in b:
            h[k] = b[k]
    return h


class _ProgressBar:
    """A one-line progress bar printed by rank 0 only (no collective calls)."""

    def __init__(self, comm: MPI.Comm) -> None:
        self.rank = comm.rank
        self.t0 = time.perf_counter()

    def update(self, i: int, n: int, label: str = "") -> None:
        if self.rank != 0:
            return
        width = 30
        done = int(width * i / max(n, 1))
        el = time.perf_counter() - self.t0
        eta = el / max(i, 1) * (n - i)
        print(f"\r  cycle [{'#' * done}{'.' * (width - done)}] {i}/{n} {label:>10}  {el:6.0f} s, ~{eta:4.0f} s left",
              end="", flush=True)

    def close(self) -> None:
        if self.rank == 0:
            print(flush=True)
