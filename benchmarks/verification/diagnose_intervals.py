"""Honest intervals (issue 16): the hidden bore heat path of the issue's report, on the full model.

The issue's synthetic case: the coarse test case, 2 torques x 2 speeds (4 and 8 N m, 1000 and
2000 rpm), three quantities (max surface, mean bulk, root mean) sampled at 120 s, 600 s and the
end, N(0, 1.5 K) noise, a hidden bore heat path of 150 W/(m^2 K). Then a 3-node quadratic
surrogate gave "identified" at 219 with a 95 % interval excluding 150. Here: the adaptive
surrogate with its error carried, the refinement with the interval edges checked on the full model
(edges="always"), and the full model's own chi2 along the bore path's prior for comparison.
Prints the surrogate's nodes and error estimate, the verdict, the surrogate and refined intervals,
the edge checks and the full-model profile; timings with the load average.

    PYTHONPATH=$PWD python benchmarks/verification/diagnose_intervals.py \
        [--library bore_heat_path,...]

Purpose: verification (coverage of the diagnosis' intervals on synthetic data).
Writes: no documentation block (prints; docs/diagnosis.md quotes it).
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys
import time
from pathlib import Path

import numpy as np
from mpi4py import MPI

import gearfem  # noqa: F401

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests"))
import diagnose_generator as G  # noqa: E402

from gearfem.config import load_case  # noqa: E402
from gearfem.cycle.cache import cache_root  # noqa: E402
from gearfem.diagnose.candidates import by_name  # noqa: E402
from gearfem.diagnose.forward import FullModel, Surrogate  # noqa: E402
from gearfem.diagnose.select import _sigma, diagnose, refine  # noqa: E402

POINTS = ((1000.0, 4.0), (1000.0, 8.0), (2000.0, 4.0), (2000.0, 8.0))
TRUTH = {"bore_heat_path": 150.0}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--library", default="bore_heat_path,convection_scale,ambient_offset")
    ap.add_argument("--seed", type=int, default=16)
    args = ap.parse_args()
    comm = MPI.COMM_WORLD
    lib = tuple(by_name(n) for n in args.library.split(","))
    case = load_case(ROOT / "tests" / "cases" / "coarse.toml")
    case = dataclasses.replace(case, thermal=dataclasses.replace(case.thermal, time_error_K=0.25))
    full = FullModel(case, comm, times_s=(120.0, 600.0), library=lib)
    t0 = time.perf_counter()
    sur = Surrogate(full, POINTS, candidates=lib, cache_dir=cache_root())
    t_sur = time.perf_counter() - t0
    rng = np.random.default_rng(args.seed)
    data = G.synthetic(full, TRUTH, rng, noise_K=1.5, points=POINTS)
    t0 = time.perf_counter()
    r = diagnose(sur.predict, data, library=lib, model_error=sur.error)
    t_an = time.perf_counter() - t0
    name = "bore_heat_path"
    t0 = time.perf_counter()
    rr = refine(
        full.predict, sur.predict, data, r, library=lib, model_error=sur.error, edges="always"
    )
    t_ref = time.perf_counter() - t0
    # the full model's chi2 along the prior (bore path alone)
    sig = _sigma(data, r.u_model_K)
    w = np.array(data.series_weights())
    prof = []
    for v in (50.0, 100.0, 150.0, 219.0, 300.0, 400.0):
        F = full.predict(data, {name: v})
        prof.append(
            (
                v,
                float(
                    np.sum(w * ((F - np.array([m.value for m in data.measurements])) / sig) ** 2)
                ),
            )
        )
    if comm.rank == 0:
        print(f"surrogate: {sur.solves} full-model runs in {t_sur:.0f} s (cached if 0 runs)")
        for c in lib:
            print(
                f"  {c.name}: nodes {sur.nodes_of(c.name)}, error estimate up to "
                f"{float(np.max(sur.error(data, (c.name,)))):.3f} K"
            )
        print(f"verdict ({t_an:.1f} s): {r.verdict.kind}: {r.verdict.text}")
        for m in r.models[:4]:
            print(f"  {m.label}: chi2 {m.chi2:.2f}, delta {m.delta:.2f}, intervals {m.intervals}")
        if rr.refined is not None:
            f = rr.refined
            print(
                f"refined ({t_ref:.0f} s): {f.params}, intervals {f.intervals}, chi2 {f.chi2:.2f}"
            )
            for e in f.edges:
                print(f"  edge {e}")
            print(f"verdict after refinement: {rr.verdict.text}")
        c_min = min(c for _, c in prof)
        print("full-model chi2 of the bore path alone (minus its minimum over these values):")
        print("  " + ", ".join(f"{v:g}: {c - c_min:.2f}" for v, c in prof))
        print(f"truth {TRUTH}; 1-minute load average {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
