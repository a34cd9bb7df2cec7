"""What the friction coefficient of the structural cycle changes: the cycle at a glassy mu and at
the rubbery 0.5 side by side, the heat of the glassy mu on both.

The structural cycle is solved with one constant mu (``[contact] friction_coefficient``, 0.5 as the
thesis), while the heat and the torque meters follow the case's friction law; a glass step makes
most contacts of a cool gear run at the glassy mu. This script solves the built-in case's cycle at
``--mu`` (default 0.14) and at 0.5 and compares what the tractions set: the normal load per tooth
pair, the pitch-point and largest pressures, the effective contact ratio, U_max (hysteresis), and,
with the friction heat of the glassy mu recomputed from each cycle's own contact history (the
first-order approximation of docs/friction.md), the friction heat and the camera reading of the
steady state. Where a
difference exceeds the quantity's u_num, the cycle should be solved with the law's mu; where not,
the constant-mu cycle serves the law (docs/friction.md, block ``friction_tractions``).

    mpirun -n 2 python benchmarks/verification/friction_tractions.py [--mu 0.14] \
        [--docs docs/friction.md]
"""

from __future__ import annotations

import argparse
import dataclasses

from mpi4py import MPI
from one_case import CycleLoads, observed_fields, steady_case

import gearfem  # noqa: F401  (must precede dolfinx/petsc4py)
from gearfem import pipeline
from gearfem.config import load_case
from gearfem.contact.friction import FrictionOptions
from gearfem.core.doctables import markdown_table, replace_block
from gearfem.core.log import setup_logging
from gearfem.instruments.evaluate import evaluate
from gearfem.uncertainty import provenance, run_uncertainty


def measures(case, comm) -> dict[str, float]:
    """The cycle's and the steady run's quantities of ``case`` (collective)."""
    cyc, _, _ = pipeline.cycle(case, comm)
    q = CycleLoads.of(cyc, case.operating.speed_rpm)
    c = steady_case(case)
    snap = observed_fields(c, comm, cyc)

    def read():
        label = snap.label_of(None)
        cam = evaluate(c.instruments, snap, only=("camera",)).camera[label].max_C
        return cam, snap.mesh_heat_W(label)[0]

    cam, heat = pipeline.on_root(comm, read)
    return {
        "largest tooth-pair load (N)": q.largest_load_N,
        "mean tooth-pair load over the engagement (N)": q.mean_load_N,
        "effective contact ratio": q.effective_contact_ratio,
        "pitch-point pressure, band (MPa)": q.pitch_point_band_pressure_MPa,
        "largest pressure (MPa)": q.largest_pressure_MPa,
        "transmission error, mean (um)": q.te_mean_um,
        "largest U_max (kJ/m3)": q.largest_u_max_J_m3 * 1e-3,
        "friction heat of the glassy mu, steady (W)": heat,
        "camera_max, steady (C)": cam,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mu", type=float, default=0.14, help="the glassy mu (default 0.14)")
    ap.add_argument("--docs", default=None)
    a = ap.parse_args()
    setup_logging("WARNING")
    comm = MPI.COMM_WORLD
    base = load_case(None)
    rows = {}
    for mu in (a.mu, base.contact.friction_coefficient):
        case = dataclasses.replace(
            base,
            contact=dataclasses.replace(base.contact, friction_coefficient=mu),
            friction=FrictionOptions(mu=a.mu),  # the heat of the glassy mu on both cycles
        )
        rows[mu] = measures(case, comm)
    lo, hi = a.mu, base.contact.friction_coefficient
    # u_num of the case's resolution (its filed studies), for the quantities they follow
    keys = {
        "effective contact ratio": "effective_contact_ratio",
        "camera_max, steady (C)": "camera_max",
        "pitch-point pressure, band (MPa)": "pitch_point_band_pressure_MPa",
        "largest pressure (MPa)": "max_contact_pressure_MPa",
        "transmission error, mean (um)": "transmission_error_mean_um",
    }
    unc = run_uncertainty(base, {keys[q]: rows[hi][q] for q in keys})
    u = {q: unc.u_num(k) for q, k in keys.items()} if unc is not None else {}
    table = markdown_table(
        ("quantity (1000 rpm, 8 N m)", f"cycle at mu {lo:g}", f"cycle at mu {hi:g}", "difference",
         "u_num at the case"),
        [
            (
                q,
                f"{rows[lo][q]:.4g}",
                f"{rows[hi][q]:.4g}",
                f"{rows[lo][q] - rows[hi][q]:+.3g}",
                f"{u[q]:.3g}" if u.get(q) is not None else "",
            )
            for q in rows[lo]
        ],
    )  # fmt: skip
    note = (
        f"\n\nThe built-in case's cycle at 1000 rpm / 8 N m solved with mu {lo:g} and {hi:g}, the "
        f"friction heat of mu {lo:g} recomputed from each cycle's contact history (so the last "
        "rows differ by the tractions alone). `mpirun -n "
        f"{comm.size} python benchmarks/verification/friction_tractions.py --mu {lo:g}`."
    )
    if comm.rank == 0:
        print(table + note)
        if a.docs:
            replace_block(a.docs, "friction_tractions", table + note, provenance(base))


if __name__ == "__main__":
    main()
