"""A two-material pair diagnosed from its case file (issue 45): synthetic bench data of a steel
pinion against a POM wheel with an effect hidden, then ``gearfem diagnose`` as a user runs it.

The case: ``demos/steel_pom.toml`` (steel pinion, POM wheel, each gear's constants from the
materials library; the coarse mesh, 8 positions per pitch), with the friction heat split by the
bodies' effusivities (``--partition blok``, the default here: the demo's split by contact
temperature repeats both gears' runs three to four times per evaluation, ``--partition
contact_temperature`` keeps it). The data: what a bench reads, the IR camera's hottest pixel
(``camera_max``) at 300 s and 900 s and the torque meters' loss at the end, at 1000 and 2000 rpm
and 2 and 4 N m, each from gearfem's full forward model
(:class:`gearfem.diagnose.forward.FullModel`) with ``--hidden`` switched on at ``--value`` (default:
the convection 25 % weaker than the thesis's correlations, ``convection_scale`` 0.75), Gaussian
noise of the stated uncertainties (camera 2 K, torque meters 0.01 N m) and a recorded ambient
between 19 and 25 C per run. Then ``mpirun -n NP gearfem diagnose DATA --case CASE --out OUT``
in a subprocess, the command a user types, with the whole library; the diagnosis carries each
gear's library intervals of conductivity, heat capacity and emissivity (the steel's emissivity
0.10-0.80) as input uncertainty.

Prints the data, the verdict, the input-uncertainty line of the report and the timings. It
checks that the verdict names the hidden effect and that its interval holds the value hidden:
exit code 1 otherwise.

    python benchmarks/verification/diagnose_pair.py [--np 2] [--out results/diagnose_pair]

Purpose: verification (a steel/POM pair is diagnosed end to end from a case file naming the
materials, with the data's uncertainty carried).
Writes: no documentation block (prints; the report in ``OUT/diagnosis/report.md``).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from mpi4py import MPI

import gearfem  # noqa: F401  (must precede dolfinx/petsc4py)

# isort: split

from gearfem.config import load_case, write_case
from gearfem.diagnose.data import Dataset, Measurement, write_csv
from gearfem.diagnose.forward import FullModel
from gearfem.diagnose.report import DiagnosisReport

ROOT = Path(__file__).resolve().parents[2]
VENV = Path(sys.executable).parent
POINTS = ((1000.0, 2.0), (1000.0, 4.0), (2000.0, 2.0), (2000.0, 4.0))
CAMERA_TIMES_S = (300.0, 900.0)
U_CAMERA_K = 2.0
U_TORQUE_NM = 0.01


def case_file(out: Path, partition: str) -> Path:
    """The demo's case with the friction heat split by ``partition``, as a case file."""
    case = load_case(ROOT / "demos" / "steel_pom.toml")
    sources = dataclasses.replace(case.sources, heat_partition=partition)
    return write_case(dataclasses.replace(case, sources=sources), out / "case.toml")


def synthetic(case_path: Path, hidden: str, value: float, seed: int) -> Dataset:
    """The bench readings of the pair with ``hidden`` at ``value``, with noise (this rank)."""
    case = load_case(case_path)
    full = FullModel(
        case,
        MPI.COMM_SELF,
        times_s=CAMERA_TIMES_S,
        quantities=("camera_max", "torque_loss_Nm"),
    )
    rng = np.random.default_rng(seed)
    rows = []
    for speed, torque in POINTS:
        ambient = float(np.round(rng.uniform(19.0, 25.0), 1))
        got = full.evaluate(speed, torque, ambient, {hidden: value})
        for t in CAMERA_TIMES_S:
            v = got[("camera_max", t)] + rng.normal(0.0, U_CAMERA_K)
            rows.append(Measurement(speed, torque, t, "camera_max", v, U_CAMERA_K, ambient))
        v = got[("torque_loss_Nm", None)] + rng.normal(0.0, U_TORQUE_NM)
        rows.append(Measurement(speed, torque, None, "torque_loss_Nm", v, U_TORQUE_NM, ambient))
    return Dataset(tuple(rows), f"synthetic steel/POM bench, {hidden} = {value:g} hidden")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--np", type=int, default=2, help="ranks of gearfem diagnose")
    ap.add_argument("--out", default="results/diagnose_pair")
    ap.add_argument("--partition", default="blok", choices=("blok", "contact_temperature"))
    ap.add_argument("--hidden", default="convection_scale")
    ap.add_argument("--value", type=float, default=0.75)
    ap.add_argument("--seed", type=int, default=45)
    args = ap.parse_args()
    out = Path(args.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    case_path = case_file(out, args.partition)
    t0 = time.perf_counter()
    data = synthetic(case_path, args.hidden, args.value, args.seed)
    data_path = write_csv(data, out / "data.csv", data.source)
    t_data = time.perf_counter() - t0
    print(f"data ({t_data:.0f} s): {data.source}")
    print(data_path.read_text())
    cmd = [
        str(VENV / "mpirun"), "-n", str(args.np), str(VENV / "gearfem"), "diagnose",
        str(data_path), "--case", str(case_path), "--out", str(out / "diagnosis"),
    ]  # fmt: skip
    print("$ " + " ".join(cmd), flush=True)
    t1 = time.perf_counter()
    proc = subprocess.run(cmd, cwd=ROOT, env=dict(os.environ), capture_output=True, text=True)
    t_diag = time.perf_counter() - t1
    sys.stdout.write(proc.stdout[-6000:])
    if proc.returncode != 0:
        sys.stderr.write(proc.stderr[-6000:])
        print(f"gearfem diagnose failed ({proc.returncode})")
        return 1
    report = DiagnosisReport.from_json(
        json.loads((out / "diagnosis" / "diagnosis.json").read_text())
    )
    for line in (out / "diagnosis" / "report.md").read_text().splitlines():
        if "u_input" in line:
            print(line)
    d = report.diagnosis
    intervals = d.refined.intervals if d.refined is not None else d.chosen_fit.intervals
    lo, hi = intervals.get(args.hidden, (float("nan"), float("nan")))
    named = tuple(d.chosen) == (args.hidden,) and d.verdict.kind == "identified"
    inside = named and lo <= args.value <= hi
    print(
        f"hidden {args.hidden} = {args.value:g}; verdict {d.verdict.kind}: {list(d.chosen)}; "
        f"95 % interval {lo:.3g} - {hi:.3g}; named: {named}, holds the value: {inside}; "
        f"data {t_data:.0f} s, diagnosis {t_diag / 60:.1f} min on {args.np} ranks"
    )
    return 0 if inside else 1


if __name__ == "__main__":
    raise SystemExit(main())
