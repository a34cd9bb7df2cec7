"""The synthetic thermogram: the camera's frame-averaged image as a PNG with its colour scale and
as a numbers file (one CSV row per detector row, C)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from gearfem.instruments.camera import Thermogram
from gearfem.instruments.options import CameraOptions


def write_csv(th: Thermogram, options: CameraOptions, path: Path, note: str = "") -> Path:
    """The image as CSV: ``pixels_v`` rows of ``pixels_h`` readings (C, row 0 at the top)."""
    r = th.reading
    head = [
        f"synthetic thermogram ({note})" if note else "synthetic thermogram",
        f"time: {r.label}; frame-averaged readings in C, row 0 = top of the image",
        f"camera: {options.pixels_h} x {options.pixels_v} px, FOV {options.fov_h_deg:g} x "
        f"{options.fov_v_deg:g} deg, band {options.band_um[0]:g}-{options.band_um[1]:g} um, "
        f"view {options.view}, distance {options.distance_m:g} m, emissivity setting "
        f"{options.emissivity_setting:g}, reflected {options.reflected_C:g} C",
        f"camera_max {r.max_C:.2f} C (mean over {r.aims} sub-pixel aims, standard deviation "
        f"{r.aim_std_C:.2f} K); at the nominal aim the hottest pixel (row, col) {r.pixel} reads "
        f"{r.pixel_C:.2f} C ({r.body} {r.surface})",
    ]
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    np.savetxt(tmp, th.image_C, fmt="%.3f", delimiter=",", header="\n".join(head))
    os.replace(tmp, path)
    return path


def write_png(th: Thermogram, options: CameraOptions, path: Path, title: str = "") -> Path:
    """The full frame as the camera shows it and a close-up of the gears, each with its colour
    scale in C; the hottest pixel marked (like a camera's spot marker)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    r = th.reading
    img = th.image_C
    r0, r1, c0, c1 = th.window
    vmin, vmax = float(img.min()), float(img.max())
    fig, axes = plt.subplots(1, 2, figsize=(12.5, 4.8), gridspec_kw={"width_ratios": [1.0, 1.25]})
    for ax, (rows, cols), name in (
        (axes[0], (slice(None), slice(None)), "full frame"),
        (axes[1], (slice(r0, r1), slice(c0, c1)), "close-up"),
    ):
        off_r = 0 if name == "full frame" else r0
        off_c = 0 if name == "full frame" else c0
        sub = img[rows, cols]
        extent = (off_c - 0.5, off_c + sub.shape[1] - 0.5, off_r + sub.shape[0] - 0.5, off_r - 0.5)
        im = ax.imshow(
            sub, cmap="inferno", vmin=vmin, vmax=vmax, interpolation="nearest", extent=extent
        )
        ax.plot(r.pixel[1], r.pixel[0], "+", color="cyan", ms=12, mew=1.5)
        if name == "close-up":
            ax.annotate(
                f"max {r.max_C:.1f} °C",
                (r.pixel[1], r.pixel[0]),
                xytext=(8, -14),
                textcoords="offset points",
                color="cyan",
                fontsize=10,
            )
        ax.set_xlabel("pixel column")
        ax.set_ylabel("pixel row")
        ax.set_title(name)
        cb = fig.colorbar(im, ax=ax, fraction=0.046, pad=0.03)
        cb.set_label("reading (°C)")
    fig.suptitle(
        title
        or (
            f"synthetic thermogram, {r.label}: camera_max {r.max_C:.1f} °C ± {r.aim_std_C:.1f} K "
            f"aim (hottest model node {r.hottest_node_C:.1f} °C)"
        ),
        fontsize=11,
    )
    fig.text(
        0.01,
        0.01,
        f"{options.pixels_h}x{options.pixels_v} px, FOV {options.fov_h_deg:g}x"
        f"{options.fov_v_deg:g}°, {options.band_um[0]:g}-{options.band_um[1]:g} µm, view "
        f"{options.view}, {options.distance_m:g} m, ε set {options.emissivity_setting:g}, "
        f"reflected {options.reflected_C:g} °C, footprint {r.footprint_mm:.2f} mm; "
        f"hottest pixel sees {_parts(r.surface_fractions)}",
        fontsize=8,
    )
    fig.tight_layout(rect=(0, 0.04, 1, 0.95))
    tmp = path.with_name(f".{path.stem}.tmp{os.getpid()}.png")
    fig.savefig(tmp, dpi=110)
    plt.close(fig)
    os.replace(tmp, path)
    return path


def _parts(fractions: dict[str, float]) -> str:
    return ", ".join(f"{k} {v:.0%}" for k, v in list(fractions.items())[:3])
