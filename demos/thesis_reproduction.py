"""Reproduce the thesis's simulations and bench points (Doll 2015, 5.3.3 and 6.2) with gearfem.

The operating points of ``gearfem/data/testbench/thesis_simulation_results.csv`` and of the bench
(``thesis_testbench.csv`` beside it), all with the thesis's model choices (PEEK 450G, μ = 0.5
constant, thesis convection correlations, radiation ε = 0.9, adiabatic bore and cut faces,
hysteresis with f = rotational frequency):

    label              speed   torque  duration  hysteresis  thesis (ANSYS)            bench
    20Nm               1000    20      6000 s    on          about 137 C               -
    20Nm_friction      1000    20      6000 s    off         nearly 100 C rise         -
    15Nm               1000    15      6000 s    on          hysteresis adds ~2 C      -
    15Nm_friction      1000    15      6000 s    off         -                         -
    10Nm_2000rpm       2000    10      6000 s    on          (full vs fractional 1.5 C)-
    bench_8Nm          1000    8       900 s     on          ~105 C (h lowered)        110 C
    bench_4Nm          2000    4       900 s     on          ~57 C (h lowered)         49 C

One structural cycle per torque (cached), then every thermal run; cycles and thermal runs are
dealt to the ranks (``gearfem.study``'s dispatch). The mesh is a parameter: ``case`` (the built-in
thesis case's: 8 teeth, 2 layers, 0.3 mm flank elements, 12 positions per pitch — the main job's
resolution), ``coarse`` (6 teeth, 8 positions per pitch; the test case) or ``fine`` (the
MeshOptions default, 171k DOFs, 24 positions per pitch; hours on 2 cores for the five cycles).

Parameters (command-line options, defaults in brackets):
    --mesh M          case | coarse | fine  [case]
    --degree P        temperature element degree, 1 or 2 [2]
    --out DIR         output directory [results/demos/thesis_reproduction]

Outputs (DIR): cases/<label>/ (each point's ``gearfem run`` output), reproduction.csv and
reproduction.md (ours vs the thesis's statement vs the bench, with hysteresis increments),
reproduction.png (maximum surface temperature histories with the bench values), summary.json last.

Run:
    python demos/thesis_reproduction.py
    mpirun -n 2 python demos/thesis_reproduction.py
"""

# %% [markdown]
# # Reproducing the thesis, step by step
#
# Each operating point is a :class:`~gearfem.config.Case` (the thesis model choices, the point's
# speed, torque and duration). The chain of one point is :func:`gearfem.pipeline.run`: the pair
# mesh → the structural cycle at the torque (cached) → heat sources at the speed (hysteresis
# $H(T)U_{max}f$, friction $\mu p v_s$ averaged over a revolution and split between the gears)
# → the transient temperature of the pinion → a typed :class:`~gearfem.pipeline.RunSummary`.
# Here: build the meshes once, solve one cycle per torque, then every thermal run, the work
# dealt to the ranks with :func:`gearfem.study.dispatch`.

# %%
from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from pathlib import Path

from mpi4py import MPI

import gearfem  # noqa: F401  (must precede dolfinx/petsc4py)
from gearfem import pipeline
from gearfem.config import load_case
from gearfem.geometry.mesh import build_gear_mesh
from gearfem.geometry.options import MeshOptions
from gearfem.pipeline import RunSummary
from gearfem.study import dispatch, is_done, parallel_mode

COARSE = MeshOptions(
    teeth_in_model=6,
    refined_teeth=4,
    layers=2,
    size_flank_mm=0.3,
    size_tip_mm=0.3,
    size_root_mm=0.4,
    size_tooth_mm=1.2,
    size_body_mm=4.0,
)

