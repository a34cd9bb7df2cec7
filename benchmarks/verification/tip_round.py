"""The tip-round contact of the built-in case under refinement of the tip elements: does the peak
pressure converge, and how much load and friction heat pass through the tip rounds?

The thesis gears have a tip round of radius rho_a = 0.1 m (0.2 mm at m = 2) between the involute
and the tip circle. When the next pair enters mesh, the wheel's (and, at the end of contact, the
pinion's) tip round touches the mate's flank below its start of active profile: a contact of a
small convex radius with a corner-like transition, where the peak pressure need not converge as
the tip elements shrink. This script
solves the cycle at the three refinement levels (factors 1, 1.5, 2.25, cycles cached) of two
directions: the tip elements alone (``[mesh] size_tip_mm``, as ``gearfem converge --kind tip``) and
the whole contact zone with them (flank, tip, root and tooth sizes, as ``--kind structural_mesh``:
the mate's flank, which the round presses on, refined too). Per level it reports, from the contact
history (:mod:`gearfem.cycle.history`):

* the largest contact pressure anywhere and on the tip rounds (points at radius >= r_Fa, the tip
  form radius where the round meets the involute, of the slave gear that owns the round);
* the normal force through the tip rounds, mean over the positions and largest, and its share of
  the mean normal load;
* the friction heat generated at tip-round contacts (μ p ŝ·v_T) and its share of the friction
  power;
* how much of the maximum surface temperature and of the camera reading comes from it: the
  thermal runs of both gears again with the friction flux recomputed from the contact history
  without the tip-round contacts (first order: the other contacts' pressures unchanged), so that
  the reading's change under refinement splits into the tip rounds' part and the rest.

With ``--entry`` it runs instead the case with the entry refinement (``[mesh] size_entry_mm``:
the drive-side tip rounds and the mate's flank foot, where the round bears) at ``ENTRY_SIZES_MM``.
With ``--docs`` it writes the table into docs/refinement.md (block ``tip_round``, or
``tip_round_entry``).

Usage: ``mpirun -n 2 python benchmarks/verification/tip_round.py [--entry] [--docs]``

Purpose: verification (what the tip rounds carry, and the entry refinement).
Writes: blocks ``tip_round`` and ``tip_round_entry`` of docs/refinement.md (``--docs``).
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import time
from pathlib import Path

import numpy as np
from mpi4py import MPI

import gearfem  # noqa: F401  (must precede dolfinx/petsc4py)
from gearfem import pipeline
from gearfem.config import load_case
from gearfem.contact.friction import FrictionOptions
from gearfem.core.doctables import markdown_table, replace_block
from gearfem.coupling.friction_heat import reference_flux
from gearfem.geometry.involute import GearPair
from gearfem.geometry.options import BODIES
from gearfem.instruments.evaluate import evaluate
from gearfem.refinement import level_case

ROOT = Path(__file__).resolve().parents[2]
DOC = ROOT / "docs" / "refinement.md"
FACTORS = (1.0, 1.5, 2.25)
# refinement kind -> what its levels refine
DIRECTIONS = {"tip": "tip elements", "structural_mesh": "contact zone"}
# sizes of the entry refinement, mm (--entry): 0.07 divided by 1.5, 1.5^2, 1.5^3
ENTRY_SIZES_MM = (0.07, 0.0467, 0.0311, 0.0207)


def on_tip_round(case, cyc) -> np.ndarray:
    """Mask of the history's points on the tip round of their slave gear (radius >= r_Fa)."""
    pair = GearPair(case.geometry)
    h = cyc.history
    centers = {"pinion": np.zeros(2), "wheel": np.array([pair.center_distance_m, 0.0])}
    on_tip = np.zeros(h.num_points, dtype=bool)
    for b in BODIES:
        r = np.linalg.norm(h.point_m[:, :2] - centers[b], axis=1)
        on_tip |= h.of(b) & (r >= pair.profile(b).tip_form_radius_m)
    return on_tip


