"""What the IR camera's reading depends on: numerics (phases, subsamples) and the physics of the
view (blur, distance, view direction, emissivity model, detector response), on a finished run.

Reads ``RESULT_DIR/instruments/snapshot.npz`` of a ``gearfem run`` (default: the built-in case's
bench point, ``results/bench_1000rpm_8Nm``) and evaluates the camera of the run's case with one
option changed at a time; prints camera_max (frame average), its pixel and surface, and the
render time; with ``--doc`` writes the table into docs/instruments.md (block camera_sensitivity).

Run:
    python benchmarks/verification/camera.py [RESULT_DIR] [--label end] [--doc]

Purpose: verification (the IR camera reading's sensitivity to numerics and view).
Writes: block ``camera_sensitivity`` of docs/instruments.md (``--doc``).
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import time
from pathlib import Path

import gearfem  # noqa: F401  (must precede dolfinx/petsc4py)
from gearfem.config import load_case
from gearfem.core.doctables import markdown_table, replace_block
from gearfem.instruments.evaluate import evaluate
from gearfem.instruments.options import InstrumentOptions
from gearfem.instruments.snapshot import FieldSnapshot

ROOT = Path(__file__).resolve().parents[2]

VARIANTS = [
    ("default (E40, axial, 24 phases, 8x8 subsamples)", {}),
    ("96 phases", {"phases": 96}),
    ("16x16 subsamples", {"subsamples": 16}),
    ("4x4 subsamples", {"subsamples": 4}),
    ("no blur", {"blur_fwhm_px": 0.0}),
    ("blur 2 px FWHM", {"blur_fwhm_px": 2.0}),
    ("distance 0.5 m", {"distance_m": 0.5}),
    ("distance 2 m", {"distance_m": 2.0}),
    ("dielectric (Fresnel) emissivity", {"directional_emissivity": "dielectric"}),
    ("time constant 1 ms", {"time_constant_s": 0.001}),
    ("photon detector, 20 us", {"response": "boxcar", "integration_time_s": 2e-5, "phases": 96}),
    ("view radial", {"view": "radial"}),
    ("view oblique (0, -1, -2)", {"view": (0.0, -1.0, -2.0)}),
    ("emissivity setting 0.95", {"emissivity_setting": 0.95}),
]


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("result", nargs="?", default=str(ROOT / "results" / "bench_1000rpm_8Nm"))
    p.add_argument("--label", default="end", help="snapshot label (end, steady, 900, ...)")
    p.add_argument("--doc", action="store_true", help="write the table into docs/instruments.md")
    a = p.parse_args()
    result = Path(a.result)
    case = load_case(result / "case.toml")
    snap = FieldSnapshot.load(result / "instruments" / "snapshot.npz")
    base = case.instruments.camera
    rows = []
    load = os.getloadavg()[0]
    for name, change in VARIANTS:
        cam = dataclasses.replace(base, **change)
        t0 = time.perf_counter()
        r = evaluate(InstrumentOptions(camera=cam), snap, labels=(a.label,), only=("camera",))
        dt = time.perf_counter() - t0
        c = r.camera[a.label]
        top = ", ".join(f"{k} {v:.0%}" for k, v in list(c.surface_fractions.items())[:2])
        rows.append(
            (
                name,
                f"{c.max_C:.1f}",
                f"{c.frame_max_range_C[0]:.1f}-{c.frame_max_range_C[1]:.1f}",
                f"{c.pixel}",
                top,
                f"{c.footprint_mm:.2f}",
                f"{dt:.1f}",
            )
        )
        print(" | ".join(rows[-1]), flush=True)
    table = markdown_table(
        (
            "camera",
            "camera_max (C)",
            "frame range (C)",
            "pixel",
            "hottest pixel sees",
            "footprint (mm)",
            "render (s)",
        ),
        rows,
    )
    note = (
        f"\n\n{case.name}, {snap.pinion_speed_rpm:g} rpm, label {a.label}; hottest model node "
        f"{c.hottest_node_C:.1f} C. Render times on rank 0 of a shared 2-core machine, 1-minute "
        f"load average {load:.1f} at the start (indicative only). Measured by "
        "`python benchmarks/verification/camera.py " + str(a.result) + f" --label {a.label} --doc`."
    )
    print(table + note)
    if a.doc:
        replace_block(ROOT / "docs" / "instruments.md", "camera_sensitivity", table + note)


if __name__ == "__main__":
    main()
