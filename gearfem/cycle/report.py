"""Outputs of a cycle result: histories (CSV, JSON) and plots.

* ``cycle_history.csv``: per pinion position: TE, pinion and wheel torque, friction power (per unit
  ω₁), peak and mid-width contact pressure, root stresses, normal load per tooth;
* ``cycle_summary.json``: effective contact ratio, peaks, energy balance, periodicity check;
* ``load_sharing.png``: normal load of one tooth over its whole engagement versus roll angle, with
  the rigid-tooth path of contact marked, and the neighbours' loads;
* ``transmission_error.png``, ``strain_energy_history.png`` (the thesis Figure 14 analogue: strain
  energy density of a drive-flank cell of the reference tooth over the engagement),
* ``flank_maps.png``: envelope of the contact pressure and the revolution-averaged friction flux on
  the reference tooth's surfaces, over (roll length, face width).
Call on one rank (the result is replicated).
"""

from __future__ import annotations

import csv
import json
import math
import os
from pathlib import Path

import numpy as np

from gearfem.cycle.result import CycleResult


def _atomic(path: Path, writer) -> None:
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    writer(tmp)
    os.replace(tmp, path)


def cycle_summary_dict(r: CycleResult) -> dict:
    ratio = r.info.get("speed_ratio", 1.0)  # ω₂/ω₁ = z1/z2
    mean_loss = float(np.mean(r.pinion_torque_Nm - r.torque_Nm * ratio))  # power loss per unit ω₁
    out = {
        "torque_Nm": r.torque_Nm,
        "friction_coefficient": r.friction_coefficient,
        "positions": len(r.phi_rad),
        "pitch_deg": math.degrees(r.pitch_angle_rad),
        "effective_contact_ratio": r.effective_contact_ratio(),
        "theoretical_contact_ratio": r.theoretical_contact_ratio,
        "transmission_error_um": {
            "mean": float(np.mean(r.te_m) * 1e6),
            "min": float(np.min(r.te_m) * 1e6),
            "max": float(np.max(r.te_m) * 1e6),
        },
        "max_contact_pressure_MPa": float(np.max(r.p_max_Pa) / 1e6),
        "max_mid_width_pressure_MPa": float(np.max(r.p_max_mid_Pa) / 1e6),
        "max_root_stress_MPa": {b: float(np.max(v) / 1e6) for b, v in r.root_stress_Pa.items()},
        "mean_friction_power_W_per_rad_s": r.mean_friction_power_W_per_rad_s(),
        "mean_torque_loss_Nm": mean_loss,
        "tooth_heat_W_per_rad_s": {b: r.tooth_heat_W_per_rad_s(b) for b in r.fields},
        "max_u_J_m3": {b: float(np.max(f.u_max_J_m3)) for b, f in r.fields.items()},
        "newton_iterations": int(np.sum(r.newton_iterations)),
        "wall_time_s": float(np.sum(r.wall_time_s)),
        "info": r.info,
        "periodicity": None if r.periodicity is None else r.periodicity.to_json(),
    }
    return out


def write_cycle_outputs(r: CycleResult, out_dir: str | Path, plots: bool = True) -> Path:
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    teeth = sorted(k for k, v in r.tooth_load_N.items() if np.any(v > 0))

    def csv_writer(tmp):
        with open(tmp, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(
                [
                    "pinion_angle_deg",
                    "te_um",
                    "pinion_torque_Nm",
                    "wheel_contact_moment_Nm",
                    "friction_power_W_per_rad_s",
                    "p_max_MPa",
                    "p_max_mid_MPa",
                    *[f"root_stress_{b}_MPa" for b in r.root_stress_Pa],
                    *[f"load_tooth{k}_N" for k in teeth],
                    *[f"S_tooth{k}_mm" for k in teeth],
                    "newton_iterations",
                    "wall_time_s",
                ]
            )
            for i, phi in enumerate(r.phi_rad):
                w.writerow(
                    [
                        math.degrees(phi),
                        r.te_m[i] * 1e6,
                        r.pinion_torque_Nm[i],
                        r.wheel_torque_Nm[i],
                        r.friction_power_W_per_rad_s[i],
                        r.p_max_Pa[i] / 1e6,
                        r.p_max_mid_Pa[i] / 1e6,
                        *[v[i] / 1e6 for v in r.root_stress_Pa.values()],
                        *[r.tooth_load_N[k][i] for k in teeth],
                        *[r.tooth_S_m[k][i] * 1e3 for k in teeth],
                        int(r.newton_iterations[i]),
                        r.wall_time_s[i],
                    ]
                )

    _atomic(out / "cycle_history.csv", csv_writer)
    if plots:
        plot_cycle(r, out)
    _atomic(
        out / "cycle_summary.json",
        lambda tmp: tmp.write_text(json.dumps(cycle_summary_dict(r), indent=2, default=_jsonable)),
    )
    return out


def _jsonable(o):
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, np.generic):
        return o.item()
    return str(o)


