"""Where a bench point's branch is decided under a glass-transition friction law, and whether
the model decides it with converged quantities.

A friction coefficient that steps up at the glass transition makes each gear bistable; a run from
ambient ends on the cool branch wherever it exists (gearfem.thermal.branches), so the branch of a
bench point is decided by where the cool branch ends: its fold. This script measures, for the
built-in case with ``[friction] law = "glass_transition"`` at glassy mu ``--mu-glassy``, at each
bench point (1000 rpm / 8 N m, 2000 rpm / 4 N m) and gear:

* the friction-heat scale at the cool branch's fold, lambda_f (the point runs on the cool branch
  when lambda_f > 1; lambda_f - 1 is its margin in heat, to first order in torque), by
  continuation of the cool branch (:func:`gearfem.thermal.branches.trace_lowest_branch`);
* at the last cool state before the fold, the contact that switches first (the hottest contact
  temperature, flank + flash): where it lies (on the involute or on the mate's tip round, its
  radius on the gear), the load per unit length of its band, the half-width its flash is computed
  with and the flash;

for these variants of the model, each a structural cycle per torque:

* ``entry``: the elements at the entering tip round and the mate's flank foot (``[mesh]
  size_entry_mm`` x 1.5, x 1, / 1.5): the refinement that resolves the corner contact;
* ``tip radius``: the tip-round radius (``[geometry] tip_round_coefficient`` 0.05 / 0.1 / 0.15,
  0.1 / 0.2 / 0.3 mm for m = 2 mm), an input the thesis does not measure;
* ``flash width``: the flash temperature on the Hertz width of each band's load (``"hertz"``, the
  default) or on its pressure profile's width (``"profile"``), on the case's cycle.

``--flash-width`` sets the width every variant's flash is computed on; ``stated`` with
``--flash-half-width-um`` takes one half-width for every band, a length no refinement changes.

Prints the table and, with ``--docs PAGE``, writes it into block ``branch_switching`` of PAGE.

    mpirun -n 2 python benchmarks/verification/branch_switching.py --mu-glassy 0.14 \
        [--docs docs/friction.md]
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import time

import numpy as np
from mpi4py import MPI

import gearfem  # noqa: F401  (must precede dolfinx/petsc4py)
from gearfem import pipeline
from gearfem.config import load_case
from gearfem.contact.friction import PASS_BALANCES, FrictionOptions
from gearfem.core.doctables import markdown_table, replace_block
from gearfem.core.log import setup_logging
from gearfem.core.materials import ZERO_CELSIUS_K
from gearfem.core.tasks import run_split
from gearfem.geometry.options import BODIES
from gearfem.thermal.branches import SAFE_SCALE, trace_lowest_branch
from gearfem.uncertainty import provenance

POINTS = ((1000.0, 8.0), (2000.0, 4.0))
AMBIENT_C = 21.0


#: The entry refinement: ``[mesh] size_entry_mm`` x 1.5, x 1, / 1.5 (coarse to fine).
ENTRY_FACTORS = (1.5, 1.0, 1.0 / 1.5)
#: The tip-round radii besides the case's, in modules (0.1 and 0.3 mm for m = 2 mm).
TIP_ROUND_COEFFICIENTS = (0.05, 0.15)


def entry_variants(case) -> list[tuple[float, object]]:
    """(entry element size in mm, case) of the entry refinement, coarse to fine."""
    m = case.mesh
    out = []
    for f in ENTRY_FACTORS:
        mesh = dataclasses.replace(m, size_entry_mm=round(m.size_entry_mm * f, 6))
        out.append((mesh.size_entry_mm, dataclasses.replace(case, mesh=mesh)))
    return out


def tip_round_variants(case) -> list[tuple[float, object]]:
    """(tip-round coefficient, case) of the other tip-round radii."""
    g = case.geometry
    return [
        (c, dataclasses.replace(case, geometry=dataclasses.replace(g, tip_round_coefficient=c)))
        for c in TIP_ROUND_COEFFICIENTS
    ]


def variants(case, which: tuple[str, ...]):
    """(label, case) of every variant."""
    out = []
    if "entry" in which:
        out += [(f"entry {e * 1e3:.1f} um", c) for e, c in entry_variants(case)]
    if "tip_radius" in which:
        module = case.geometry.module_mm
        out += [(f"tip round {k * module:.2f} mm", c) for k, c in tip_round_variants(case)]
    if "flash_width" in which:
        fr = dataclasses.replace(case.friction, flash_width="profile", flash_half_width_um=None)
        out.append(("flash on the profile width", dataclasses.replace(case, friction=fr)))
    return out


def switching(case, speed: float, torque: float, comm) -> dict:
    """Per gear: the fold scale and the first contact to switch (collective)."""
    cyc, _, _ = pipeline.cycle(case.with_operating(torque_Nm=torque), comm)

    def one_gear(gear: str, sub):
        c = case.with_operating(speed_rpm=speed, torque_Nm=torque)
        c = dataclasses.replace(
            c,
            thermal=dataclasses.replace(
                c.thermal, body=gear, mode="steady", ambient_C=AMBIENT_C, output_times_s=()
            ),
        )
        setup = pipeline.thermal_problem(c, sub, cyc)
        problem = setup.problem
        with problem:
            fold, x = trace_lowest_branch(problem, problem.set_friction_scale, SAFE_SCALE, 3.0, 1.0)
            out = {"fold": fold.fold, "cool": fold.cool, "gone": fold.gone, "solves": fold.solves}
            if x is not None:
                problem.set_state(x)
                problem.set_friction_scale(fold.cool)
                problem.solve_steady()  # the flux model's state at the last cool point
                x.destroy()
                flux = problem.sources.flank_flux_model
                st, bands = flux.state, flux.bands
                k_loc = int(np.argmax(st.contact_K)) if len(st.contact_K) else -1
                best = st.contact_K[k_loc] if k_loc >= 0 else -np.inf
                top = sub.allreduce(float(best), op=MPI.MAX)
                info = None
                if k_loc >= 0 and best == top:
                    inst = flux.flux.inst
                    p = inst.point[k_loc]
                    b = bands.band[p]
                    h = cyc.history
                    ev = bands.event[p]
                    prof = setup.gear_mesh.pair.profile(gear)
                    r = float(
                        np.linalg.norm(
                            h.point_m[ev][:2] - np.asarray(setup.gear_mesh.center(gear))[:2]
                        )
                    )
                    info = {
                        "contact_C": float(top - ZERO_CELSIUS_K),
                        "flash_K": float(st.flash_K[k_loc]),
                        "flank_C": float(st.contact_K[k_loc] - st.flash_K[k_loc] - ZERO_CELSIUS_K),
                        "radius_mm": r * 1e3,
                        "on_tip_round": bool(r > prof.tip_form_radius_m),
                        "load_N_mm": float(bands.load_per_length_N_m[b]) * 1e-3,
                        "half_width_um": float(bands.half_width_m[b]) * 1e6,
                        "position": int(bands.position[b]),
                    }
                infos = sub.allgather(info)
                out["switch"] = next((i for i in infos if i is not None), None)
        return out

    return run_split(comm, BODIES, one_gear)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mu-glassy", type=float, default=0.14)
    ap.add_argument(
        "--variants", nargs="*", default=["entry", "tip_radius", "flash_width"],
        choices=["entry", "tip_radius", "flash_width"],
    )  # fmt: skip
    ap.add_argument(
        "--flash-width", choices=["hertz", "profile", "stated"], default="hertz",
        help="the width every variant's flash temperature is computed on ([friction] flash_width)",
    )  # fmt: skip
    ap.add_argument(
        "--flash-half-width-um", type=float, default=None,
        help="the stated half-width ([friction] flash_half_width_um; with --flash-width stated)",
    )  # fmt: skip
    ap.add_argument(
        "--pass-balance", choices=PASS_BALANCES, default="cycle",
        help="how each gear's pass of the contact history is scaled ([friction] pass_balance)",
    )  # fmt: skip
    ap.add_argument("--docs", default=None, help="write the table into this page")
    ap.add_argument(
        "--block",
        choices=(
            "branch_switching",
            "branch_switching_profile_flash",
            "branch_switching_balanced",
        ),
        default="branch_switching",
        help="the page's block to write",
    )
    a = ap.parse_args()
    setup_logging("WARNING")
    comm = MPI.COMM_WORLD
    base = load_case(None)
    base = dataclasses.replace(
        base,
        friction=FrictionOptions(
            law="glass_transition",
            mu_glassy=a.mu_glassy,
            flash_width=a.flash_width,
            flash_half_width_um=a.flash_half_width_um,
            pass_balance=a.pass_balance,
        ),
    )
    rows = []
    t0 = time.perf_counter()
    for label, case in variants(base, tuple(a.variants)):
        for speed, torque in POINTS:
            res = switching(case, speed, torque, comm)
            for gear in BODIES:
                r = res[gear]
                s = r.get("switch") or {}
                fold = r["fold"]
                lam = (
                    "> 3"
                    if fold is None and r["cool"] is not None
                    else ("< 0.2" if fold is None else f"{fold:.3f}")
                )
                rows.append(
                    (
                        label,
                        f"{speed:g} rpm, {torque:g} N m",
                        gear,
                        lam,
                        "cool"
                        if (fold is None and r["cool"] is not None) or (fold or 0) > 1
                        else "hot",
                        f"{s.get('contact_C', math.nan):.1f}",
                        f"{s.get('flank_C', math.nan):.1f} + {s.get('flash_K', math.nan):.1f}",
                        f"{s.get('radius_mm', math.nan):.2f}"
                        + (" (tip round)" if s.get("on_tip_round") else ""),
                        f"{s.get('load_N_mm', math.nan):.1f}",
                        f"{s.get('half_width_um', math.nan):.0f}",
                    )
                )
            if comm.rank == 0:
                print(rows[-2:], flush=True)
    head = (
        "model",
        "bench point",
        "gear",
        "fold scale lambda_f",
        "lands",
        "first to switch: contact (C)",
        "flank + flash (K)",
        "radius (mm)",
        "load (N/mm)",
        "half-width (um)",
    )
    table = markdown_table(head, rows)
    law = base.friction_law()  # T_g, width and rubbery mu as the case resolves them
    note = (
        f"\n\nBuilt-in case, glass-transition friction with glassy mu {a.mu_glassy:g} (T_g "
        f"{law.tg_K - ZERO_CELSIUS_K:g} C, w {law.width_K:g} K, rubbery {law.mu_rubbery:g}), "
        f"ambient {AMBIENT_C:g} C; the fold scale is where each gear's cool "
        "branch ends in the friction-heat scale (> 1: the point runs cool), the first contact to "
        "switch is the hottest at the last cool state. "
        f"`mpirun -n {comm.size} python benchmarks/verification/branch_switching.py "
        f"--mu-glassy {a.mu_glassy:g}"
        + (f" --flash-width {a.flash_width}" if a.flash_width != "hertz" else "")
        + (
            f" --flash-half-width-um {a.flash_half_width_um:g}"
            if a.flash_half_width_um is not None
            else ""
        )
        + (f" --pass-balance {a.pass_balance}" if a.pass_balance != "cycle" else "")
        + (f" --variants {' '.join(a.variants)}" if len(a.variants) < 3 else "")
        + f"`, {time.perf_counter() - t0:.0f} s."
    )
    if comm.rank == 0:
        print(table + note)
        if a.docs:
            replace_block(a.docs, a.block, table + note, provenance(base))


if __name__ == "__main__":
    main()
