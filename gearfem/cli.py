"""The ``gearfem`` command.

Every subcommand prints where its results went and exits non-zero on failure; ``gearfem info``
prints the versions a bug report needs.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import logging
import os
import shutil
import sys
from collections.abc import Sequence
from pathlib import Path

from mpi4py import MPI

from gearfem import case_keys, claims, pipeline
from gearfem.config import load_case
from gearfem.core.doctables import replace_block
from gearfem.core.errors import GearfemError, ParameterError
from gearfem.core.io import write_json
from gearfem.core.log import ProgressBar, setup_logging
from gearfem.core.material_library import library_material
from gearfem.core.provenance import format_versions, versions
from gearfem.cycle.report import cycle_summary_dict, write_cycle_outputs
from gearfem.diagnose.data import read_csv
from gearfem.diagnose.design import bench_grid, check_grid
from gearfem.diagnose.report import design_case, run_diagnosis
from gearfem.geometry.mesh import build_gear_mesh, mesh_report, plot_pair
from gearfem.pipeline import read_case, run_thermal_case
from gearfem.refinement import CASE_LEVELS as REFINEMENT_CASE_LEVELS
from gearfem.refinement import KINDS as REFINEMENT_KINDS
from gearfem.refinement import LEVELS as REFINEMENT_LEVELS
from gearfem.refinement import MAX_LEVELS as REFINEMENT_MAX_LEVELS
from gearfem.refinement import refinement_study
from gearfem.study import load_study, run_study

log = logging.getLogger("gearfem.cli")


def _cmd_info(args: argparse.Namespace) -> int:
    info = versions()

    if MPI.COMM_WORLD.rank == 0:
        print(json.dumps(info, indent=2) if args.json else format_versions(info))
    return 0


def _cmd_claims(args: argparse.Namespace) -> int:
    """List the quoted results of the README and docs that no longer belong to the shipped model
    (gearfem.claims); with ``--mark`` put the stale note into each of those blocks first (and
    take it out of blocks that are current again). Exit 1 when a stale block does not say so."""
    if args.mark and MPI.COMM_WORLD.rank == 0:
        claims.mark_stale(Path(args.root))
    MPI.COMM_WORLD.barrier()
    found = claims.stale_claims(Path(args.root))
    if MPI.COMM_WORLD.rank == 0:
        for c in found:
            cmd = claims.regenerate_command(c)
            print(f"{c}" + (f"\n    regenerate: {cmd}" if cmd else ""))
        print(f"{len(found)} stale quoted block(s) in {args.root}" if found else "no stale claims")
        steps = claims.regenerations(found)
        if steps:
            print(
                "to regenerate them, run from the repository's root, in this order (or "
                "`python benchmarks/regenerate.py`, which also times each):"
            )
            for step in steps:
                print(f"    {step.command}")
        left = claims.unmarked(found)
        if left:
            print(
                f"{len(left)} of them carry no stale note: regenerate them, or mark them with "
                "`gearfem claims --mark`"
            )
    return 1 if claims.unmarked(found) else 0


def _cmd_keys(args: argparse.Namespace) -> int:
    """Print the case file's keys (gearfem.case_keys): every table's, or one table's; with
    ``--docs PAGE`` write the Markdown reference into block ``case_keys`` of PAGE instead."""
    case = load_case(args.case) if args.case else None
    reference = case_keys.markdown() if args.docs else case_keys.text(args.table, case)
    if MPI.COMM_WORLD.rank != 0:  # a serial command: under mpirun, rank 0 alone writes
        return 0
    if args.docs:
        replace_block(args.docs, "case_keys", reference)
        print(f"wrote the case file reference into {args.docs} (block case_keys)")
    else:
        print(reference)
    return 0


def _cmd_mesh(args: argparse.Namespace) -> int:
    """Build (or load) the gear-pair mesh of a case; write mesh.msh, mesh.json and a picture."""

    case = load_case(args.case)
    geometry, options = case.geometry, case.mesh
    comm = MPI.COMM_WORLD
    gm = build_gear_mesh(geometry, options, comm, cache_dir=args.cache_dir, rebuild=args.rebuild)
    report = mesh_report(gm)
    out = Path(args.out)
    if comm.rank == 0:
        out.mkdir(parents=True, exist_ok=True)
        tmp = out / f".mesh.msh.tmp{os.getpid()}"
        shutil.copyfile(gm.msh_path, tmp)
        os.replace(tmp, out / "mesh.msh")
        if not args.no_picture:
            png = plot_pair(
                gm.msh_path,
                out / ".gear_pair_mesh.tmp.png",
                focus_mm=tuple(report["reference"]["pitch_point_mm"]),
                face_width_mm=geometry.face_width_mm,
                title=f"{report['counts']['cells']} {report['element']['cell_type']} cells, "
                f"{report['counts']['dofs_p2_vector']} P2 vector DOFs",
            )
            os.replace(png, out / "gear_pair_mesh.png")
        write_json(out / "mesh.json", report)  # last: its presence marks a complete output
        c, t = report["counts"], report["timing"]
        q = report["quality"]
        print(
            f"mesh {gm.cache_key}: {c['cells']} cells ({report['element']['cell_type']}), "
            f"{c['nodes']} nodes, "
            f"{c['dofs_p2_vector']} P2 vector DOFs; min scaled Jacobian "
            f"{q['min_scaled_jacobian']:.3f}"
        )
        for body, v in report["volumes"].items():
            print(
                f"  {body}: volume {v['fe_mm3']:.3f} mm^3 "
                f"(analytic {v['analytic_mm3']:.3f}, rel. error {v['rel_error']:.1e})"
            )
        print(
            f"  {len(report['groups'])} named groups; "
            f"build {t['build_time_s']:.1f} s, import {t['import_time_s']:.1f} s"
        )
        written = [out / "mesh.msh", out / "mesh.json"] + (
            [] if args.no_picture else [out / "gear_pair_mesh.png"]
        )
        print("wrote " + ", ".join(str(w) for w in written))
    return 0


def _cmd_thermal(args: argparse.Namespace) -> int:
    """Transient (or steady) temperature of one gear from prescribed sources."""

    summary = run_thermal_case(read_case(args.case), args.out, cache_dir=args.cache_dir)
    # (read_case: the one case schema of gearfem.config; None = the built-in thesis case)
    if MPI.COMM_WORLD.rank == 0:
        T = summary["final_temperatures_C"]
        print(
            f"thermal: t = {summary['time_s']:g} s, {summary['steps']} steps, {summary['dofs']} "
            f"DOFs, "
            f"T max surface {T['max_surface']:.1f} C, mean bulk {T['mean_bulk']:.1f} C; "
            f"results in {args.out} (thermal_history.csv, temperature.bp, thermal_history.png, "
            f"thermal_summary.json)"
        )
    return 0


def cycle_mu_note(case, torque, loop) -> str | None:
    """What ``gearfem run`` says when the friction law's effective mu at the end value (the
    torque meters' law friction power over the cycle's, times the cycle's mu) differs from the
    constant mu the cycle was solved with by ``[friction] cycle_mu_tolerance`` or more (None:
    it does not, the meters read the cycle, or the cycle was solved at the law's mu already,
    ``loop``)."""
    if torque.source != "law" or loop is not None or not torque.cycle_friction_power_W > 0.0:
        return None
    mu_c = case.contact.friction_coefficient
    mu_eff = torque.effective_mu(mu_c)
    if abs(mu_eff - mu_c) < case.friction.cycle_mu_tolerance:
        return None
    return (
        f"note: the friction law's effective mu is {mu_eff:.4f} at the end value, the cycle's "
        f"{mu_c:g}: the pressures, loads and U_max are the cycle's at {mu_c:g}; [friction] "
        'cycle_mu = "law" solves the cycle with the law\'s mu at each contact (docs/friction.md)'
    )


def material_limit_notes(
    case, max_surface_C: float | None, vdi2736_flank_C: float | None = None
) -> list[str]:
    """What a run's temperatures of ``[thermal] body`` say against its polymer's limits in the
    materials library: the hottest surface above the maximum service temperature, VDI 2736's flank
    temperature above the melting temperature (where its rating is outside the material's range).
    Empty for a steel gear or temperatures within the limits."""
    body = case.thermal.body
    lib = library_material(case.materials[body].name)
    if lib.kind != "polymer":
        return []
    notes = []
    service, melting = lib.value("max_service_temperature_C"), lib.value("melting_C")
    if max_surface_C is not None and max_surface_C > service:
        notes.append(
            f"the {body}'s hottest surface, {max_surface_C:.1f} C, lies above {lib.name}'s maximum "
            f"service temperature, {service:.0f} C (materials library)"
        )
    if vdi2736_flank_C is not None and vdi2736_flank_C > melting:
        notes.append(
            f"VDI 2736's flank temperature, {vdi2736_flank_C:.1f} C, lies above {lib.name}'s "
            f"melting temperature, {melting:.0f} C: the rating is outside the material's range"
        )
    return notes


def with_u_num(headline: pipeline.Headline, field: str, unit: str, digits: int = 1) -> str:
    """The headline's ``field`` with its u_num where a study gives one: "284.9 ± 16.3 C"."""
    value = getattr(headline, field)
    u = (headline.u_num or {}).get(field)
    text = f"{value:.{digits}f}" + (f" ± {u:.{digits}f}" if u is not None else "")
    return f"{text} {unit}".rstrip()


def _say(*a, **k) -> None:

    if MPI.COMM_WORLD.rank == 0:
        print(*a, **k)


def _cmd_cycle(args: argparse.Namespace) -> int:
    """Solve the mesh cycle of a case's torque (cached) and write histories and plots."""

    case = load_case(args.case)
    if args.torque_Nm is not None:
        case = case.with_operating(torque_Nm=args.torque_Nm)
    comm = MPI.COMM_WORLD
    with ProgressBar(comm) as bar:
        res, directory, cached = pipeline.cycle(
            case, comm, rebuild=args.rebuild, progress=bar.update
        )
    if comm.rank == 0:
        write_cycle_outputs(res, args.out)
        s = cycle_summary_dict(res)
        _say(
            f"cycle at {case.operating.torque_Nm:g} N m ({'cached' if cached else 'computed'}, "
            f"{directory}): "
            f"{s['positions']} positions, effective contact ratio "
            f"{s['effective_contact_ratio']:.3f} "
            f"(theory {s['theoretical_contact_ratio']:.3f}), TE "
            f"{s['transmission_error_um']['mean']:.1f} um, "
            f"max pressure {s['max_contact_pressure_MPa']:.1f} MPa, friction power "
            f"{s['mean_friction_power_W_per_rad_s']:.3f} W per rad/s; results in {args.out} "
            "(cycle_history.csv, cycle_summary.json, load_sharing.png, transmission_error.png, "
            "strain_energy_history.png, flank_maps.png)"
        )
    comm.barrier()
    return 0


def _cmd_run(args: argparse.Namespace) -> int:
    """The whole chain for one operating point: cycle (cached), thermal, baselines, summary."""

    case = load_case(args.case)
    case = case.with_operating(speed_rpm=args.speed_rpm, torque_Nm=args.torque_Nm)
    if args.duration_s is not None:
        case = dataclasses.replace(
            case, thermal=dataclasses.replace(case.thermal, duration_s=args.duration_s)
        )
    summary = pipeline.run(case, args.out, MPI.COMM_WORLD, progress=not args.no_progress)
    h = summary.headline
    # a steady run's values are the steady state; a transient run names it beside when it has one
    steady_run = case.thermal.mode == "steady"
    when = "steady state" if steady_run else f"t = {h.time_s:g} s"

    def beside(steady_C: float | None) -> str:
        return "" if steady_run or steady_C is None else f"steady {steady_C:.1f} C"

    _say(
        f"{case.name}: {case.operating.speed_rpm:g} rpm, {case.operating.torque_Nm:g} N m, "
        f"{when}: max surface "
        f"{with_u_num(h, 'max_surface_temperature_C', 'C')}"
        + (f" ({s})" if (s := beside(h.steady_max_surface_temperature_C)) else "")
        + f", mean bulk {with_u_num(h, 'mean_bulk_temperature_C', 'C')}; "
        + (
            f"VDI 2736 flank {h.vdi2736_flank_C:.1f} C, root {h.vdi2736_root_C:.1f} C"
            if h.vdi2736_flank_C is not None
            else f"VDI 2736 does not rate the {case.thermal.body} (a metal gear)"
        )
    )
    for note in material_limit_notes(case, h.max_surface_temperature_C, h.vdi2736_flank_C):
        _say(f"note: {note}")
    if h.max_surface_field_C is not None:
        _say(
            "the field's surface maximum (between the nodes) "
            f"{with_u_num(h, 'max_surface_field_C', 'C')}, the hottest surface node "
            f"{h.max_surface_temperature_C:.1f} C"
        )
    if h.friction_power_W is not None:
        _say(
            f"friction heat of the pair {with_u_num(h, 'friction_power_W', 'W', 2)}, effective "
            f"contact ratio {with_u_num(h, 'effective_contact_ratio', '', 3)}"
        )
    if summary.heat_split is not None:
        split = summary.heat_split
        _say(
            f"friction heat split by contact temperature: the pinion takes "
            f"{split.fraction_pinion:.4f} after {len(split.passes)} runs of both gears ("
            + "; ".join(f"{p.fraction_pinion:.4f}: {p.difference_K:+.2f} K" for p in split.passes)
            + f"; tolerance {split.tolerance_K:g} K)"
        )
    if summary.cycle_mu is not None:
        loop = summary.cycle_mu
        _say(
            f"the cycle solved at the friction law's mu: {len(loop.passes)} cycle(s), "
            + "; ".join(
                (
                    f"mu {p.mu_cycle:.4f} -> {p.mu_effective:.4f} "
                    f"({p.mu_effective - p.mu_cycle:+.4f})"
                    if p.field_change is None
                    else f"mu {p.mu_cycle:.4f} where a contact has no band, "
                    f"{p.mu_cycle_mean:.4f} on heat-weighted mean -> {p.mu_effective:.4f}, "
                    f"per band {p.mu_band_range[0]:.3f}-{p.mu_band_range[1]:.3f}, "
                    f"moved by {p.field_change:.4f} (at most {p.field_change_max:.4f})"
                )
                for p in loop.passes
            )
            + f"; the readings are the cycle's at mu {loop.mu:.4f} (tolerance {loop.tolerance:g})"
        )
    if summary.modulus is not None:
        loop = summary.modulus
        _say(
            f"the cycle's modulus from the thermal state, cell by cell: {len(loop.passes)} "
            "cycle(s); mean relative modulus pinion, wheel "
            + "; ".join(
                "{:.3f}, {:.3f} -> {:.3f}, {:.3f}".format(*p.relative_cycle, *p.relative_state)
                + f" (a cell's e moved by at most {p.change_max:.3f}, the mean by {p.change:.4f})"
                for p in loop.passes
            )
            + f"; tolerance {loop.tolerance:g}; share beyond the E(T) table "
            + ", ".join(f"{100 * x:.0f} %" for x in loop.passes[-1].beyond_table)
        )
    u = summary.numerical_uncertainty
    if u is not None:
        missing = f"; no study of: {', '.join(u.missing)}" if u.missing else ""
        _say(
            f"± u_num: numerical standard uncertainty from the refinement studies of resolution "
            f"{u.resolution_key} (docs/refinement.md){missing}"
        )
    if h.camera_max_C is not None and summary.instruments is not None:
        end = summary.instruments.camera["end"]
        steady_camera = beside(h.camera_max_steady_C)
        _say(
            f"IR camera ({case.instruments.camera.view} view): camera_max "
            f"{with_u_num(h, 'camera_max_C', 'C')} "
            f"at the end ({steady_camera + '; ' if steady_camera else ''}the unknown sub-pixel aim "
            f"{end.aim_std_C:.1f} K), at pixel {end.pixel} on {end.body} {end.surface} at the "
            f"nominal aim; the hottest model node of the pair is {end.hottest_node_C:.1f} C"
        )
    q = summary.instruments.torque if summary.instruments is not None else None
    if q is not None:
        what = (
            "the friction law's and the hysteresis' power at the end value"
            if q.source == "law"
            else "the structural cycle's torques"
        )
        cyc = (
            f" (the cycle's constant mu: {q.cycle_torque_loss_Nm:.4f} N m)"
            if q.source == "law" and q.cycle_torque_loss_Nm is not None
            else ""
        )
        _say(
            f"torque meters ({what}): torque loss {q.torque_loss_Nm:.4f} +- "
            f"{q.u_torque_loss_Nm:.4f} N m, efficiency {q.efficiency:.4f}{cyc}"
        )
        note = cycle_mu_note(case, q, summary.cycle_mu)
        if note:
            _say(note)
    _say(
        f"results in {args.out}: summary.json, case.toml, versions.json, cycle/, thermal/"
        + (", instruments/ (snapshot.npz, thermograms)" if summary.instruments else "")
    )
    return 0


def _cmd_observe(args: argparse.Namespace) -> int:
    """Read the instruments again on a finished run (no solve)."""

    instruments = load_case(args.case).instruments if args.case else None
    r = pipeline.observe(
        args.result_dir,
        MPI.COMM_WORLD,
        instruments=instruments,
        only=tuple(args.instrument) if args.instrument else None,
        out_dir=args.out,
    )
    for lab in r.labels:
        t = r.times_s[r.labels.index(lab)]
        when = "steady state" if t is None else f"t = {t:g} s"
        if lab in r.camera:
            c = r.camera[lab]
            _say(
                f"{when}: camera_max {c.max_C:.1f} C (sub-pixel aim: standard deviation "
                f"{c.aim_std_C:.1f} K, {c.aim_range_C[0]:.1f}-{c.aim_range_C[1]:.1f} C over "
                f"{c.aims} aims; nominal aim: frames {c.frame_max_range_C[0]:.1f}-"
                f"{c.frame_max_range_C[1]:.1f} C at pixel {c.pixel} on {c.body} {c.surface}); "
                f"hottest model node {c.hottest_node_C:.1f} C"
            )
        for name, p in r.probes.get(lab, {}).items():
            _say(f"{when}: probe:{name} ({p.kind}, {p.body}) {p.value_C:.1f} C")
    if r.torque is not None:
        q = r.torque
        _say(
            f"torque meters: input {q.input_torque_Nm:.4f} N m, output "
            f"{q.output_torque_Nm:.4f} N m, loss {q.torque_loss_Nm:.4f} +- "
            f"{q.u_torque_loss_Nm:.4f} N m, efficiency "
            f"{q.efficiency:.4f} +- {q.u_efficiency:.4f}"
        )
    out = args.out or f"{args.result_dir}/instruments"
    _say(f"results in {out}: readings.json" + (", thermogram_*.png/.csv" if r.files else ""))
    return 0


def _cmd_study(args: argparse.Namespace) -> int:
    """A speed x torque study: one cycle per torque, every operating point, a table and plots."""

    study = load_study(args.study)
    if args.list:
        for i, (label, c) in enumerate(study.cases()):
            _say(f"{i:4d}  {label}  ({c.operating.speed_rpm:g} rpm, {c.operating.torque_Nm:g} N m)")
        return 0
    res = run_study(study, args.out, MPI.COMM_WORLD, index=args.index, collect_only=args.collect)
    if args.index is not None:
        _say(
            f"study {study.name}: task {args.index} "
            f"{'ran' if res.ran else 'was already finished'}; "
            f"collect with: gearfem study {args.study} --out {args.out} --collect"
        )
        return 0
    _say(
        f"study {study.name}: {len(res.results)} operating points, {len(res.ran)} computed "
        f"now, "
        f"{len(res.missing)} missing"
    )
    _say(
        f"{'speed rpm':>10} {'torque Nm':>10} {'friction W':>10} {'T max end C':>11} "
        f"{'T max steady C':>14} "
        f"{'VDI flank C':>11}"
    )
    for r in res.results:
        if r.status != "done":
            _say(f"{r.speed_rpm:10g} {r.torque_Nm:10g}  (missing)")
            continue
        steady = r.max_surface_steady_C
        _say(
            f"{r.speed_rpm:10g} {r.torque_Nm:10g} {r.friction_W:10.1f} "
            f"{r.max_surface_end_C:11.1f} "
            f"{steady if steady is not None else float('nan'):14.1f} "
            f"{r.vdi2736_flank_C or float('nan'):11.1f}"
        )
    _say(
        f"results in {args.out}: results.csv, study.json, temperature_histories.png, "
        f"steady_temperature.png, "
        "cases/<label>/"
    )
    return 0 if res.complete else 1


def _cmd_converge(args: argparse.Namespace) -> int:
    """Refinement study of a case in one direction (gearfem.refinement)."""

    case = load_case(args.case)
    if args.duration_s is not None:
        case = dataclasses.replace(
            case, thermal=dataclasses.replace(case.thermal, duration_s=args.duration_s)
        )
    study = refinement_study(
        case,
        args.out,
        MPI.COMM_WORLD,
        kind=args.kind,
        factor=args.factor,
        case_level=args.case_level,
        levels=args.levels,
    )
    _say(
        f"{args.kind} refinement of {case.name}: DOFs {', '.join(str(n) for n in study.dofs)} "
        f"(coarse to fine; the case's resolution is the {args.case_level})"
    )
    at = study.case_value_index
    for r in study.rows:
        _say(
            f"  {r.quantity:26s} {r.values[at]:10.4g} {r.unit:3s} (case), order "
            f"{r.observed_order:5.2f}, extrapolated {r.extrapolated:10.4g}, u_num of the case "
            f"{r.u_num_case:8.3g}{'' if r.asymptotic else ' (not asymptotic)'}"
        )
    _say(
        f"results in {args.out}: refinement.md, refinement.csv, refinement.png, refinement.json; "
        f"filed for `gearfem run` under resolution {study.resolution_key}"
    )
    return 0


def _floats(text: str | None, name: str) -> tuple[float, ...] | None:
    if text is None:
        return None
    try:
        return tuple(float(x) for x in text.split(",") if x.strip())
    except ValueError:
        raise ParameterError(name, text, "comma-separated numbers") from None


def _design_grid(args: argparse.Namespace, case):
    """The --suggest grid: the bench grid with the options' speeds, torques and times."""
    speeds = _floats(args.suggest_speeds, "--suggest-speeds")
    torques = _floats(args.suggest_torques, "--suggest-torques")
    times = _floats(args.suggest_times, "--suggest-times")
    if not args.suggest or (speeds, torques, times) == (None, None, None):
        return None
    base = bench_grid(
        tuple(q for q in design_case(case).instruments.quantities if q != "efficiency")
    )
    return check_grid(
        dataclasses.replace(
            base,
            speeds_rpm=speeds or base.speeds_rpm,
            torques_Nm=torques or base.torques_Nm,
            times_s=times if times is not None else base.times_s,
            source="given on the command line",
        )
    )


def _cmd_diagnose(args: argparse.Namespace) -> int:
    """Confront a case with measured data: V&V 20, candidate extensions ranked, verdict, gain."""

    data = read_csv(args.data)
    case = load_case(args.case)
    r = run_diagnosis(
        data,
        case,
        args.out,
        MPI.COMM_WORLD,
        max_size=1 if args.singles else 2,
        u_model_K=args.u_model_K,
        suggest_next=args.suggest,
        grid=_design_grid(args, case),
    )
    for row in r.vv20.rows:  # in the data's order, each in its reading's unit
        _say("  " + row.line())
    g = r.diagnosis.gain
    _say(f"verdict: {r.diagnosis.verdict.text}")
    if g.loo_rmse_before_K is not None and g.loo_rmse_after_K is not None:
        _say(
            f"held-out RMS error: {g.loo_rmse_before_K:.1f} K before, "
            f"{g.loo_rmse_after_K:.1f} K after{g.other_units_text()}"
        )
    if r.suggestion is not None:
        _say("what to measure next:\n" + r.suggestion.text)
    extra = ", suggestion.json" if r.suggestion is not None else ""
    _say(
        f"results in {args.out}: diagnosis.json, report.md, prediction_vs_data.png, "
        f"ranking.png{extra}"
    )
    return 0


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="gearfem",
        description="Thermomechanical FE model of polymer spur gear pairs (FEniCSx).",
    )
    p.add_argument(
        "--log-level",
        default=None,
        help="DEBUG, INFO, WARNING, ERROR (default: $GEARFEM_LOG_LEVEL or INFO)",
    )
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")

    s = sub.add_parser(
        "info", help="print versions (gearfem, DOLFINx, PETSc, gmsh, MPI) for bug reports"
    )
    s.add_argument("--json", action="store_true", help="print JSON instead of a table")
    s.set_defaults(func=_cmd_info)

    s = sub.add_parser(
        "claims",
        help="list quoted results in README.md and docs/ computed with another resolution or code "
        "than the shipped model's (stale claims), with the command that regenerates each",
    )
    s.add_argument("root", nargs="?", default=".", help="repository root (default: .)")
    s.add_argument(
        "--mark",
        action="store_true",
        help="write a visible 'not re-run on the current model' note into each stale block (and "
        "remove it from blocks that are current again); regenerating a block removes its note",
    )
    s.set_defaults(func=_cmd_claims)

    s = sub.add_parser(
        "keys",
        help="the case file's tables and keys: default, accepted values and meaning of each",
    )
    s.add_argument(
        "table", nargs="?", default=None, help="one table (thermal, instruments.camera, ...)"
    )
    s.add_argument(
        "--case",
        default=None,
        help="show this case file's values where they differ from the defaults (default: the "
        "built-in case's)",
    )
    s.add_argument(
        "--docs", default=None, help="write the Markdown reference into this page's block instead"
    )
    s.set_defaults(func=_cmd_keys)

    s = sub.add_parser(
        "mesh", help="mesh the gear pair of a case: mesh.msh, mesh.json, picture (cached)"
    )
    s.add_argument(
        "case",
        nargs="?",
        default=None,
        help="case TOML with optional [geometry] and [mesh] tables (default: the thesis pair)",
    )
    s.add_argument("--out", required=True, help="output directory")
    s.add_argument(
        "--cache-dir",
        default=None,
        help="mesh cache (default: $GEARFEM_MESH_CACHE or meshes/cache)",
    )
    s.add_argument("--rebuild", action="store_true", help="regenerate even if the mesh is cached")
    s.add_argument("--no-picture", action="store_true", help="skip the PNG")
    s.set_defaults(func=_cmd_mesh)

    s = sub.add_parser(
        "thermal",
        help="temperature history of one gear from the stored cycle or prescribed sources",
    )
    s.add_argument(
        "case", nargs="?", default=None, help="case TOML (default: the built-in thesis case)"
    )
    s.add_argument("--out", required=True, help="output directory")
    s.add_argument(
        "--cache-dir",
        default=None,
        help="mesh cache (default: $GEARFEM_MESH_CACHE or meshes/cache)",
    )
    s.set_defaults(func=_cmd_thermal)

    s = sub.add_parser(
        "cycle", help="solve the mesh cycle at the case torque: load sharing, TE, U_max, flank flux"
    )
    s.add_argument(
        "case", nargs="?", default=None, help="case TOML (default: the built-in thesis case)"
    )
    s.add_argument("--out", required=True, help="output directory")
    s.add_argument(
        "--torque-Nm",
        dest="torque_Nm",
        type=float,
        default=None,
        help="override [operating] torque_Nm",
    )
    s.add_argument("--rebuild", action="store_true", help="recompute even if the cycle is cached")
    s.set_defaults(func=_cmd_cycle)

    s = sub.add_parser(
        "run", help="the whole chain for one operating point (the README's main job)"
    )
    s.add_argument(
        "case", nargs="?", default=None, help="case TOML (default: the built-in thesis case)"
    )
    s.add_argument("--out", required=True, help="output directory")
    s.add_argument(
        "--speed-rpm",
        dest="speed_rpm",
        type=float,
        default=None,
        help="override [operating] speed_rpm",
    )
    s.add_argument(
        "--torque-Nm",
        dest="torque_Nm",
        type=float,
        default=None,
        help="override [operating] torque_Nm",
    )
    s.add_argument(
        "--duration-s",
        dest="duration_s",
        type=float,
        default=None,
        help="override [thermal] duration_s",
    )
    s.add_argument("--no-progress", action="store_true", help="no progress bar")
    s.set_defaults(func=_cmd_run)

    s = sub.add_parser(
        "observe",
        help="read the instruments (camera, probes, torque meters) again on a finished run",
    )
    s.add_argument("result_dir", help="output directory of a finished `gearfem run`")
    s.add_argument(
        "--instrument",
        action="append",
        choices=("camera", "probes", "torque"),
        help="only this instrument (repeatable; default: all configured)",
    )
    s.add_argument(
        "--case",
        default=None,
        help="take the [instruments] table from this case file instead of the run's case.toml",
    )
    s.add_argument("--out", default=None, help="output directory (default: RESULT_DIR/instruments)")
    s.set_defaults(func=_cmd_observe)

    s = sub.add_parser(
        "study", help="speed x torque study (resumable): one cycle per torque, table and plots"
    )
    s.add_argument(
        "study", help="study TOML: a case file with a [study] table (see gearfem/study.py)"
    )
    s.add_argument("--out", required=True, help="output directory (re-running resumes it)")
    s.add_argument(
        "--index", type=int, default=None, help="run only this operating point (cluster array task)"
    )
    s.add_argument(
        "--collect", action="store_true", help="only collect the table and plots of finished cases"
    )
    s.add_argument(
        "--list", action="store_true", help="list the operating points with their indices"
    )
    s.set_defaults(func=_cmd_study)

    s = sub.add_parser(
        "converge",
        help="refinement study (thermal mesh, structural contact zone, structural layers, "
        "positions per pitch or tip elements): observed order, extrapolation, GCI and u_num per "
        "reported quantity",
    )
    s.add_argument("case", nargs="?", default=None, help="case TOML (default: built-in thesis)")
    s.add_argument("--out", required=True, help="output directory")
    s.add_argument(
        "--factor", type=float, default=1.5, help="refinement factor between levels, [1.2, 3]"
    )
    s.add_argument(
        "--kind",
        default="thermal_mesh",
        choices=REFINEMENT_KINDS,
        help="what is refined",
    )
    s.add_argument(
        "--case-level",
        default="coarsest",
        choices=tuple(REFINEMENT_CASE_LEVELS),
        help="where the case's resolution sits among the levels: the coarsest (levels 1, "
        "r, r^2 times finer), the middle (1/r, 1, r: u_num from one coarser and one finer "
        "solution) or the finest (1/r^2, 1/r, 1: the fine-grid GCI)",
    )
    s.add_argument(
        "--levels",
        type=int,
        default=REFINEMENT_LEVELS,
        help=f"number of levels, {REFINEMENT_LEVELS} to {REFINEMENT_MAX_LEVELS} (four or more: a "
        "least-squares fit through all of them, Eça & Hoekstra; the middle case level is then "
        "the second coarsest)",
    )
    s.add_argument("--duration-s", type=float, default=None, help="override [thermal] duration_s")
    s.set_defaults(func=_cmd_converge)

    s = sub.add_parser(
        "diagnose", help="confront the model with measured data, name the cause, measure the gain"
    )
    s.add_argument(
        "data", help="measured-data CSV (gearfem.diagnose.data format, or the thesis bench file)"
    )
    s.add_argument("--case", default=None, help="case TOML (default: the built-in thesis case)")
    s.add_argument("--out", required=True, help="output directory")
    s.add_argument("--singles", action="store_true", help="single candidates only (no pairs)")
    s.add_argument(
        "--u-model-K",
        dest="u_model_K",
        type=float,
        default=1.0,
        help="model (time-step, discretisation) standard uncertainty added to u_D in the fits, K "
        "(the surrogate's own error estimate is added besides)",
    )
    s.add_argument(
        "--suggest",
        action="store_true",
        help="rank the next measurements (bench speed x torque grid, warm-up times, instruments) "
        "by how well they would separate the explanations still standing (suggestion.json)",
    )
    s.add_argument(
        "--suggest-speeds",
        default=None,
        help="speeds the bench can run, rpm, comma-separated (default 500,1000,1500,2000)",
    )
    s.add_argument(
        "--suggest-torques",
        default=None,
        help="torques the bench can run, N m, comma-separated (default 4,6,8)",
    )
    s.add_argument(
        "--suggest-times",
        default=None,
        help="warm-up times one could record, s, comma-separated (default 60,180,300,600,900)",
    )
    s.set_defaults(func=_cmd_diagnose)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)

    try:
        setup_logging(args.log_level)
        return int(args.func(args) or 0)
    except GearfemError as err:
        log.error("%s", err)
        print(f"gearfem {args.command}: error: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
