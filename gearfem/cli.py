"""The ``gearfem`` command.

Every subcommand prints where its results went and exits non-zero on failure; ``gearfem info``
prints the versions a bug report needs.
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import sys
from collections.abc import Sequence

log = logging.getLogger("gearfem.cli")


def _cmd_info(args: argparse.Namespace) -> int:
    from gearfem.provenance import format_versions, versions

    info = versions()
    from mpi4py import MPI

    if MPI.COMM_WORLD.rank == 0:
        print(json.dumps(info, indent=2) if args.json else format_versions(info))
    return 0


def _cmd_mesh(args: argparse.Namespace) -> int:
    """Build (or load) the gear-pair mesh of a case; write mesh.msh, mesh.json and a picture."""
    import shutil
    import tomllib
    from pathlib import Path

    from mpi4py import MPI

    from gearfem.errors import ParameterError
    from gearfem.geometry.gmsh_pair import MeshOptions
    from gearfem.geometry.involute import GearPairGeometry
    from gearfem.geometry.mesh import build_gear_mesh, mesh_report, plot_pair, write_json_atomic
    from gearfem.params import from_dict

    case: dict = {}
    if args.case is not None:
        try:
            case = tomllib.loads(Path(args.case).read_text())
        except (OSError, tomllib.TOMLDecodeError) as err:
            raise ParameterError("CASE", str(args.case), "a readable TOML file", str(err)) from None
    geometry = from_dict(GearPairGeometry, case.get("geometry", {}), "geometry")
    options = from_dict(MeshOptions, case.get("mesh", {}), "mesh")
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
            png = plot_pair(gm.msh_path, out / ".gear_pair_mesh.tmp.png",
                            focus_mm=tuple(report["reference"]["pitch_point_mm"]),
                            face_width_mm=geometry.face_width_mm,
                            title=f"{report['counts']['cells']} {report['element']['cell_type']} cells, "
                                  f"{report['counts']['dofs_p2_vector']} P2 vector DOFs")
            os.replace(png, out / "gear_pair_mesh.png")
        write_json_atomic(out / "mesh.json", report)  # last: its presence marks a complete output
        c, t = report["counts"], report["timing"]
        q = report["quality"]
        print(f"mesh {gm.cache_key}: {c['cells']} cells ({report['element']['cell_type']}), {c['nodes']} nodes, "
              f"{c['dofs_p2_vector']} P2 vector DOFs; min scaled Jacobian {q['min_scaled_jacobian']:.3f}")
        for body, v in report["volumes"].items():
            print(f"  {body}: volume {v['fe_mm3']:.3f} mm^3 "
                  f"(analytic {v['analytic_mm3']:.3f}, rel. error {v['rel_error']:.1e})")
        print(f"  {len(report['groups'])} named groups; "
              f"build {t['build_time_s']:.1f} s, import {t['import_time_s']:.1f} s")
        written = [out / "mesh.msh", out / "mesh.json"] + ([] if args.no_picture else [out / "gear_pair_mesh.png"])
        print("wrote " + ", ".join(str(w) for w in written))
    return 0


def _cmd_thermal(args: argparse.Namespace) -> int:
    """Transient (or steady) temperature of one gear from prescribed sources."""
    from mpi4py import MPI

    from gearfem.thermal.case import read_case, run_thermal_case

    summary = run_thermal_case(read_case(args.case), args.out, cache_dir=args.cache_dir)
    if MPI.COMM_WORLD.rank == 0:
        T = summary["final_temperatures_C"]
        print(f"thermal: t = {summary['time_s']:g} s, {summary['steps']} steps, {summary['dofs']} DOFs, "
              f"T max surface {T['max_surface']:.1f} C, mean bulk {T['mean_bulk']:.1f} C; "
              f"results in {args.out} (thermal_history.csv, temperature.bp, thermal_history.png, "
              f"thermal_summary.json)")
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

    s = sub.add_parser("info", help="print versions (gearfem, DOLFINx, PETSc, gmsh, MPI) for bug reports")
    s.add_argument("--json", action="store_true", help="print JSON instead of a table")
    s.set_defaults(func=_cmd_info)

    s = sub.add_parser("mesh", help="mesh the gear pair of a case: mesh.msh, mesh.json, picture (cached)")
    s.add_argument("case", nargs="?", default=None,
                   help="case TOML with optional [geometry] and [mesh] tables (default: the thesis pair)")
    s.add_argument("--out", required=True, help="output directory")
    s.add_argument("--cache-dir", default=None, help="mesh cache (default: $GEARFEM_MESH_CACHE or meshes/cache)")
    s.add_argument("--rebuild", action="store_true", help="regenerate even if the mesh is cached")
    s.add_argument("--no-picture", action="store_true", help="skip the PNG")
    s.set_defaults(func=_cmd_mesh)

    s = sub.add_parser("thermal", help="temperature history of one gear (prescribed sources until the cycle exists)")
    s.add_argument("case", help="case TOML: [geometry] [mesh] [material] [operating] [thermal] [sources]")
    s.add_argument("--out", required=True, help="output directory")
    s.add_argument("--cache-dir", default=None, help="mesh cache (default: $GEARFEM_MESH_CACHE or meshes/cache)")
    s.set_defaults(func=_cmd_thermal)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    from gearfem.errors import GearfemError
    from gearfem.log import setup_logging

    try:
        setup_logging(args.log_level)
        return int(args.func(args) or 0)
    except GearfemError as err:
        log.error("%s", err)
        print(f"gearfem {args.command}: error: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
