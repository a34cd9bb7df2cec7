"""Analytic baselines at the two thesis bench points (Doll 2015, chapter 6), printed as a table.

PEEK 450G pair, 30/30 teeth, m = 2 mm, 30 deg pressure angle, b = 12.934 mm, addendum 1 m
(assumed), dedendum 1.25 m (assumed), centre distance 60 mm, mu = 0.5 (the thesis model's value),
ambient 23 C (the thesis model's; the IR camera was set to 21 C). Tooth thickness 2.995 mm at the
pitch circle gives the generating profile shift for the root stress; the root fillet is the largest
tool tip radius a 30-deg, 1.25 m rack admits (a full-round tip, 0.110 m; the 0.38 m of
thesis_gear.toml does not fit such a rack).

Usage:  python benchmarks/verification/baselines_thesis.py

Purpose: verification (the analytic baselines at the bench points).
Writes: no documentation block (prints its table).
"""

from __future__ import annotations

import gearfem  # noqa: F401  (import order)
from gearfem import baselines as B
from gearfem.core.materials import Material, read_csv, read_toml


def main() -> None:
    ref = read_toml("thesis_gear_reference.toml")
    kg, ag = ref["known"]["geometry"], ref["assumed"]["geometry"]
    model = ref["known"]["model"]
    m = ag["module_mm"] * 1e-3
    z = kg["teeth"]
    alpha = kg["pressure_angle_deg"]
    r_a = (m * z / 2) + ag["addendum_mm"] * 1e-3
    h_fP = ag["dedendum_mm"] * 1e-3 / m
    x = B.profile_shift_from_thickness(kg["operating_tooth_thickness_mm"] * 1e-3, m, alpha)
    opt = B.BaselineOptions(
        rack_dedendum_coef=h_fP, rack_fillet_coef=B.max_rack_fillet_coef(alpha, h_fP)
    )
    peek = Material.peek450g()
    bench = read_csv("testbench", "thesis_testbench.csv")

    rows = []
    for row in bench:
        rows.append(
            B.baseline_summary(
                speed_rpm=float(row["speed_rpm"]),
                torque_Nm=float(row["torque_Nm"]),
                mu=model["friction_coefficient"],
                teeth1=z,
                teeth2=z,
                module_m=m,
                pressure_angle_deg=alpha,
                face_width_m=kg["face_width_mm"] * 1e-3,
                tip_radius1_m=r_a,
                tip_radius2_m=r_a,
                centre_distance_m=kg["operating_pitch_diameter_mm"] * 1e-3,
                ambient_C=model["ambient_C"],
                material1=peek,
                material2=peek,
                profile_shift1=x,
                profile_shift2=x,
                options=opt,
            )
        )

    print(
        f"PEEK 450G pair z = {z}/{z}, m = {m * 1e3:g} mm, alpha = {alpha:g} deg, b = "
        f"{kg['face_width_mm']} mm, "
        f"r_a = {r_a * 1e3:g} mm, x = {x:+.4f}, rho_fP = {opt.rack_fillet_coef:.4f} m, mu = "
        f"{model['friction_coefficient']}, "
        f"ambient {model['ambient_C']} C"
    )
    lines = [
        ("speed (rpm)", "speed_rpm", 1, "{:.0f}"),
        ("torque (N m)", "torque_Nm", 1, "{:.1f}"),
        ("power (W)", "power_W", 1, "{:.1f}"),
        ("pitch-line speed (m/s)", "pitch_line_speed_m_s", 1, "{:.3f}"),
        ("contact ratio eps_alpha", "contact_ratio", 1, "{:.4f}"),
        ("tooth loss factor H_V", "tooth_loss_factor_HV", 1, "{:.4f}"),
        ("friction power mu H_V P (W)", "friction_power_W", 1, "{:.2f}"),
        ("VDI 2736 flank (C)", "vdi2736_flank1_C", 1, "{:.1f}"),
        ("VDI 2736 root (C)", "vdi2736_root1_C", 1, "{:.1f}"),
        ("Mao bulk (C)", "mao_bulk1_C", 1, "{:.1f}"),
        ("Blok flash max (K)", "flash_max_K", 1, "{:.1f}"),
        ("  at s from pitch point (mm)", "flash_max_at_s_m", 1e3, "{:+.3f}"),
        ("  min Peclet number", "flash_min_peclet", 1, "{:.0f}"),
        ("VDI root + flash max (C)", "vdi_root_plus_flash_max_C", 1, "{:.1f}"),
        ("Hertz p0 at pitch point (MPa)", "hertz_pitch_p0_Pa", 1e-6, "{:.2f}"),
        ("AGMA sigma_H at pitch point (MPa)", "agma_pitch_sigma_H_Pa", 1e-6, "{:.2f}"),
        ("Hertz half-width at pitch (mm)", "hertz_pitch_half_width_m", 1e3, "{:.4f}"),
        ("ISO 6336-3 B: Y_F", "iso6336_YF1", 1, "{:.4f}"),
        ("ISO 6336-3 B: Y_S", "iso6336_YS1", 1, "{:.4f}"),
        ("ISO 6336-3 B: sigma_F0 (MPa)", "iso6336_sigmaF0_1_Pa", 1e-6, "{:.2f}"),
        ("VDI 2736: Y_Fa", "vdi2736_YFa1", 1, "{:.4f}"),
        ("VDI 2736: Y_Sa", "vdi2736_YSa1", 1, "{:.4f}"),
        ("VDI 2736: Y_eps", "vdi2736_Yeps", 1, "{:.4f}"),
        ("VDI 2736: sigma_F (MPa)", "vdi2736_sigmaF1_Pa", 1e-6, "{:.2f}"),
    ]
    w = 36
    print(f"{'':{w}s}" + "".join(f"{'point ' + str(i + 1):>14s}" for i in range(len(rows))))
    for label, key, scale, fmt in lines:
        print(f"{label:{w}s}" + "".join(f"{fmt.format(r[key] * scale):>14s}" for r in rows))
    meas = [float(r["measured_max_surface_C"]) for r in bench]
    cam = [float(r["camera_ambient_C"]) for r in bench]
    print(f"{'measured max surface (C)':{w}s}" + "".join(f"{t:>14.1f}" for t in meas))

    a, b = rows
    print("\nratio of temperature rises, point 2 / point 1 (equal power, speed x2, torque /2):")
    for label, key in (
        ("VDI 2736 flank", "vdi2736_flank1_C"),
        ("VDI 2736 root", "vdi2736_root1_C"),
        ("Mao bulk", "mao_bulk1_C"),
        ("VDI root + Blok flash max", "vdi_root_plus_flash_max_C"),
    ):
        print(f"  {label:28s} {B.temperature_rise_ratio(a, b, key):.3f}")
    print(f"  {'Blok flash max':28s} {b['flash_max_K'] / a['flash_max_K']:.3f}")
    print(f"  {'bench (camera ambient 21 C)':28s} {(meas[1] - cam[1]) / (meas[0] - cam[0]):.3f}")
    print(f"  {'bench (ambient 23 C)':28s} {(meas[1] - 23.0) / (meas[0] - 23.0):.3f}")


if __name__ == "__main__":
    main()
