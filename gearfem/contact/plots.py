"""Pictures and tables of contact results (matplotlib; rank 0 only, no MPI in here).

* :func:`plot_hertz_pressure` — FE contact pressure of a Hertz line contact against the ellipse
  p0 sqrt(1 − x²/a²), with the pointwise error.
* :func:`write_hertz_csv` — the contact integration points with the Hertz pressure at the same
  undeformed position.
"""

from __future__ import annotations

import csv
import os
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from gearfem.contact.verification import hertz_pressure

_METHOD_NAMES = {"penalty": "penalty", "augmented_lagrangian": "augmented Lagrangian"}


def plot_hertz_pressure(path: Path, table, cmp, info: dict) -> None:
    """FE pressure at the integration points against Hertz, with the pointwise error (rank 0
    only: no MPI in here). ``table``: :func:`gearfem.contact.output.gather_points`; ``cmp``:
    :func:`gearfem.contact.verification.compare_hertz`; ``info``: dofs, ranks, contact_size_m,
    youngs_modulus_Pa, poissons_ratio, method, friction_coefficient, radius_m."""
    a, p0 = cmp.a_analytic_m, cmp.p0_analytic_Pa
    xa = table.x_reference[:, 0] / a  # Hertz's theory is small-strain: positions before deformation
    view = np.abs(xa) <= 1.5
    fig, (ax, ax_err) = plt.subplots(
        2, 1, figsize=(7.2, 6.6), sharex=True, height_ratios=(3, 1.25), constrained_layout=True
    )
    s = np.linspace(-1.5, 1.5, 1201)
    ax.plot(
        s,
        hertz_pressure(s, 1.0, 1.0),
        color="black",
        lw=1.6,
        label=r"Hertz $p_0\sqrt{1-x^2/a^2}$",
        zorder=3,
    )
    styles = [dict(marker="o", color="tab:blue"), dict(marker="^", color="tab:orange")]
    for k, name in enumerate(table.slaves):
        sel = view & (table.pass_index == k)
        ax.scatter(
            xa[sel],
            table.pressure[sel] / p0,
            s=11,
            alpha=0.55,
            lw=0,
            label=f"FE, slave: {name}",
            zorder=2,
            **styles[k],
        )
        err = (table.pressure[sel] - hertz_pressure(table.x_reference[sel, 0], a, p0)) / p0
        ax_err.scatter(xa[sel], 100.0 * err, s=9, alpha=0.55, lw=0, **styles[k])
    mu = info["friction_coefficient"]
    if mu > 0.0:
        q = np.linalg.norm(table.shear, axis=1)
        ax.scatter(
            xa[view], q[view] / p0, s=6, color="tab:green", alpha=0.5, lw=0, label=r"FE shear $|q|$"
        )
        ax.plot(
            s,
            mu * hertz_pressure(s, 1.0, 1.0),
            color="tab:green",
            lw=1.2,
            ls="--",
            label=r"$\mu\,p$ (Hertz)",
        )
    ax.axhline(0.0, color="0.6", lw=0.6)
    for v in (-1.0, 1.0):
        ax.axvline(v, color="0.6", lw=0.6, ls=":")
        ax_err.axvline(v, color="0.6", lw=0.6, ls=":")
    ax_err.axhline(0.0, color="0.6", lw=0.6)
    ax.set_xlim(-1.5, 1.5)
    ax.set_ylim(-0.05, 1.2)
    ax.set_ylabel(r"contact pressure $p / p_0$")
    ax_err.set_xlabel(r"position across the contact (undeformed) $x / a$")
    ax_err.set_ylabel(r"$(p - p_{\rm Hertz}) / p_0$  [%]")
    top = ax.secondary_xaxis("top", functions=(lambda u: u * a * 1e3, lambda v: v / (a * 1e3)))
    top.set_xlabel("x [mm]")
    right = ax.secondary_yaxis("right", functions=(lambda u: u * p0, lambda v: v / p0))
    right.set_ylabel("p [Pa]")
    ranks = f"{info['ranks']} rank{'s' if info['ranks'] > 1 else ''}"
    ax.set_title(
        f"Hertz line contact, {info['dofs']:,} DOFs on {ranks}: "
        f"$p_0$ {100 * cmp.p0_error:+.2f} %, $a$ {100 * cmp.a_error:+.2f} %",
        fontsize=10.5,
    )
    txt = (
        f"R = {info['radius_m']:g} m (both), E = {info['youngs_modulus_Pa']:g} Pa, ν = "
        f"{info['poissons_ratio']:g}\n"
        f"P' = {cmp.force_per_length_N_m:.4g} N/m → a = {a * 1e3:.3f} mm, $p_0$ = {p0:.4g} Pa\n"
        f"h = {info['contact_size_m'] * 1e3:g} mm = a/{a / info['contact_size_m']:.1f}, "
        f"{_METHOD_NAMES[info['method']]}, μ = {mu:g}\n"
        f"a from pressure moments; ellipse fit: {100 * (cmp.a_fit_m / a - 1):+.2f} %\n"
        f"x: undeformed position of the integration points"
    )
    ax.text(
        0.015,
        0.975,
        txt,
        transform=ax.transAxes,
        va="top",
        ha="left",
        fontsize=8,
        bbox=dict(boxstyle="round", fc="white", ec="0.8", alpha=0.9),
    )
    ax.legend(loc="upper right", fontsize=8, framealpha=0.9)
    tmp = path.with_name(f".{path.stem}.tmp{os.getpid()}{path.suffix}")
    fig.savefig(tmp, dpi=150)
    plt.close(fig)
    os.replace(tmp, path)


def write_hertz_csv(path: Path, table, cmp) -> None:
    """The integration points with the Hertz pressure at the same (undeformed) x (rank 0 only)."""
    a, p0 = cmp.a_analytic_m, cmp.p0_analytic_Pa
    ph = hertz_pressure(table.x_reference[:, 0], a, p0)
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    with open(tmp, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(
            [
                "pass",
                "slave_surface",
                "x_ref_m",
                "y_ref_m",
                "z_ref_m",
                "x_m",
                "y_m",
                "z_m",
                "x_ref_over_a",
                "gap_m",
                "pressure_Pa",
                "p_over_p0",
                "p_hertz_Pa",
                "traction_x_Pa",
                "traction_y_Pa",
                "traction_z_Pa",
                "normal_x",
                "normal_y",
                "normal_z",
                "weight_m2",
            ]
        )
        for i in range(table.num_points):
            k = int(table.pass_index[i])
            w.writerow(
                [
                    k,
                    table.slaves[k],
                    *(f"{v:.10e}" for v in table.x_reference[i]),
                    *(f"{v:.10e}" for v in table.x[i]),
                    f"{table.x_reference[i, 0] / a:.6f}",
                    f"{table.gap[i]:.6e}",
                    f"{table.pressure[i]:.10e}",
                    f"{table.pressure[i] / p0:.6f}",
                    f"{ph[i]:.10e}",
                    *(f"{v:.10e}" for v in table.traction[i]),
                    *(f"{v:.8f}" for v in table.normal[i]),
                    f"{table.weight[i]:.10e}",
                ]
            )
    os.replace(tmp, path)