# label, speed rpm, torque N m, duration s, hysteresis, thesis statement, thesis value C, bench C
POINTS = [
    ("20Nm", 1000.0, 20.0, 6000.0, True, "about 137 C (full 30-tooth model)", 137.0, None),
    (
        "20Nm_friction",
        1000.0,
        20.0,
        6000.0,
        False,
        "friction alone: nearly 100 C rise",
        123.0,
        None,
    ),
    ("15Nm", 1000.0, 15.0, 6000.0, True, "hysteresis adds about 2 C", None, None),
    ("15Nm_friction", 1000.0, 15.0, 6000.0, False, "-", None, None),
    (
        "10Nm_2000rpm",
        2000.0,
        10.0,
        6000.0,
        True,
        "full and fractional models differ by 1.5 C",
        None,
        None,
    ),
    (
        "bench_8Nm",
        1000.0,
        8.0,
        900.0,
        True,
        "about 5 C below the bench after lowering h",
        105.0,
        110.0,
    ),
    (
        "bench_4Nm",
        2000.0,
        4.0,
        900.0,
        True,
        "about 8 C above the bench after lowering h",
        57.0,
        49.0,
    ),
]


def cases(mesh: str, degree: int | None):
    base = load_case(None)
    if mesh == "coarse":
        base = dataclasses.replace(
            base, mesh=COARSE, cycle=dataclasses.replace(base.cycle, positions_per_pitch=8)
        )
    elif mesh == "fine":
        base = dataclasses.replace(
            base, mesh=MeshOptions(), cycle=dataclasses.replace(base.cycle, positions_per_pitch=24)
        )
    deg = degree or 2
    out = []
    for label, n, T, dur, hyst, stmt, thesis, bench in POINTS:
        c = base.with_operating(speed_rpm=n, torque_Nm=T)
        c = dataclasses.replace(
            c,
            name=f"thesis reproduction {label}",
            sources=dataclasses.replace(c.sources, hysteresis=hyst),
            thermal=dataclasses.replace(
                c.thermal,
                duration_s=dur,
                degree=deg,
                output_times_s=(900.0,) if dur > 900.0 else (),
            ),
        )
        out.append(
            (label, c, dict(statement=stmt, thesis_C=thesis, bench_C=bench, hysteresis=hyst))
        )
    return out


