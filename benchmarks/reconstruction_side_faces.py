"""What the flux reconstruction makes of a uniform flux next to the side faces, on the cycle's own
facet rows.

The friction flux of the cycle lives on the contact-surface facets of each gear's reference tooth,
in rows across the face width. The conservative Gaussian reconstruction
(gearfem.coupling.transfer) spreads each facet's heat over its neighbours; without images in the
side planes a facet next to a side face has neighbours on one side only and sends its heat
inwards. This prints, for each level of the structural layers study (cycles cached by
``benchmarks/uncertainty_builtin.py``) and axial widths, the reconstructed value of a uniform
flux on the pinion's contact-surface facets, as the area-weighted mean of each of the first rows
of the drive flank's facets
from a side face (1 = unbiased), for gearfem's reconstruction (balanced, with side-plane images)
and for the one until stop 30 (a Gaussian normalised per column, written out here). No
finite-element solve: seconds.

    python benchmarks/reconstruction_side_faces.py [--docs]

It also prints the cycle's own flux per facet row (heat per area relative to the rows' mean, and
the largest facet flux of each row): what the layers resolve across the face width.

``--docs`` replaces the blocks ``reconstruction_side_faces`` and ``cycle_flux_rows`` of
docs/refinement.md. The axial widths are those of the per-facet layers study (1.5 mm at the
case, scaled with the layers), the built-in case's until stop 33.
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import numpy as np
import scipy.sparse as sps
from scipy.spatial import cKDTree

import gearfem  # noqa: F401  (must precede dolfinx/petsc4py)
from gearfem.config import load_case
from gearfem.core.doctables import markdown_table, replace_block
from gearfem.coupling.transfer import SMOOTHING_CUTOFF, smoothing_operator
from gearfem.cycle.cache import load
from gearfem.pipeline import case_cycle_dir
from gearfem.refinement import level_case

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "refinement.md"
#: Layer levels of the study (factor 1.5 from the case's 2 layers) and the rows shown per side.
LEVELS = (0, 1, 2, 3)
#: the per-facet study's axial width of the reconstruction at the case (2 layers), mm
PER_FACET_AXIAL_WIDTH_MM = 1.5
ROWS_SHOWN = 3


def _row_means(u: np.ndarray, z: np.ndarray, area: np.ndarray) -> list[float]:
    """Area-weighted mean of ``u`` per row of facet centroids (rows: z to 1 um), from z = 0."""
    rows = np.round(z * 1e6).astype(np.int64)
    return [
        float(np.sum(u[rows == r] * area[rows == r]) / np.sum(area[rows == r]))
        for r in np.unique(rows)
    ]


def column_normalised(points_m, area_m2, sigma_m) -> sps.csr_matrix:
    """The reconstruction until stop 30: S_ij = A_j G_ij / Σ_k A_k G_kj (heat kept, uniform flux
    not), G the Gaussian cut at SMOOTHING_CUTOFF standard deviations."""
    y = np.asarray(points_m) / np.array([sigma_m[0], sigma_m[0], sigma_m[1]])
    d = cKDTree(y).sparse_distance_matrix(cKDTree(y), SMOOTHING_CUTOFF, output_type="ndarray")
    g = np.exp(-0.5 * d["v"] ** 2)
    norm = np.bincount(d["j"], weights=area_m2[d["i"]] * g, minlength=len(area_m2))
    w = area_m2[d["j"]] * g / norm[d["j"]]
    return sps.csr_matrix((w, (d["i"], d["j"])), shape=(len(area_m2),) * 2)


def _row_max(u: np.ndarray, z: np.ndarray) -> list[float]:
    """Largest ``u`` per row of facet centroids (rows: z to 1 um), from z = 0."""
    rows = np.round(z * 1e6).astype(np.int64)
    return [float(u[rows == r].max()) for r in np.unique(rows)]


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--docs", action="store_true", help="write the docs/refinement.md block")
    args = p.parse_args()
    # the per-facet layers study these rows were measured for (the built-in case's resolution
    # until stop 33; since stop 34 it is evaluated continuously with the width kept)
    builtin = load_case(None)
    case = dataclasses.replace(
        builtin,
        sources=dataclasses.replace(
            builtin.sources,
            flux_evaluation="reference_facets",
            flux_smoothing_axial_mm=PER_FACET_AXIAL_WIDTH_MM,
        ),
    )
    b = case.geometry.face_width_mm * 1e-3
    table, raw = [], []
    for level in LEVELS:
        c = case if level == 0 else level_case(case, "structural_layers", 1.5**level)
        directory = case_cycle_dir(c)
        if not (directory / "cycle.json").is_file():
            raise SystemExit(
                f"no cached cycle of {c.mesh.layers} layers in {directory}: run "
                "`mpirun -n 2 python benchmarks/uncertainty_builtin.py --kinds structural_layers`"
            )
        f = load(directory).fields["pinion"]
        # the reconstruction acts on all contact-surface facets (drive flank, tip, root); the
        # rows are read on the drive flank's
        flank = f.facet_kind == "drive_flank"
        pts = f.facet_points_m - f.center_m
        area = f.facet_area_m2
        z = f.facet_points_m[:, 2]
        n_rows = len(np.unique(np.round(z[flank] * 1e6)))
        # the cycle's own flux per row (no reconstruction): heat per area relative to the flank's
        q = f.generated_flux_W_m2_per_rad_s[flank]
        density = _row_means(q, z[flank], area[flank])
        peak = _row_max(q, z[flank])
        raw.append(
            [
                f"{c.mesh.layers} ({n_rows} rows)",
                " / ".join(f"{v / np.mean(density):.3f}" for v in density),
                " / ".join(f"{v:.0f}" for v in peak),
            ]
        )
        widths = sorted({c.sources.flux_smoothing_axial_mm, case.sources.flux_smoothing_axial_mm})
        for width in widths:
            sigma = (c.sources.flux_smoothing_profile_mm * 1e-3, width * 1e-3)
            planes = (-f.center_m[2], b - f.center_m[2])
            for label, S in (
                ("gearfem's (balanced, images)", smoothing_operator(pts, area, sigma, planes)),
                ("until stop 30 (per column)", column_normalised(pts, area, sigma)),
            ):
                u = S @ np.ones(len(area))
                rows = _row_means(u[flank], z[flank], area[flank])
                first = " / ".join(f"{v:.3f}" for v in rows[:ROWS_SHOWN])
                last = " / ".join(f"{v:.3f}" for v in rows[::-1][:ROWS_SHOWN])
                study = " (the study's)" if width == c.sources.flux_smoothing_axial_mm else ""
                table.append(
                    [
                        f"{c.mesh.layers} ({n_rows} rows, {1e3 * b / n_rows:.2f} mm)",
                        f"{width:.3g} mm{study}",
                        label,
                        first,
                        last,
                        f"{max(abs(v - 1.0) for v in rows):.1e}",
                        f"{np.max(np.abs(u - 1.0)):.1e}",
                    ]
                )
    text = markdown_table(
        (
            "layers (rows, spacing)",
            "axial width",
            "reconstruction",
            "first rows from z = 0",
            "first rows from z = b",
            "largest deviation of a row mean from 1",
            "of a facet (all contact facets)",
        ),
        table,
    )
    caption = (
        "\n\nA uniform flux through the reconstruction on the pinion's contact-surface facets of "
        "each layer level's cycle; rows: area-weighted means over the drive flank's facet rows "
        "(1 = unbiased); "
        "`python benchmarks/reconstruction_side_faces.py --docs`."
    )
    raw_text = markdown_table(
        (
            "layers (rows)",
            "heat per area of each row / the rows' mean, from z = 0",
            "largest facet flux of each row, W/m² per rad/s",
        ),
        raw,
    )
    raw_caption = (
        "\n\nThe pinion's drive-flank flux of each layer level's cycle as the cycle delivers it "
        "(revolution average, before any reconstruction), per facet row across the face width; "
        "`python benchmarks/reconstruction_side_faces.py --docs`."
    )
    print(text)
    print(raw_text)
    if args.docs:
        replace_block(DOC, "reconstruction_side_faces", text + caption)
        replace_block(DOC, "cycle_flux_rows", raw_text + raw_caption)


if __name__ == "__main__":
    main()
