"""What a change of the contact solver's options buys on the built-in case's cycle, and what it
costs in the results.

Each variant is the built-in case at ``--torque-Nm`` with some ``[contact]`` options changed; its
structural cycle (``mpirun -n 2 gearfem cycle``) runs from the same stored compliances as the
default's, one after the other, the default first and again last (the machine's speed varies from
run to run: the two default runs bound that). Per variant it prints the wall time, the Newton
iterations of the cycle, and the largest differences from the first default run over the
positions: transmission error, tooth loads, friction power, peak contact pressure (relative), and
the largest strain energy density U_max of each gear (relative). A variant whose differences are
at the level of the default's own Newton tolerance is a speed lever; one that moves the peak
pressure or U_max changes the model's answer.

The compliances come from ``GEARFEM_CACHE`` when it holds them (hard links into a temporary
cache, so nothing is written there), otherwise from a first, untimed cycle of the default.
``--docs`` writes the table into block ``contact_options`` of docs/performance.md (``--block``:
another block).

    python benchmarks/performance/contact_options.py [--torque-Nm T]
        [--variant NAME=key:value[,key:value...]]... [--docs [--block NAME]] [--log-dir DIR]
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import json
import os
import shutil
import tempfile
import tomllib
from pathlib import Path

import numpy as np
from loops import gearfem_command, machine_reference_s, measured_by, run_command

from gearfem.config import load_case, write_case
from gearfem.core.doctables import markdown_table, replace_block
from gearfem.core.provenance import git_hash

ROOT = Path(__file__).resolve().parents[2]

#: The variants measured by default: (name, {contact option: value}).
VARIANTS: tuple[tuple[str, dict], ...] = (
    ("uzawa_newton_rtol 1e-3", {"uzawa_newton_rtol": 1e-3}),
    ("uzawa_newton_rtol 1e-2", {"uzawa_newton_rtol": 1e-2}),
    ("penalty_factor 4", {"penalty_factor": 4.0}),
    (
        "geometric_tangent, uzawa_newton_rtol 1e-3",
        {"geometric_tangent": True, "uzawa_newton_rtol": 1e-3},
    ),
)


def _parse_variant(text: str) -> tuple[str, dict]:
    """``NAME=key:value[,key:value...]`` (values as TOML scalars: 1e-3, 4.0, true)."""
    name, _, body = text.partition("=")
    if not name or not body:
        raise SystemExit(f"--variant {text!r}: expected NAME=key:value[,key:value...]")
    out = {}
    for item in body.split(","):
        key, _, value = item.partition(":")
        out[key.strip()] = tomllib.loads(f"v = {value.strip()}")["v"]
    return name, out


def _write_case(path: Path, torque_Nm: float, contact: dict) -> None:
    """The built-in case at ``torque_Nm`` with ``contact`` options changed, as a case file (the
    options are validated on construction: a bad key or value stops here, naming it)."""
    case = load_case(None).with_operating(torque_Nm=torque_Nm)
    write_case(
        dataclasses.replace(case, contact=dataclasses.replace(case.contact, **contact)), path
    )


def _read(out: Path) -> tuple[dict, dict[str, np.ndarray]]:
    summary = json.loads((out / "cycle_summary.json").read_text())
    with open(out / "cycle_history.csv") as f:
        rows = list(csv.DictReader(f))
    cols = {k: np.array([float(r[k]) for r in rows]) for k in rows[0]}
    return summary, cols


def _differences(base: Path, other: Path) -> tuple[int, str]:
    """Newton iterations of ``other`` and its largest differences from ``base``."""
    s0, h0 = _read(base)
    s1, h1 = _read(other)
    loads = [k for k in h0 if k.startswith("load_tooth")]
    d_load = max(float(np.abs(h1[k] - h0[k]).max()) for k in loads)
    rel = lambda k: float(np.abs(h1[k] / np.where(h0[k] == 0, 1.0, h0[k]) - 1.0).max())
    u = max(abs(s1["max_u_J_m3"][b] / s0["max_u_J_m3"][b] - 1.0) for b in s0["max_u_J_m3"])
    text = (
        f"TE {1e3 * float(np.abs(h1['te_um'] - h0['te_um']).max()):.2g} nm, loads "
        f"{d_load:.2g} N, friction power {rel('friction_power_W_per_rad_s'):.1e}, "
        f"p_max {rel('p_max_MPa'):.1e}, U_max {u:.1e}"
    )
    return int(s1["newton_iterations"]), text


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--torque-Nm", type=float, default=4.0, help="the cycle's torque (N m)")
    ap.add_argument(
        "--variant",
        action="append",
        default=None,
        help="NAME=key:value[,key:value...] of [contact] (repeatable; default: VARIANTS)",
    )
    ap.add_argument("--docs", action="store_true", help="write docs/performance.md")
    ap.add_argument("--block", default="contact_options", help="the docs block written")
    ap.add_argument("--log-dir", default=None, help="keep each run's output in DIR/NAME.log")
    a = ap.parse_args()
    variants = [_parse_variant(v) for v in a.variant] if a.variant else list(VARIANTS)
    log_dir = Path(a.log_dir) if a.log_dir else None
    commit, reference_start = git_hash(ROOT), machine_reference_s()
    tmp = Path(tempfile.mkdtemp(prefix="gearfem-contact-options-"))
    env = dict(os.environ, PYVISTA_OFF_SCREEN="true", MPLBACKEND="Agg")
    env["GEARFEM_LOG_LEVEL"] = "INFO" if log_dir is not None else "WARNING"
    env["GEARFEM_CACHE"] = str(tmp / "cache")

    def cycle(case: Path, out: Path, name: str) -> float:
        """``mpirun -n 2 gearfem cycle``; its wall time in seconds."""
        cmd = gearfem_command(2, "cycle", str(case), "--out", str(out))
        return run_command(cmd, env, name=name, log_dir=log_dir)["wall_s"]

    try:
        stored = Path(os.environ.get("GEARFEM_CACHE", ROOT / "cache")) / "compliance"
        default = tmp / "default.toml"
        _write_case(default, a.torque_Nm, {})
        if stored.is_dir():
            shutil.copytree(stored, tmp / "cache" / "compliance", copy_function=os.link)
        else:  # the compliances by a first cycle of the default, not timed
            cycle(default, tmp / "warm_up", "warm_up")
        rows = []
        runs = [("default", {}), *variants, ("default, again", {})]
        for k, (name, contact) in enumerate(runs):
            shutil.rmtree(tmp / "cache" / "cycles", ignore_errors=True)
            case = default if not contact else tmp / f"variant{k}.toml"
            if contact:
                _write_case(case, a.torque_Nm, contact)
            out = tmp / f"run{k}"
            wall = cycle(case, out, f"run{k}")
            its, diff = _differences(tmp / "run0", out)
            rows.append((name, f"{wall:.0f} s", str(its), "-" if k == 0 else diff))
            print(" | ".join(rows[-1]), flush=True)
        positions = _read(tmp / "run0")[0]["positions"]
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    text = (
        markdown_table(
            ("[contact] options", "cycle, 2 ranks", "Newton iterations", "largest differences"),
            rows,
        )
        + f"\n\nThe built-in case at {a.torque_Nm:g} N m, {positions} positions, compliances "
        "stored. "
        + measured_by(
            "benchmarks/performance/contact_options.py",
            commit,
            (reference_start, machine_reference_s()),
        )
    )
    print(text)
    if a.docs:
        replace_block(ROOT / "docs" / "performance.md", a.block, text)


if __name__ == "__main__":
    main()
