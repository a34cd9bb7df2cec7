"""VDI 2736-2 flank and root temperatures of four material pairs at the thesis geometry, from the
materials library, and the library's values as a table.

Pairs (pinion / wheel): PEEK 450G / PEEK 450G, POM / POM, steel / POM, steel / PA66, each at the
thesis gear geometry (30/30 teeth, m = 2 mm, 30 deg, b = 12.934 mm, unshifted, tip radius 32 mm,
a = 60 mm: gearfem/data/thesis_gear_reference.toml, through gearfem.geometry.profile_shift) and
the operating points 1000 rpm / 4 N m, 1000 rpm / 8 N m, 2000 rpm / 4 N m, ambient 23 C, open
drive (R_lambda,G = 0), continuous duty (ED = 1). For each: the tooth loss factor H_V
(gearfem.baselines.tooth_loss_factor) and the polymer gear's VDI 2736-2 flank and root
temperatures (gearfem.baselines.vdi2736_temperature_C),

    theta = theta_0 + P mu H_V k_theta / (b z (v_t m)^0.75),

with the pair's friction coefficient from the library (``friction_against_self`` of the polymer,
or its ``friction_against_steel``) and its interval (the temperature rise is proportional to mu,
so the interval of mu gives the interval of the rise), and k_theta by pairing
(gearfem.baselines.VDI2736_K_THETA: plastic/plastic 9000 / 2148 as quoted from VDI 2736-2 in the
project's reference data; plastic/steel 6300 / 895 from GEARpie's VDI2736.py, a secondary source).
The pairing is chosen by the materials, whichever gear is the steel one (GEARpie tests only
whether the pinion is steel, so a plastic pinion against a steel wheel gets its plastic/plastic
constants there).

Usage:  python benchmarks/studies/vdi2736_pairs.py [--docs [docs/materials.md]]

Prints both tables; ``--docs`` writes them into the blocks ``vdi2736_pairs`` and
``materials_library`` of the page (gearfem.core.doctables; no provenance line: no result of the
built-in case is quoted). Milliseconds, no solve.

Purpose: study (VDI 2736 side by side for the library's pairs; gearfem's own temperatures for these
pairs need the steel body and the config change of issue 45).
Writes: blocks ``vdi2736_pairs`` and ``materials_library`` of docs/materials.md (``--docs``).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import gearfem  # noqa: F401  (import order)
from gearfem import baselines as B
from gearfem.core.doctables import markdown_table, replace_block
from gearfem.core.material_library import (
    LibraryMaterial,
    SourcedValue,
    effusivity,
    library_material,
    library_names,
)
from gearfem.core.materials import read_toml
from gearfem.geometry.profile_shift import profile_shifted_pair

ROOT = Path(__file__).resolve().parents[2]
PAIRS = (("PEEK 450G", "PEEK 450G"), ("POM", "POM"), ("steel", "POM"), ("steel", "PA66"))
POINTS = ((1000.0, 4.0), (1000.0, 8.0), (2000.0, 4.0))
AMBIENT_C = 23.0


def thesis_geometry():
    ref = read_toml("thesis_gear_reference.toml")
    kg, ag = ref["known"]["geometry"], ref["assumed"]["geometry"]
    m = ag["module_mm"] * 1e-3
    pair = profile_shifted_pair(
        kg["teeth"],
        kg["teeth"],
        m,
        kg["pressure_angle_deg"],
        addendum_coef=ag["addendum_mm"] * 1e-3 / m,
        dedendum_coef=ag["dedendum_mm"] * 1e-3 / m,
    )
    return pair, kg["face_width_mm"] * 1e-3


def pair_constants(pinion: str, wheel: str) -> tuple[LibraryMaterial, str, SourcedValue]:
    """The polymer gear of the pair, the pairing (plastic/plastic or plastic/steel) and its mu."""
    m1, m2 = library_material(pinion), library_material(wheel)
    if m1.kind == m2.kind == "steel":
        raise ValueError("a steel/steel pair is not a plastic gear pair")
    polymer = m2 if m1.kind == "steel" else m1
    steel_mate = "steel" in (m1.kind, m2.kind)
    if not steel_mate and m1.name != m2.name:
        raise ValueError(f"no friction coefficient for {m1.name} against {m2.name} in the library")
    mu = polymer["friction_against_steel" if steel_mate else "friction_against_self"]
    return polymer, "plastic/steel" if steel_mate else "plastic/plastic", mu


def vdi_rows() -> list[list[str]]:
    p, b = thesis_geometry()
    rows = []
    H_V = B.tooth_loss_factor(
        p.teeth1,
        p.teeth2,
        p.module_m,
        p.pressure_angle_deg,
        p.tip_radius1_m,
        p.tip_radius2_m,
        p.centre_distance_m,
    )
    for pinion, wheel in PAIRS:
        polymer, pairing, mu_value = pair_constants(pinion, wheel)
        mu = mu_value.value
        k_flank, k_root = B.VDI2736_K_THETA[pairing]
        mu_lo, mu_hi = mu_value.interval()
        for n, T in POINTS:
            omega = n * 2.0 * 3.141592653589793 / 60.0
            P = T * omega
            v_t = omega * p.reference_radius1_m
            z = p.teeth2 if polymer.name == library_material(wheel).name else p.teeth1
            common = dict(
                ambient_C=AMBIENT_C,
                power_W=P,
                loss_factor=H_V,
                teeth=z,
                face_width_m=b,
                pitch_line_speed_m_s=v_t,
                module_m=p.module_m,
            )
            out = []
            for k in (k_flank, k_root):
                t = [B.vdi2736_temperature_C(mu=x, k_theta=k, **common) for x in (mu, mu_lo, mu_hi)]
                out.append(f"{t[0]:.1f} [{t[1]:.0f}, {t[2]:.0f}]")
            est = " est." if mu_value.estimate else ""
            rows.append(
                [
                    f"{pinion} / {wheel}",
                    f"{pairing} ({k_flank:.0f} / {k_root:.0f})",
                    f"{mu:.2f} [{mu_lo:.2f}, {mu_hi:.2f}]{est}",
                    f"{n:.0f}",
                    f"{T:.0f}",
                    f"{P:.0f}",
                    *out,
                    f"{polymer.value('max_service_temperature_C'):.0f}",
                ]
            )
    return rows


VDI_HEADERS = (
    "pair (pinion / wheel)",
    "pairing (k_θ flank / root)",
    "μ [interval]",
    "n (rpm)",
    "T (N m)",
    "P (W)",
    "flank (°C)",
    "root (°C)",
    "polymer's max service (°C)",
)

#: Rows of the library table: key, label, scale, format.
QUANTITIES = (
    ("density_kg_m3", "density (kg/m³)", 1.0, "{:.0f}"),
    ("youngs_modulus_Pa", "E, 23 °C (GPa)", 1e-9, "{:.2f}"),
    ("youngs_modulus_conditioned_Pa", "E conditioned (GPa)", 1e-9, "{:.2f}"),
    ("poissons_ratio", "ν", 1.0, "{:.2f}"),
    ("thermal_conductivity_W_mK", "k (W/(m K))", 1.0, "{:.3g}"),
    ("specific_heat_J_kgK", "c_p (J/(kg K))", 1.0, "{:.0f}"),
    ("thermal_expansion_1_K", "α_th (1e-6/K)", 1e6, "{:.3g}"),
    ("emissivity", "emissivity", 1.0, "{:.2f}"),
    ("glass_transition_C", "T_g (°C)", 1.0, "{:.0f}"),
    ("melting_C", "T_m (°C)", 1.0, "{:.0f}"),
    ("max_service_temperature_C", "max service (°C)", 1.0, "{:.0f}"),
    ("friction_against_self", "μ against itself", 1.0, "{:.2f}"),
    ("friction_against_steel", "μ against steel", 1.0, "{:.2f}"),
)


def library_block() -> str:
    mats = [library_material(n) for n in library_names()]
    rows = []
    for key, label, scale, fmt in QUANTITIES:
        cells = [label]
        for m in mats:
            if key not in m.values:
                cells.append("–")
                continue
            v = m[key]
            lo, hi = v.interval()
            f = lambda x: fmt.format(x * scale)
            cell = f"{f(v.value)} [{f(lo)}, {f(hi)}] `{v.source_key}`"
            cells.append(cell + (" **est.**" if v.estimate else ""))
        rows.append(cells)
    rows.append(["effusivity √(kρc_p) (W s^½/(m² K))", *(f"{effusivity(m):.0f}" for m in mats)])
    tables = []
    for m in mats:
        for t in m.tables.values():
            tables.append(
                f"- {m.name}, table `{t.name}` ({len(t.T_C)} points, {t.T_C[0]:g}–{t.T_C[-1]:g} "
                f"°C, `{t.source_key}`{', **est.**' if t.estimate else ''}): {t.quantity}."
                + (f" Estimate: {t.reason}." if t.estimate else "")
            )
        if m.kind == "polymer":
            absent = [q for q in ("hysteresis", "youngs_modulus_Pa") if q not in m.tables]
            if absent:
                what = " or ".join(
                    {"hysteresis": "H(T)", "youngs_modulus_Pa": "E(T)"}[q] for q in absent
                )
                tables.append(f"- {m.name}: no {what} table (none found in a stored source).")
    sources = []
    for m in mats:
        items = "; ".join(f"`{k}`: {c}" for k, c in m.sources.items())
        sources.append(f"- **{m.name}**, {m.grade}. {items}.")
    estimates = []
    for m in mats:
        for v in m.estimates():
            estimates.append(f"- {m.name} `{v.name}`: {v.reason}.")
    parts = [
        markdown_table(["quantity", *(m.name for m in mats)], rows),
        "",
        "Cells: value [input-uncertainty interval] `source key`; **est.**: an estimate.",
        "",
        "Temperature tables:",
        "",
        *tables,
        "",
        "Sources:",
        "",
        *sources,
        "",
        "Estimates and why:",
        "",
        *estimates,
    ]
    return "\n".join(parts)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--docs",
        nargs="?",
        const="docs/materials.md",
        default=None,
        help="write the blocks into this page (default docs/materials.md)",
    )
    args = ap.parse_args()
    p, b = thesis_geometry()
    vdi = markdown_table(VDI_HEADERS, vdi_rows())
    note = (
        f"Thesis geometry (z = {p.teeth1}/{p.teeth2}, m = {p.module_m * 1e3:g} mm, "
        f"α = {p.pressure_angle_deg:g}°, b = {b * 1e3:g} mm, r_a = {p.tip_radius1_m * 1e3:g} mm, "
        f"a = {p.centre_distance_m * 1e3:g} mm, ε_α = {p.contact_ratio:.4f}), ambient "
        f"{AMBIENT_C:g} °C, open drive, ED = 1; the temperatures of the polymer gear with the "
        "pair's μ and, in brackets, with the ends of its interval. Written by "
        "`python benchmarks/studies/vdi2736_pairs.py --docs`."
    )
    lib = library_block()
    print(vdi, note, "", lib, sep="\n")
    if args.docs:
        page = ROOT / args.docs if not Path(args.docs).is_absolute() else Path(args.docs)
        replace_block(page, "vdi2736_pairs", f"{vdi}\n\n{note}")
        replace_block(page, "materials_library", lib)
        print(f"wrote blocks vdi2736_pairs and materials_library of {page}")


if __name__ == "__main__":
    main()
