"""Where the test suite's two longest fixtures (the diagnosis surrogates) spend their time.

The fixtures: tests/test_diagnose.py's ``models`` (the classic library at the generator's
speeds) and tests/test_diagnose_friction.py's ``friction_models`` (the friction laws and their
rivals at two torques), built from scratch.

Each surrogate tabulates the full forward model (the coarse test case) per operating point along
every candidate's axis (gearfem.diagnose.forward.Surrogate); this script times every full-model
evaluation and prints, per candidate and per (candidate, point), how many there were and the
seconds they took, and the structural cycles' times. It builds in a fresh cache of its own (the
tests' cache is left alone), on one rank, as the suite's pytest-xdist workers do:

    python benchmarks/performance/diagnose_surrogate_cost.py --fixture friction   # or classic

Purpose: performance (where the test suite's two diagnosis surrogate fixtures spend their time).
Writes: no documentation block (prints its table).
"""

from __future__ import annotations

import argparse
import collections
import os
import sys
import tempfile
import time
from pathlib import Path

import gearfem  # noqa: F401  (must precede dolfinx/petsc4py)

# isort: split

from gearfem.cycle.cache import ENV_CACHE
from gearfem.diagnose import forward
from gearfem.diagnose.candidates import CLASSIC_LIBRARY

# the fixtures are the tests' own (tests/ is not a package)
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tests"))

# isort: split

from test_diagnose import CLASSIC_POINTS, forward_models
from test_diagnose_friction import FRICTION_LIBRARY, FRICTION_POINTS


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--fixture", choices=("classic", "friction"), default="friction")
    p.add_argument("--top", type=int, default=12, help="(candidate, point) rows to print")
    args = p.parse_args()

    spent: dict[tuple, list] = collections.defaultdict(lambda: [0, 0.0])
    evaluate, cycle = forward.FullModel._evaluate, forward.FullModel.cycle

    def timed_evaluate(self, speed, torque, ambient, model, transform, branch_search):
        t0 = time.perf_counter()
        out = evaluate(self, speed, torque, ambient, model, transform, branch_search)
        row = spent[(",".join(sorted(model or {})) or "(base)", speed, torque)]
        row[0] += 1
        row[1] += time.perf_counter() - t0
        return out

    def timed_cycle(self, torque, case=None):
        t0 = time.perf_counter()
        n = len(self._cycles)
        out = cycle(self, torque, case)
        if len(self._cycles) > n:
            print(f"cycle at {torque} N m: {time.perf_counter() - t0:.1f} s", flush=True)
        return out

    forward.FullModel._evaluate = timed_evaluate
    forward.FullModel.cycle = timed_cycle
    library, points = {
        "friction": (FRICTION_LIBRARY, FRICTION_POINTS),
        "classic": (CLASSIC_LIBRARY, CLASSIC_POINTS),
    }[args.fixture]
    with tempfile.TemporaryDirectory(prefix="gearfem-surrogate-cost-") as cache:
        os.environ[ENV_CACHE] = cache  # built from scratch, the tests' cache left alone
        t0 = time.perf_counter()
        _, surrogate = forward_models(library, points)
        total = time.perf_counter() - t0
    print(f"{args.fixture} surrogate: {total:.1f} s, {surrogate.solves} full-model evaluations")
    per_candidate: dict[str, list] = collections.defaultdict(lambda: [0, 0.0])
    for (name, _, _), (n, s) in spent.items():
        per_candidate[name][0] += n
        per_candidate[name][1] += s
    print("candidate: evaluations, seconds (the base includes the cycles)")
    for name, (n, s) in sorted(per_candidate.items(), key=lambda kv: -kv[1][1]):
        print(f"  {name:32s} {n:4d} {s:8.1f}")
    print(f"the {args.top} costliest (candidate, speed rpm, torque N m):")
    for (name, sp, tq), (n, s) in sorted(spent.items(), key=lambda kv: -kv[1][1])[: args.top]:
        print(f"  {name:32s} {sp:7.0f} {tq:5.1f} {n:4d} {s:8.1f}")


if __name__ == "__main__":
    main()