def plot_cycle(r: CycleResult, out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    p = r.pitch_angle_rad
    deg = np.degrees
    # --- load sharing over one tooth's engagement
    phi, load = r.engagement_curve()
    total = np.sum(np.stack(list(r.tooth_load_N.values())), axis=0)
    fig, ax = plt.subplots(figsize=(8, 4.5))
    ax.plot(deg(phi), load, "o-", ms=3, color="C0", label="reference pinion tooth")
    ax.plot(deg(phi - p), load, "--", color="C0", alpha=0.4, label="previous / next tooth")
    ax.plot(deg(phi + p), load, "--", color="C0", alpha=0.4)
    ax.axhline(float(np.median(total)), color="0.4", lw=0.8, ls=":", label="total normal load")
    eps = r.theoretical_contact_ratio
    # rigid path of contact: the tooth is at the pitch point at 0; approach/recess split equally
    # here
    ax.axvspan(
        -deg(0.5 * eps * p),
        deg(0.5 * eps * p),
        color="C2",
        alpha=0.08,
        label=f"rigid path of contact (ε = {eps:.2f})",
    )
    ax.set_xlabel("pinion angle from the pitch-point position (deg)")
    ax.set_ylabel("normal load on the tooth (N)")
    ax.set_title(
        f"Load sharing at {r.torque_Nm:g} N m, μ = {r.friction_coefficient:g}: effective contact "
        f"ratio "
        f"{r.effective_contact_ratio():.2f}"
    )
    ax.legend(fontsize=8, loc="upper right")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(out / "load_sharing.png", dpi=130)
    plt.close(fig)
    # --- transmission error and torques
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    a1.plot(deg(r.phi_rad - r.phi_rad[0]), r.te_m * 1e6, "o-", ms=3)
    a1.set_ylabel("transmission error (µm)")
    a1.grid(alpha=0.3)
    a2.plot(deg(r.phi_rad - r.phi_rad[0]), r.pinion_torque_Nm, "o-", ms=3, label="pinion (input)")
    a2.plot(
        deg(r.phi_rad - r.phi_rad[0]), -r.wheel_torque_Nm, "s-", ms=3, label="wheel (resisting)"
    )
    a2.set_ylabel("torque (N m)")
    a2.set_xlabel("pinion angle over one pitch (deg)")
    a2.legend(fontsize=8)
    a2.grid(alpha=0.3)
    fig.suptitle(f"Transmission error and torques, {r.torque_Nm:g} N m")
    fig.tight_layout()
    fig.savefig(out / "transmission_error.png", dpi=130)
    plt.close(fig)
    # --- strain energy history of a drive-flank cell of the reference pinion tooth (thesis Fig. 14)
    f = r.fields["pinion"]
    rr = np.linalg.norm((f.cell_points_m - f.center_m)[:, :2], axis=1)
    target_r = (
        float(np.median(rr[f.u_max_J_m3 > 0.5 * np.max(f.u_max_J_m3)]))
        if np.any(f.u_max_J_m3 > 0)
        else 0.0
    )
    mid = np.abs(f.cell_points_m[:, 2] - np.median(f.cell_points_m[:, 2]))
    score = (
        f.u_max_J_m3 / max(np.max(f.u_max_J_m3), 1e-30) - np.abs(rr - target_r) / 1e-3 - mid / 5e-3
    )
    c = int(np.argmax(score))
    order = np.argsort(f.history_angle_rad)
    fig, ax = plt.subplots(figsize=(8, 4))
    ax.plot(deg(f.history_angle_rad[order]), f.u_history_J_m3[order, c] / 1e3, "-", color="C3")
    ax.set_xlabel(f"pinion angle (deg, one pitch is {deg(p):.0f} deg)")
    ax.set_ylabel("strain energy density (kJ/m³)")
    ax.set_title(
        f"Strain energy of a flank cell over its engagement (U_max = {f.u_max_J_m3[c] / 1e3:.1f} "
        f"kJ/m³)"
    )
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(out / "strain_energy_history.png", dpi=130)
    plt.close(fig)
    # --- flank maps
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), sharey=True)
    for ax, vals, lab in (
        (axes[0], f.pressure_max_Pa / 1e6, "contact pressure envelope (MPa)"),
        (
            axes[1],
            f.generated_flux_W_m2_per_rad_s / 1e3,
            "friction flux generated per unit ω₁ (kW/m² per rad/s)",
        ),
    ):
        rf = np.linalg.norm((f.facet_points_m - f.center_m)[:, :2], axis=1)
        sc = ax.scatter(
            rf * 1e3, f.facet_points_m[:, 2] * 1e3, c=vals, s=10, cmap="inferno", marker="s"
        )
        fig.colorbar(sc, ax=ax, label=lab)
        ax.set_xlabel("radius on the reference pinion tooth (mm)")
    axes[0].set_ylabel("face width position (mm)")
    fig.suptitle("Reference pinion tooth: drive flank, tip and root")
    fig.tight_layout()
    fig.savefig(out / "flank_maps.png", dpi=130)
    plt.close(fig)
