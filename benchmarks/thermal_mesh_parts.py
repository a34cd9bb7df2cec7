"""Which part of the thermal mesh moves the hottest surface temperature: the pinion's thermal
run on a case's cached cycle with ``[thermal_mesh]`` options replaced.

Prints one line ``RESULT {json}`` with the options set, the thermal DOFs, the hottest node, the
field's surface maximum (between the nodes) and where it is (radius and axial position from the
gear's centre, mm), and the run's wall time. The tables of docs/refinement.md, "Graded layers
across the face width" (stop 35), were assembled by hand from these lines:

    mpirun -n 2 python benchmarks/thermal_mesh_parts.py \
        --case benchmarks/studies/3802072c5835f948/case.toml --set layers=8 --out OUT
    mpirun -n 2 python benchmarks/thermal_mesh_parts.py --set layers=6 --out OUT
    mpirun -n 2 python benchmarks/thermal_mesh_parts.py \
        --set teeth_in_model=1 refined_teeth=1 periodic_cuts=true --out OUT

(``--case`` omitted: the built-in case.) The case's cycle must be in the cache or is solved
first. About 100 s (106k DOFs) to 1200 s (786k DOFs) on 2 ranks.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import time
from pathlib import Path

from mpi4py import MPI

import gearfem  # noqa: F401  (must precede dolfinx/petsc4py)
from gearfem import pipeline
from gearfem.config import load_case

#: the ``[thermal_mesh]`` options that are whole numbers
INTEGER_OPTIONS = ("layers", "teeth_in_model", "refined_teeth")
#: the ``[thermal_mesh]`` options that are true or false
BOOLEAN_OPTIONS = ("periodic_cuts",)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--case", default=None, help="case TOML (default: the built-in case)")
    p.add_argument("--set", nargs="*", default=[], help="KEY=VALUE of [thermal_mesh]")
    p.add_argument("--out", required=True)
    args = p.parse_args()
    comm = MPI.COMM_WORLD
    case = load_case(args.case)
    changes = {}
    for item in args.set:
        key, _, value = item.partition("=")
        if key in BOOLEAN_OPTIONS:
            changes[key] = {"true": True, "false": False}[value.lower()]
        else:
            changes[key] = int(value) if key in INTEGER_OPTIONS else float(value)
    case = dataclasses.replace(
        case, thermal_mesh=dataclasses.replace(case.thermal_mesh_options, **changes)
    )
    cycle, _, _ = pipeline.cycle(case, comm)
    t0 = time.perf_counter()
    thermal, field = pipeline.thermal_field(
        case,
        Path(args.out),
        comm,
        cycle,
        write_fields=False,
        steady=False,
        write_plot=False,
        record=True,
    )
    wall_s = time.perf_counter() - t0
    if comm.rank == 0:
        last = field.temperature_K.shape[0] - 1
        hottest_K, x = field.hottest_point(last)
        rel = x - field.center_m
        result = {
            "set": changes,
            "dofs": thermal["dofs"],
            "max_surface": thermal["final_temperatures_C"]["max_surface"],
            "field_max": hottest_K - 273.15,
            "r_mm": math.hypot(rel[0], rel[1]) * 1e3,
            "z_mm": rel[2] * 1e3,
            "wall_s": wall_s,
            # counts and rank 0's seconds of the transient Newton solver (Jacobians, residuals,
            # linear solves with their factorisations)
            "transient_solver": thermal.get("transient_solver"),
        }
        print("RESULT", json.dumps(result), flush=True)


if __name__ == "__main__":
    main()
