"""Does gearfem's u_num rule for four or more levels agree with the procedure it cites?

gearfem.core.gci.least_squares_convergence follows Eça & Hoekstra (J. Comput. Phys. 262 (2014)
104-130) in the fit, the scatter σ and the good-fit test, but departs from it where no order in
[0.5, formal] fits: it clips the order to that range and fits again. The 2014 procedure instead
refits at fixed orders and keeps the fit of least scatter (the order below 0.5: p = 1, p = 2 and
α h + β h²; above 2: p = 1 and p = 2), each unweighted and weighted by w_i ∝ 1/h_i, with

    σ = sqrt(n Σ w_i (φ_i − φ_fit,i)² / (n − n_p)),      Δφ = (φ_max − φ_min)/(n − 1),
    Fs = 1.25 if 0.5 <= p < 2.1 (the fitted order) and σ < Δφ, else 3,
    U_i = Fs ε_i + σ + |φ_i − φ_fit,i|                     (σ < Δφ)
    U_i = 3 σ/Δφ (ε_i + σ + |φ_i − φ_fit,i|)               (σ >= Δφ),   ε_i = |φ_fit,i − φ0|,

and no bound by the data range (Δ_M, the largest difference between two solutions, belongs to
the 2008 procedure, J. Mar. Sci. Technol. 13 (2008)). This script implements
those formulas independently of gearfem (as reconstructed from two implementations that cite the
paper's equations; the paper's text was not at hand) and prints both u_num = U/1.15 of the case's
level for the quantities of refinement studies' refinement.json:

    python benchmarks/verification/uncertainty_method.py STUDY/refinement.json [...]
        [--quantities max_surface camera_max ...] [--add-level SIZE Q=VALUE ...]

``--add-level``: one more level (its representative size, as the study's ``sizes``) with the
given quantities' values (e.g. solutions at further levels run by hand);
quantities without a value there keep the study's levels. ``--docs``: replace the block
``uncertainty_method`` of docs/refinement.md with the table. No solves; milliseconds.

Purpose: verification (the least-squares rule against Eça & Hoekstra's on filed studies).
Writes: block ``uncertainty_method`` of docs/refinement.md (``--docs``).
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np
from scipy.optimize import minimize_scalar

from gearfem.core.doctables import markdown_table, replace_block
from gearfem.core.gci import GCI_TO_STANDARD, convergence
from gearfem.core.io import read_json
from gearfem.refinement import RefinementStudy

DOC = Path(__file__).resolve().parents[2] / "docs" / "refinement.md"
P_LOW, P_HIGH = 0.5, 2.0  # the 2014 procedure's range of trusted orders (Fs 1.25 up to 2.1)


def _weighted_fit(h: np.ndarray, f: np.ndarray, w: np.ndarray, columns: list[np.ndarray]):
    """φ0, the fit at h and σ of f ≈ φ0 + Σ c_k columns_k, weights w (Σ w = 1)."""
    a = np.column_stack([np.ones_like(h), *columns])
    sw = np.sqrt(w)
    coef, *_ = np.linalg.lstsq(a * sw[:, None], f * sw, rcond=None)
    fit = a @ coef
    n, n_p = len(f), a.shape[1]
    if n <= n_p:  # as many solutions as parameters (three levels): an exact fit
        return float(coef[0]), fit, 0.0
    sigma = math.sqrt(n * float(np.sum(w * (f - fit) ** 2)) / (n - n_p))
    return float(coef[0]), fit, sigma


def _free_order(h: np.ndarray, f: np.ndarray, w: np.ndarray) -> float:
    def sse(p: float) -> float:
        _, fit, _ = _weighted_fit(h, f, w, [h**p])
        return float(np.sum(w * (f - fit) ** 2))

    grid = np.geomspace(1e-3, 12.0, 400)
    k = int(np.argmin([sse(p) for p in grid]))
    lo, hi = grid[max(k - 1, 0)], grid[min(k + 1, len(grid) - 1)]
    return float(minimize_scalar(sse, bounds=(lo, hi), method="bounded").x)


def eca_hoekstra_2014(values, sizes, level: int) -> tuple[float, str]:
    """U/1.15 of ``level`` (index into ``values`` sorted fine to coarse) and the fit used."""
    order = np.argsort(sizes)
    h = np.asarray(sizes, float)[order] / min(sizes)
    f = np.asarray(values, float)[order]
    n = len(f)
    candidates = []  # (σ, name, φ0, fit, fitted order), per weighting
    for label, w in (("", np.full(n, 1.0 / n)), ("weighted ", (1 / h) / np.sum(1 / h))):
        p = _free_order(h, f, w)
        if P_LOW <= p <= P_HIGH:
            phi0, fit, sigma = _weighted_fit(h, f, w, [h**p])
            candidates.append((sigma, f"{label}p = {p:.2f}", phi0, fit, p, True))
            continue
        fixed = {"p = 1": [h], "p = 2": [h**2]}
        if p < P_LOW:
            fixed["h + h²"] = [h, h**2]
        for name, cols in fixed.items():
            phi0, fit, sigma = _weighted_fit(h, f, w, cols)
            candidates.append((sigma, f"{label}{name} (fitted p {p:.2f})", phi0, fit, p, False))
    in_range = [c for c in candidates if c[5]]  # a fit in the trusted range wins
    sigma, name, phi0, fit, p, _ = min(in_range or candidates, key=lambda c: c[0])
    spread = (f.max() - f.min()) / (n - 1)
    fs = 1.25 if (P_LOW <= p < 1.05 * P_HIGH and sigma < spread) else 3.0
    eps = abs(fit[level] - phi0)
    dev = abs(f[level] - fit[level])
    u = fs * eps + sigma + dev if sigma < spread else 3 * sigma / spread * (eps + sigma + dev)
    return u / GCI_TO_STANDARD, name


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("studies", nargs="+", help="refinement.json files")
    p.add_argument("--quantities", nargs="+", default=["max_surface", "camera_max"])
    p.add_argument("--add-level", nargs="+", metavar="SIZE Q=VALUE", default=None)
    p.add_argument("--docs", action="store_true", help="write the block uncertainty_method")
    args = p.parse_args()
    extra_size, extra = None, {}
    if args.add_level:
        extra_size = float(args.add_level[0])
        extra = {k: float(v) for k, v in (a.split("=", 1) for a in args.add_level[1:])}
    rows = []
    for path in args.studies:
        study = RefinementStudy.from_json(read_json(path))
        for q in args.quantities:
            r = study.row(q)
            values, sizes = list(r.values), list(r.sizes)
            case_h = sizes[study.case_value_index]
            if q in extra:  # one more level: the study's rule again (formal order: none)
                if study.kind == "thermal_mesh":
                    raise SystemExit("--add-level: not for thermal_mesh (its formal order)")
                values.append(extra[q])
                sizes.append(extra_size)
            level = sorted(sizes).index(case_h)
            ours = convergence(values, sizes).u_num_at(level) if q in extra else r.u_num_case
            if len(values) < 4:  # gearfem: the three-solution GCI, which the 2014 fit is not for
                rows.append([f"{study.kind} ({study.resolution_key})", q, "3", f"{ours:.3g}"])
                rows[-1] += ["three levels: not compared", "-"]
                continue
            theirs, fit = eca_hoekstra_2014(values, sizes, level)
            rows.append(
                [
                    f"{study.kind} ({study.resolution_key})",
                    q,
                    str(len(values)),
                    f"{ours:.3g}",
                    fit,
                    f"{theirs:.3g}",
                ]
            )
    header = (
        "study",
        "quantity",
        "levels",
        "u_num case, gearfem",
        "Eça & Hoekstra 2014: fit",
        "u_num case",
    )
    added = ", ".join(f"{k} {v:g}" for k, v in extra.items())
    extra_note = f" Levels added: size {extra_size:g} with {added}." if extra else ""
    text = (
        markdown_table(header, rows)
        + "\n\nu_num of the case's level by gearfem's rule (gearfem.core.gci) and by the 2014 "
        + "procedure's formulas (this script's own implementation, in its docstring)."
        + extra_note
        + "\n\n`python benchmarks/verification/uncertainty_method.py "
        + f"{' '.join(args.studies)} --quantities "
        + " ".join(args.quantities)
        + (f" --add-level {' '.join(args.add_level)}" if args.add_level else "")
        + " --docs`."
    )
    print(text)
    if args.docs:
        replace_block(DOC, "uncertainty_method", text)


if __name__ == "__main__":
    main()
