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
import math
import tempfile
from pathlib import Path

import numpy as np
from mpi4py import MPI

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
    at = pipeline.CycleAtSpeed.of(cyc, case.operating.speed_rpm)
    loads = np.array([v for v in cyc.tooth_load_N.values()])  # (teeth, positions)
    th = dataclasses.replace(case.thermal, mode="steady", output_times_s=())
    c = dataclasses.replace(case, thermal=th)
    name = tempfile.mkdtemp(prefix="gearfem-tractions-") if comm.rank == 0 else None
    out = Path(comm.bcast(name, root=0))
    _, _, snap = pipeline.observed_thermal(c, out, comm, cyc, write_fields=False, write_plot=False)
    cam = heat = None
    if comm.rank == 0:
        cam = evaluate(c.instruments, snap, only=("camera",)).camera[snap.label_of(None)].max_C
        heat = snap.mesh_heat_W(snap.label_of(None))[0]
    cam, heat = comm.bcast((cam, heat), root=0)
    umax = max(float(np.max(f.u_max_J_m3)) for f in cyc.fields.values())
    return {
        "largest tooth-pair load (N)": float(loads.max()),
        "mean tooth-pair load over the engagement (N)": float(loads[loads > 0].mean()),
        "effective contact ratio": at.effective_contact_ratio,
        "pitch-point pressure, band (MPa)": at.pitch_point_band_pressure_MPa or math.nan,
        "largest pressure (MPa)": at.max_contact_pressure_MPa,
        "transmission error, mean (um)": at.transmission_error_um["mean"],
        "largest U_max (kJ/m3)": umax * 1e-3,
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
