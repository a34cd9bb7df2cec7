"""Thermal benchmark: 8000 s of the default thesis gear (8-tooth P2 mesh, 40 W per gear on the drive
flanks).

Prints DOFs, steps, Newton iterations, factorisations and wall time of the default run, the
step-size error (against a run with a 20 times tighter local error tolerance: the maximum
difference over the run of T max surface, mean bulk, flank and root mean, the reference
interpolated monotonically at the default run's step times) and the plausibility numbers (lumped
estimate, time constant, VDI 2736-2 temperatures for the same friction heat).

    python benchmarks/performance/thermal.py                    # 1 rank
    mpirun -n 2 python benchmarks/performance/thermal.py        # 2 ranks
    python benchmarks/performance/thermal.py --no-reference     # timing only

Target (issue 6): under 60 s on 2 cores for the default mesh, step-size error below 0.5 K.

Purpose: performance (the thermal stage's time), with the time-step error as a check.
Writes: no documentation block (prints; docs/thermal.md quotes it).
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
import time
from pathlib import Path

import numpy as np
from mpi4py import MPI

import gearfem  # noqa: F401  (orders dolfinx_solver first)
from gearfem.core.materials import ZERO_CELSIUS_K
from gearfem.pipeline import read_case
from gearfem.thermal import ThermalBoundary, ThermalDomain, ThermalProblem
from gearfem.thermal.lumped import gear_radii, lumped_estimate

HERE = Path(__file__).resolve().parent
KEYS = ("max_surface", "mean_bulk", "flank_mean", "root_mean")


def build(case, comm, **thermal_overrides):
    from gearfem.geometry import build_gear_mesh

    options = dataclasses.replace(case.thermal, **thermal_overrides)
    prescribed = case.sources.prescribed()
    material = case.material
    gm = build_gear_mesh(case.geometry, case.thermal_mesh_options, comm, bodies=(options.body,))
    domain = ThermalDomain.from_gear_mesh(gm, options.body, flux_flanks=prescribed.flanks)
    profile = gm.pair.profile(options.body)
    boundary = ThermalBoundary.from_options(
        options, material, case.operating.speed_rpm, gear_radii(profile)
    )
    sources = prescribed.build(domain, material, case.operating.speed_rpm, profile.teeth)
    tag = "_".join(f"{k}{v}" for k, v in sorted(thermal_overrides.items())).replace(".", "p")
    return ThermalProblem(
        domain, material, sources, boundary, options, petsc_options_prefix=f"bench_{tag}_"
    ), gm


def timed_run(case, comm, **over):
    comm.barrier()
    t0 = time.perf_counter()
    problem, _gm = build(case, comm, **over)
    comm.barrier()
    t1 = time.perf_counter()
    records = problem.integrate()
    comm.barrier()
    t2 = time.perf_counter()
    stats = {
        "pc_builds": problem._transient_solver.pc_builds,
        "linear_iterations": problem._transient_solver.linear_iterations,
    }
    problem.close()  # collective: free the factorisation on every rank now
    return problem, records, t1 - t0, t2 - t1, stats


def series(records, key):
    return np.array([r.time_s for r in records]), np.array([r.temperatures_K[key] for r in records])


def step_error(records, ref_records) -> dict[str, float]:
    from scipy.interpolate import PchipInterpolator

    out = {}
    for key in KEYS:
        t, T = series(records, key)
        tr, Tr = series(ref_records, key)
        out[key] = float(np.max(np.abs(T - PchipInterpolator(tr, Tr)(t))))
    return out


def time_constant(records, key="mean_bulk") -> float:
    """Time at which the rise reaches 1 - 1/e of its final value (linear interpolation)."""
    t, T = series(records, key)
    rise = T - T[0]
    target = (1.0 - math.exp(-1.0)) * rise[-1]
    i = int(np.argmax(rise >= target))
    return float(t[i - 1] + (target - rise[i - 1]) * (t[i] - t[i - 1]) / (rise[i] - rise[i - 1]))


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--case", default=str(HERE / "thermal_thesis_40W.toml"))
    p.add_argument(
        "--no-reference", action="store_true", help="skip the tight-tolerance reference run"
    )
    p.add_argument("--degree1", action="store_true", help="also run P1 for comparison")
    args = p.parse_args(argv)
    comm = MPI.COMM_WORLD
    say = print if comm.rank == 0 else (lambda *a, **k: None)
    case = read_case(args.case)

    problem, records, t_setup, t_run, stats = timed_run(case, comm)
    o = problem.options
    last = records[-1]
    say(
        f"thermal benchmark: {comm.size} rank(s), degree {o.degree}, {problem.num_dofs} DOFs, "
        f"{len(records) - 1} steps, {sum(r.newton_iterations for r in records)} Newton iterations, "
        f"{stats['pc_builds']} factorisations, {stats['linear_iterations']} Krylov iterations"
    )
    say(
        f"  wall time: set-up {t_setup:.1f} s (mesh from cache, forms), 8000 s simulated in "
        f"{t_run:.1f} s "
        f"(target < 60 s on 2 cores)"
    )
    say(
        "  final (C): "
        + ", ".join(f"{k} {v - ZERO_CELSIUS_K:.2f}" for k, v in last.temperatures_K.items())
    )
    say(
        f"  heat balance: max |imbalance| / flow = "
        f"{max(r.balance.relative_imbalance for r in records[1:]):.2e}"
    )

    if not args.no_reference:
        tol = o.time_error_K / 20.0
        _, ref, _, t_ref, _ = timed_run(case, comm, time_error_K=tol)
        err = step_error(records, ref)
        say(
            f"  step-size error vs time_error_K = {tol:g} K ({len(ref) - 1} steps, {t_ref:.1f} s): "
            + ", ".join(f"{k} {v:.3f} K" for k, v in err.items())
            + " (target < 0.5 K)"
        )

    if args.degree1:
        p1, r1, _, t1, _ = timed_run(case, comm, degree=1)
        say(
            f"  P1 ({p1.num_dofs} DOFs, {t1:.1f} s) minus P2, final (K): "
            + ", ".join(
                f"{k} {r1[-1].temperatures_K[k] - last.temperatures_K[k]:+.2f}"
                for k in last.temperatures_K
            )
        )

    # plausibility: lumped one-node estimate, time constant, VDI 2736-2 for the same friction heat
    gen = last.balance.generated_W
    lump = lumped_estimate(problem, gen)
    areas = problem.role_areas_m2()
    b = problem.boundary
    hA = b.teeth.h(0.0) * areas["teeth"] + b.sides.h(0.0) * areas["sides"]
    theta_h = last.balance.convected_W / hA  # h A weighted mean surface rise of the FE solution
    t_bulk, bulk = series(records, "mean_bulk")
    bulk_900_C = bulk[np.searchsorted(t_bulk, 900.0)] - ZERO_CELSIUS_K
    say(
        f"  lumped: P = {gen:.3f} W in the {problem.domain.model_fraction:.4f} sector "
        f"({gen / problem.domain.model_fraction:.1f} W per gear), theta_ss = "
        f"{lump['theta_ss_K']:.1f} K, "
        f"tau = rho c V / G = {lump['tau_s']:.0f} s"
    )
    say(
        f"  FE: hA-weighted mean surface rise {theta_h:.1f} K, mean bulk rise "
        f"{last.temperatures_K['mean_bulk'] - records[0].temperatures_K['mean_bulk']:.1f} K, "
        f"flank mean rise "
        f"{last.temperatures_K['flank_mean'] - records[0].temperatures_K['flank_mean']:.1f} K, "
        f"root mean rise "
        f"{last.temperatures_K['root_mean'] - records[0].temperatures_K['root_mean']:.1f} K; "
        f"63 % of the final rise "
        f"after {time_constant(records):.0f} s (bulk), "
        f"{time_constant(records, 'max_surface'):.0f} s "
        f"(max surface); at 900 s: bulk "
        f"{bulk_900_C:.1f} C"
    )
    try:
        from gearfem.baselines import vdi2736_temperature_C
    except ImportError:  # pragma: no cover - baselines not merged
        return 0
    geo = case.get("geometry", {})
    m = geo.get("module_mm", 2.0) * 1e-3
    z = round(problem.domain.teeth_modelled / problem.domain.model_fraction)
    v_t = problem.boundary.convection.speed_rpm * 2 * math.pi / 60 * 0.5 * m * z
    loss_pair = 2.0 * gen / problem.domain.model_fraction  # both gears
    common = dict(
        ambient_C=problem.options.ambient_C,
        power_W=loss_pair,
        mu=1.0,
        loss_factor=1.0,
        face_width_m=geo.get("face_width_mm", 12.934) * 1e-3,
        pitch_line_speed_m_s=v_t,
        module_m=m,
    )
    try:
        fl = vdi2736_temperature_C(teeth=z, k_theta=9000.0, **common)
        rt = vdi2736_temperature_C(teeth=z, k_theta=2148.0, **common)
        say(
            f"  VDI 2736-2 with the same friction heat ({loss_pair:.0f} W per pair): flank "
            f"{fl:.0f} C, root {rt:.0f} C"
        )
    except TypeError as err:  # signature differs: skip the comparison
        say(f"  (VDI 2736-2 comparison skipped: {err})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