def without_tip_rounds(case, cyc):
    """The cycle with the friction flux of its contact history without the tip-round contacts
    (the pressures there set to zero, the rest as solved)."""
    on_tip = on_tip_round(case, cyc)
    h = dataclasses.replace(cyc.history, pressure_Pa=np.where(on_tip, 0.0, cyc.history.pressure_Pa))
    masked = dataclasses.replace(cyc, history=h)
    speed = case.operating.speed_rpm
    omega = 2 * math.pi * speed / 60
    law = FrictionOptions().law_for(cyc.friction_coefficient)
    fields = {}
    for b in BODIES:
        q, _, _ = reference_flux(masked, b, law, case.materials, speed, 300.0)
        fields[b] = dataclasses.replace(cyc.fields[b], generated_flux_W_m2_per_rad_s=q / omega)
    return dataclasses.replace(masked, fields=fields)


def temperatures(case, cyc, out: Path, comm) -> tuple[float, float]:
    """(max surface of the case's gear, camera_max) at the end of the run (C)."""
    th, _, snap = pipeline.observed_thermal(
        case, out, comm, cyc, write_fields=False, steady=False, write_plot=False
    )
    cam = pipeline.on_root(comm, lambda: evaluate(case.instruments, snap).camera["end"].max_C)
    return th["final_temperatures_C"]["max_surface"], cam


def tip_round_measures(case, cyc) -> dict[str, float]:
    """The tip-round measures of one cycle (see the module docstring)."""
    h = cyc.history
    n = len(cyc.phi_rad)
    on_tip = on_tip_round(case, cyc)
    pw = h.pressure_Pa * h.weight_m2
    mu = cyc.friction_coefficient
    heat = mu * pw * h.dissipation_speed_m_s  # per unit ω1
    # a contact through a tip round is counted once, in the pass whose slave owns the round
    f_tip = np.bincount(h.position[on_tip], weights=pw[on_tip], minlength=n)
    f_all = np.bincount(h.position, weights=pw * h.pass_weight, minlength=n)
    q_tip = np.bincount(h.position[on_tip], weights=heat[on_tip], minlength=n)
    q_all = cyc.friction_power_W_per_rad_s
    omega = 2 * math.pi * case.operating.speed_rpm / 60
    return {
        "p_max_MPa": float(np.max(cyc.p_max_Pa)) * 1e-6,
        "p_max_tip_MPa": float(np.max(h.pressure_Pa[on_tip], initial=0.0)) * 1e-6,
        "p_max_off_tip_MPa": float(np.max(h.pressure_Pa[~on_tip], initial=0.0)) * 1e-6,
        "tip_force_mean_N": float(np.mean(f_tip)),
        "tip_force_max_N": float(np.max(f_tip)),
        "tip_force_share": float(np.mean(f_tip) / np.mean(f_all)),
        "tip_heat_W": float(np.mean(q_tip)) * omega,
        "friction_power_W": float(np.mean(q_all)) * omega,
        "tip_heat_share": float(np.mean(q_tip) / np.mean(q_all)),
    }


@dataclasses.dataclass(frozen=True)
class Level:
    """The tip-round measures of one refinement level and its temperatures at the end of the run
    with and without the tip-round contacts' friction heat (C)."""

    size_tip_mm: float
    size_flank_mm: float
    measures: dict[str, float]
    max_surface_C: float
    camera_C: float
    max_surface_without_C: float
    camera_without_C: float


def solve_level(case, out: Path, comm) -> Level:
    cyc, _, _ = pipeline.cycle(case, comm)
    with_ = temperatures(case, cyc, out / "with", comm)
    without = temperatures(case, without_tip_rounds(case, cyc), out / "without", comm)
    return Level(
        case.mesh.size_tip_mm,
        case.mesh.size_flank_mm,
        tip_round_measures(case, cyc),
        *with_,
        *without,
    )


