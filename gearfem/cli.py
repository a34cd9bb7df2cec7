"""The ``gearfem`` command.

Every subcommand prints where its results went and exits non-zero on failure; ``gearfem info``
prints the versions a bug report needs.
"""

from __future__ import annotations

import argparse
import json
import logging
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
