"""Hidden-effect benchmark of the diagnosis (issue 8): confusion matrix over the library and seeds.

For every candidate of the library and ``--seeds`` random seeds, synthetic data are made by the
full model (coarse case, the operating points and quantities of tests/diagnose_generator.py) with
that effect hidden at a random size; the diagnosis (surrogate) must name it. Prints the confusion
matrix (rows: hidden effect, columns: verdict), the recovery rate, the rate at which the truth lies
in the 95 % profile interval, the null-case false-alarm rate and timings.

    PYTHONPATH=$PWD python benchmarks/verification/diagnose_synthetic.py --seeds 5

Purpose: verification (the diagnosis names the planted effect on synthetic data).
Writes: no documentation block (prints; docs/diagnosis.md quotes it).
"""

from __future__ import annotations

import argparse
import dataclasses
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
from gearfem.diagnose.candidates import LIBRARY  # noqa: E402
from gearfem.diagnose.forward import FullModel, Surrogate  # noqa: E402
from gearfem.diagnose.select import diagnose, refine  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--noise-K", type=float, default=1.0)
    args = ap.parse_args()
    case = load_case(ROOT / "tests" / "cases" / "coarse.toml")
    case = dataclasses.replace(case, thermal=dataclasses.replace(case.thermal, time_error_K=0.25))
    full = FullModel(case, MPI.COMM_SELF, times_s=G.TIMES_S)
    t0 = time.perf_counter()
    sur = Surrogate(full, [(s, G.TORQUE_NM) for s in G.SPEEDS_RPM], cache_dir=cache_root())
    print(f"surrogate: {full.solves} full-model solves, {time.perf_counter() - t0:.0f} s")
    names = [c.name for c in LIBRARY]
    cols = ["baseline", *names, "pair", "not identifiable", "unexplained"]
    matrix = {n: dict.fromkeys(cols, 0) for n in ["null", *names]}
    inside = {n: 0 for n in names}
    inside_refined = {n: 0 for n in names}
    t_an = []
    for hidden in ["null", *names]:
        for seed in range(args.seeds):
            rng = np.random.default_rng(10_000 + 97 * seed + 7 * (["null", *names].index(hidden)))
            truth = {} if hidden == "null" else {hidden: G.draw(hidden, rng)}
            data = G.synthetic(full, truth, rng, noise_K=args.noise_K)
            t = time.perf_counter()
            r = diagnose(sur.predict, data, model_error=sur.error)
            t_an.append(time.perf_counter() - t)
            kind = r.verdict.kind
            if kind == "baseline adequate":
                col = "baseline"
            elif kind in ("not identifiable", "unexplained"):
                col = kind
            elif len(r.chosen) == 1:
                col = r.chosen[0]
            else:
                col = "pair"
            matrix[hidden][col] += 1
            if hidden != "null" and r.chosen == (hidden,):
                lo, hi = r.fit_of((hidden,)).intervals[hidden]
                inside[hidden] += int(lo <= truth[hidden] <= hi)
                ref = refine(
                    full.predict, sur.predict, data, r, final_check=False, model_error=sur.error
                ).refined
                lo, hi = ref.intervals[hidden]
                inside_refined[hidden] += int(lo <= truth[hidden] <= hi)
    print("hidden \\ verdict".ljust(28) + " ".join(c[:10].rjust(10) for c in cols))
    for h, row in matrix.items():
        print(h.ljust(28) + " ".join(str(row[c]).rjust(10) for c in cols))
    ok = sum(matrix[n][n] for n in names)
    print(
        f"rank-1 recovery: {ok}/{len(names) * args.seeds}; truth inside the 95 % interval when "
        f"recovered: "
        f"{sum(inside.values())}/{ok} (surrogate), {sum(inside_refined.values())}/{ok} (after "
        f"full-model "
        f"refinement); null false alarms: {args.seeds - matrix['null']['baseline']}/{args.seeds}"
    )
    print(
        f"analysis time per data set: mean {np.mean(t_an):.1f} s, max {np.max(t_an):.1f} s "
        f"(full-model solves in total {full.solves})"
    )


if __name__ == "__main__":
    main()