def table(rows, out: Path) -> str:
    by = {r["label"]: r for r in rows}
    lines = [
        "| point | speed rpm | torque N m | t s | hysteresis | ours T_max C | ours at 900 s C | "
        "ours bulk C | friction W/gear | hysteresis W/gear | VDI 2736 flank C | thesis | bench C |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        at900 = r.get("at_900_C")
        lines.append(
            f"| {r['label']} | {r['speed_rpm']:g} | {r['torque_Nm']:g} | {r['time_s']:g} | "
            f"{'on' if r['hysteresis'] else 'off'} | {r['max_surface_C']:.1f} | "
            f"{'' if at900 is None else f'{at900:.1f}'} | {r['mean_bulk_C']:.1f} | "
            f"{r['friction_W']:.1f} | "
            f"{r['hysteresis_W']:.2f} | {r['vdi2736_flank_C']:.1f} | {r['statement']} | "
            f"{'' if r['bench_C'] is None else r['bench_C']:} |"
        )
    for T in ("20Nm", "15Nm"):
        if T in by and f"{T}_friction" in by:
            d = by[T]["max_surface_C"] - by[f"{T}_friction"]["max_surface_C"]
            lines.append(
                f"\nHysteresis adds {d:.1f} C to the maximum surface temperature at {T[:-2]} N m "
                f"(thesis: {'about 6' if T == '20Nm' else 'about 2'} C)."
            )
    text = "\n".join(lines) + "\n"
    (out / "reproduction.md").write_text(text)
    return text


def plot(rows, out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    fig, ax = plt.subplots(figsize=(8, 5))
    for r in rows:
        d = np.genfromtxt(
            out / "cases" / r["label"] / "thermal" / "thermal_history.csv",
            delimiter=",",
            names=True,
        )
        (line,) = ax.plot(
            d["time_s"] / 60,
            d["T_max_surface_C"],
            label=f"{r['label']} ({r['speed_rpm']:g} rpm, {r['torque_Nm']:g} N m)",
        )
        if r["bench_C"] is not None:
            ax.plot([15.0], [r["bench_C"]], "s", color=line.get_color(), ms=9, mfc="none")
        if r["thesis_C"] is not None:
            ax.plot([r["time_s"] / 60], [r["thesis_C"]], "^", color=line.get_color(), ms=8)
    ax.plot([], [], "ks", mfc="none", label="bench (IR camera, 15 min)")
    ax.plot([], [], "k^", label="thesis ANSYS model (as stated)")
    ax.set_xlabel("time (min)")
    ax.set_ylabel("maximum surface temperature (°C)")
    ax.set_title("gearfem vs the thesis's model and bench (PEEK 450G, 30/30 teeth, μ = 0.5)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(out / "reproduction.png", dpi=130)
    plt.close(fig)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--mesh", default="case", choices=("case", "coarse", "fine"))
    p.add_argument("--degree", type=int, default=None, choices=(1, 2))
    p.add_argument("--out", default="results/demos/thesis_reproduction")
    args = p.parse_args(argv)
    comm = MPI.COMM_WORLD
    out = Path(args.out)
    t0 = time.perf_counter()
    todo = cases(args.mesh, args.degree)
    if comm.rank == 0:
        (out / "cases").mkdir(parents=True, exist_ok=True)
        (out / "summary.json").unlink(missing_ok=True)
    comm.barrier()

    # %% [markdown]
    # ## 1. Meshes (the pair for the cycle, one gear for the thermal model), built once

    # %%
    c0 = todo[0][1]
    pipeline.pair_mesh(c0, comm)
    build_gear_mesh(c0.geometry, c0.thermal_mesh_options, comm, bodies=("pinion",))

    # %% [markdown]
    # ## 2. One structural cycle per torque (cached), then every operating point

    # %%
    reps = {}
    for _, c, _ in todo:
        reps.setdefault(c.operating.torque_Nm, c)
    dispatch(
        comm,
        parallel_mode("auto", len(reps), comm.size),
        list(reps.values()),
        lambda c, sub: pipeline.cycle(c, sub),
    )
    # finished points are decided on rank 0 and broadcast (every rank must take the same tasks)
    done = comm.bcast(
        [is_done(c, out / "cases" / lab) for lab, c, _ in todo] if comm.rank == 0 else None
    )
    pending = [(lab, c) for (lab, c, _), d in zip(todo, done) if not d]
    dispatch(
        comm,
        parallel_mode("auto", len(pending), comm.size),
        pending,
        lambda item, sub: pipeline.run(
            item[1], out / "cases" / item[0], sub, progress=False, write_fields=False
        ),
    )

    # %% [markdown]
    # ## 3. Ours vs the thesis vs the bench, from the typed summaries

    # %%
    if comm.rank == 0:
        rows = []
        for lab, c, meta in todo:
            s = RunSummary.read(out / "cases" / lab / "summary.json")
            th = s.thermal
            frac = th["model_fraction"]
            rows.append(
                dict(
                    label=lab,
                    speed_rpm=c.operating.speed_rpm,
                    torque_Nm=c.operating.torque_Nm,
                    time_s=th["time_s"],
                    max_surface_C=th["final_temperatures_C"]["max_surface"],
                    mean_bulk_C=th["final_temperatures_C"]["mean_bulk"],
                    at_900_C=th.get("at_times_C", {}).get("900", {}).get("max_surface"),
                    friction_W=th["final_balance_W"]["friction_W"] / frac,
                    hysteresis_W=th["final_balance_W"]["hysteresis_W"] / frac,
                    vdi2736_flank_C=s.headline.vdi2736_flank_C,
                    effective_contact_ratio=s.cycle.effective_contact_ratio,
                    **meta,
                )
            )
        import csv

        with (out / "reproduction.csv").open("w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)
        print(table(rows, out))
        plot(rows, out)
        (out / "summary.json").write_text(
            json.dumps(
                {
                    "mesh": args.mesh,
                    "rows": rows,
                    "ranks": comm.size,
                    "wall_time_s": time.perf_counter() - t0,
                },
                indent=2,
            )
        )
        print(
            f"wrote {out / 'reproduction.md'}, {out / 'reproduction.csv'}, "
            f"{out / 'reproduction.png'}"
        )
    comm.barrier()
    return 0


if __name__ == "__main__":
    sys.exit(main())
