"""A speed × torque study of the thesis gear pair: one structural cycle per torque, every speed.

The study (written to OUT/study.toml, then run exactly as ``gearfem study OUT/study.toml --out
OUT``)
uses the thesis gears and material on a coarse mesh so that it finishes in minutes on 2 cores:
6 of 30 teeth per gear, 2 element layers, flank elements of 0.3 mm, 8 positions per pitch,
first-order thermal elements. The structural cycle is computed once per torque and cached; every
speed reuses it (the friction flux is stored per unit speed). Re-running resumes: finished
operating points are not recomputed.

Parameters (command-line options, defaults in brackets):
    --speeds-rpm N...      pinion speeds, rpm [500 1000 2000]
    --torques-Nm T...      resisting torques on the wheel, N m [4 8]
    --duration-s D         simulated running time per point, s [900: when the bench was read]
    --friction MU          Coulomb friction coefficient, dimensionless [0.5: thesis 5.1.2]
    --parallel P           cases | mpi | auto: how the ranks share the work (docs/study.md) [auto]
    --out DIR              output directory [results/demos/study]

Outputs (DIR): study.toml (the study as run), results.csv and study.json (one row per operating
point: heat, temperatures, contact ratio, pressure, VDI 2736 and Mao baselines, wall time),
temperature_histories.png, steady_temperature.png, cases/<label>/ (each point's full
``gearfem run`` output). study.json is written last.

Run:
    python demos/study.py
    mpirun -n 2 python demos/study.py        # two operating points at a time
"""

# %% [markdown]
# # A speed × torque study, step by step
#
# A study is a case file plus a ``[study]`` table of operating points. For each torque the
# structural cycle is solved once (quasi-static: it does not depend on speed) and cached; for each
# speed the thermal model takes the cycle's sources at that speed — the friction flux
# $q = \mu p v_s$ scales with the speed, the hysteresis heat $H(T) U_{max} f$ with $f = n/60$ —
# and the thesis convection at that speed. Steps: write the study file → :func:`load_study`
# (validated) → :func:`run_study` (resumable; ``parallel`` says whether ranks share one point or
# take one point each) → the typed :class:`~gearfem.study.StudyResult` and its table and plots.

# %%
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import tomli_w
from mpi4py import MPI

import gearfem  # noqa: F401  (must precede dolfinx/petsc4py)
from gearfem.study import load_study, run_study

COARSE_MESH = {
    "teeth_in_model": 6,
    "refined_teeth": 4,
    "layers": 2,
    "size_flank_mm": 0.3,
    "size_tip_mm": 0.3,
    "size_root_mm": 0.4,
    "size_tooth_mm": 1.2,
    "size_body_mm": 4.0,
}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--speeds-rpm", type=float, nargs="+", default=[500.0, 1000.0, 2000.0])
    p.add_argument("--torques-Nm", type=float, nargs="+", default=[4.0, 8.0])
    p.add_argument("--duration-s", type=float, default=900.0)
    p.add_argument("--friction", type=float, default=0.5)
    p.add_argument("--parallel", default="auto", choices=("auto", "cases", "mpi"))
    p.add_argument("--out", default="results/demos/study")
    args = p.parse_args(argv)
    comm = MPI.COMM_WORLD
    out = Path(args.out)

    # %% [markdown]
    # ## 1. The study file: the case tables plus [study]

    # %%
    study = {
        "name": "thesis gears: speed x torque (coarse mesh)",
        "mesh": COARSE_MESH,
        "cycle": {"positions_per_pitch": 8},
        "contact": {"friction_coefficient": args.friction},
        "thermal": {
            "duration_s": args.duration_s,
            "degree": 1,
            "output_times_s": [min(300.0, args.duration_s)],
        },
        "study": {
            "speeds_rpm": args.speeds_rpm,
            "torques_Nm": args.torques_Nm,
            "parallel": args.parallel,
        },
    }
    if comm.rank == 0:
        out.mkdir(parents=True, exist_ok=True)
        (out / "study.toml").write_text(tomli_w.dumps(study))
    comm.barrier()

    # %% [markdown]
    # ## 2. Run (or resume) and read the typed result

    # %%
    res = run_study(load_study(out / "study.toml"), out, comm)
    if comm.rank == 0:
        print(
            f"{'speed rpm':>10} {'torque Nm':>10} {'friction W':>10} {'T_max end C':>11} "
            f"{'VDI flank C':>11}"
        )
        for r in res.results:
            print(
                f"{r.speed_rpm:10g} {r.torque_Nm:10g} {r.friction_W:10.1f} "
                f"{r.max_surface_end_C:11.1f} "
                f"{r.vdi2736_flank_C:11.1f}"
            )
        print(
            f"wrote {out / 'results.csv'}, {out / 'steady_temperature.png'}, "
            f"{out / 'temperature_histories.png'}, {out / 'study.json'}"
        )
    return 0 if res.complete else 1


if __name__ == "__main__":
    sys.exit(main())