HEADER = (
    "refined",
    "tip / flank size (mm)",
    "p_max on tip rounds (MPa)",
    "p_max elsewhere (MPa)",
    "tip-round force, mean / max (N)",
    "share of the normal load",
    "tip-round friction heat (W)",
    "friction power (W)",
    "share of the friction heat",
    "camera_max (C)",
    "camera_max without tip-round heat (C)",
    "tip rounds' part of camera_max (K)",
    "max surface (C)",
    "tip rounds' part of max surface (K)",
)


def _row(label: str, lv: Level) -> list[str]:
    m = lv.measures
    return [
        label,
        f"{lv.size_tip_mm:.3f} / {lv.size_flank_mm:.3f}",
        f"{m['p_max_tip_MPa']:.0f}",
        f"{m['p_max_off_tip_MPa']:.0f}",
        f"{m['tip_force_mean_N']:.1f} / {m['tip_force_max_N']:.1f}",
        f"{100 * m['tip_force_share']:.2f} %",
        f"{m['tip_heat_W']:.2f}",
        f"{m['friction_power_W']:.2f}",
        f"{100 * m['tip_heat_share']:.2f} %",
        f"{lv.camera_C:.2f}",
        f"{lv.camera_without_C:.2f}",
        f"{lv.camera_C - lv.camera_without_C:+.2f}",
        f"{lv.max_surface_C:.1f}",
        f"{lv.max_surface_C - lv.max_surface_without_C:+.2f}",
    ]


def entry_levels(case, comm, out: Path) -> list[list[str]]:
    """The case with the entry refinement (``[mesh] size_entry_mm``) at ``ENTRY_SIZES_MM``, the
    rest of its resolution unchanged: rows of the table, the case first."""
    pinned = dataclasses.replace(case, thermal_mesh=case.thermal_mesh_options)
    rows = []
    for size in (None, *ENTRY_SIZES_MM):
        c = dataclasses.replace(pinned, mesh=dataclasses.replace(case.mesh, size_entry_mm=size))
        lv = solve_level(c, out / f"entry_{size}", comm)
        if comm.rank == 0:
            print("entry", size, lv, flush=True)
            rows.append(_row("(the case)" if size is None else f"entry {size:.4f} mm", lv))
    return rows


def direction_levels(case, comm, out: Path) -> list[list[str]]:
    """The case at ``FACTORS`` in each of ``DIRECTIONS``: rows of the table (on rank 0)."""
    levels: dict[tuple[str, float], Level] = {}
    for kind in DIRECTIONS:
        for f in FACTORS:
            # factor 1 is the case itself in both directions: solved once
            key = (kind, f) if f != 1.0 else ("case", 1.0)
            if key not in levels:
                levels[key] = solve_level(level_case(case, kind, f), out / f"{key[0]}_{f:g}", comm)
                if comm.rank == 0:
                    print(kind, f, levels[key], flush=True)
    if comm.rank != 0:
        return []
    return [
        _row(
            "(the case)" if f == 1.0 else f"{DIRECTIONS[kind]} x{f:g}",
            levels[(kind, f) if f != 1.0 else ("case", 1.0)],
        )
        for kind in DIRECTIONS
        for f in FACTORS
    ]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--docs", action="store_true", help="write the table into docs/refinement.md")
    ap.add_argument(
        "--entry",
        action="store_true",
        help="the entry refinement's levels instead (block tip_round_entry)",
    )
    args = ap.parse_args()
    comm = MPI.COMM_WORLD
    case = load_case(None)
    out = Path("results/tip_round")
    t0 = time.perf_counter()
    rows = (entry_levels if args.entry else direction_levels)(case, comm, out)
    wall = time.perf_counter() - t0
    if comm.rank == 0:
        table = markdown_table(HEADER, rows)
        print(table)
        if args.docs:
            flags = " --entry" if args.entry else ""
            caption = (
                f"\n\n`mpirun -n {comm.size} python benchmarks/verification/tip_round.py"
                f"{flags} --docs`: "
                f"{wall:.0f} s (cycles cached or solved), load average "
                f"{os.getloadavg()[0]:.1f}."
            )
            replace_block(DOC, "tip_round_entry" if args.entry else "tip_round", table + caption)


if __name__ == "__main__":
    main()
