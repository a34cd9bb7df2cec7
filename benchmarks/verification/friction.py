"""Measured figures of docs/friction.md (issue 15): writes the tables between the page's markers.

    python benchmarks/verification/friction.py --approximation
        # TINY: recomputed flux vs a cycle at mu 0.3
    python benchmarks/verification/friction.py --verification
        # flash limits, 0-D branches and turning points
    python benchmarks/verification/friction.py --hysteresis
        # W / (H U_max) on the coarse cycle's cells
    python benchmarks/verification/friction.py --bench  # each law at the two bench points (coarse)

Cycles come from the cycle cache ($GEARFEM_CACHE or ./cache; computed on first use: TINY about
4 min each, coarse about 8 min each on this 2-core machine). Serial.

Purpose: verification (friction laws: flux approximation, flash and branch limits, hysteresis
check) and each law at the bench points.
Writes: blocks ``friction_*`` of docs/friction.md.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import shutil
import sys
import time
from pathlib import Path

import numpy as np
from mpi4py import MPI

import gearfem  # noqa: F401
from gearfem import baselines as B
from gearfem import pipeline
from gearfem.config import Case, load_case
from gearfem.contact.friction import FrictionOptions
from gearfem.contact.options import ContactOptions
from gearfem.core.doctables import markdown_table, replace_block
from gearfem.core.materials import ZERO_CELSIUS_K, Material
from gearfem.coupling.friction_heat import reference_flux
from gearfem.cycle.options import CycleOptions
from gearfem.geometry.options import BODIES, MeshOptions
from gearfem.instruments.evaluate import evaluate

ROOT = Path(__file__).resolve().parents[2]
PAGE = ROOT / "docs" / "friction.md"
IMAGES = ROOT / "docs" / "images" / "friction"
COMM = MPI.COMM_SELF

TINY = MeshOptions(
    teeth_in_model=4,
    refined_teeth=3,
    layers=2,
    size_flank_mm=0.35,
    size_tip_mm=0.35,
    size_root_mm=0.45,
    size_tooth_mm=1.5,
    size_body_mm=5.0,
)


def _tiny(mu: float) -> Case:
    return Case(
        mesh=TINY,
        contact=ContactOptions(friction_coefficient=mu),
        cycle=CycleOptions(positions_per_pitch=12, check_periodicity=False),
    ).with_operating(torque_Nm=8.0)


def approximation() -> None:
    """The first-order recomputation (the pressures of a mu = 0.5 cycle, mu = 0.3 in the heat)
    against a cycle solved at mu = 0.3."""
    c5, _, _ = pipeline.cycle(_tiny(0.5), COMM)
    c3, _, _ = pipeline.cycle(_tiny(0.3), COMM)
    mats, speed = Case().materials, 1000.0
    omega = 2 * math.pi * speed / 60
    law = FrictionOptions(mu=0.3).law_for(0.5)
    rows = []
    fig_data = {}
    for b in BODIES:
        f = c5.fields[b]
        q, _, _ = reference_flux(c5, b, law, mats, speed, 300.0)
        ref = c3.fields[b].generated_flux_W_m2_per_rad_s * omega
        A = f.facet_area_m2
        d = q - ref
        rows.append(
            (
                b,
                f"{30 * np.sum(q * A):.2f}",
                f"{30 * np.sum(ref * A):.2f}",
                f"{np.sum(q * A) / np.sum(ref * A) - 1:+.1%}",
                f"{math.sqrt(np.sum(d * d * A) / np.sum(ref * ref * A)):.1%}",
                f"{np.max(np.abs(d)) / np.max(ref):.1%}",
            )
        )
        fig_data[b] = (np.linalg.norm((f.facet_points_m - f.center_m)[:, :2], axis=1), q, ref)
    # the normal load: friction's moment about the wheel axis is part of the torque balance
    load5 = sum(np.asarray(v) for v in c5.tooth_load_N.values())
    load3 = sum(np.asarray(v) for v in c3.tooth_load_N.values())
    rows.append(
        (
            "normal load, mean over the cycle (N)",
            f"{np.mean(load5):.1f} (mu 0.5)",
            f"{np.mean(load3):.1f} (mu 0.3)",
            f"{np.mean(load5) / np.mean(load3) - 1:+.1%}",
            "",
            "",
        )
    )
    table = markdown_table(
        (
            "gear",
            "recomputed from the mu 0.5 cycle (W, both gears' heat, 30 teeth)",
            "cycle solved at mu 0.3 (W)",
            "heat difference",
            "flux difference (L2, area-weighted)",
            "largest facet difference / largest flux",
        ),
        rows,
    )
    replace_block(PAGE, "friction_approximation", table)
    IMAGES.mkdir(parents=True, exist_ok=True)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5), sharey=True)
    for ax, (b, (r, q, ref)) in zip(axes, fig_data.items()):
        o = np.argsort(r)
        ax.plot(r[o] * 1e3, ref[o] / 1e3, ".", ms=3, label="cycle solved at mu 0.3")
        ax.plot(r[o] * 1e3, q[o] / 1e3, ".", ms=3, label="recomputed from the mu 0.5 cycle")
        ax.set_xlabel(f"{b} facet radius (mm)")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("revolution-averaged flux, kW/m² (1000 rpm)")
    axes[0].legend()
    fig.suptitle("first-order recomputation of the friction flux (TINY mesh, 8 N m)")
    fig.tight_layout()
    fig.savefig(IMAGES / "approximation.png", dpi=120)
    print(table)


def verification() -> None:
    """Flash temperature limits and the 0-D branches and turning points (gearfem vs analytic)."""
    rows = [
        (
            "uniform band, maximum, L -> inf",
            "Jaeger 1942: 1.596 / sqrt 2 = 1.1285",
            f"{B.band_source_high_peclet('uniform'):.4f} (exact 2D at L = 1000: "
            f"{float(B.band_source_rise(1e3, 'uniform')) * math.sqrt(1e3):.4f})",
        ),
        (
            "uniform band, mean, L -> inf",
            "Jaeger 1942: 1.064 / sqrt 2 = 0.7524",
            f"{B.band_source_high_peclet('uniform', 'mean'):.4f}",
        ),
        (
            "semi-elliptic band, maximum, L -> inf",
            "Blok 1937: 1.11 (1D Duhamel integral 1.1115)",
            f"{B.band_source_high_peclet('semi_elliptic'):.4f} (exact 2D at L = 1000: "
            f"{float(B.band_source_rise(1e3)) * math.sqrt(1e3):.5f})",
        ),
    ]
    for L in (1e-3, 1e-2):
        for which in ("max", "mean"):
            ref = B.band_source_low_peclet_uniform(L, which)
            got = float(B.band_source_rise(L, "uniform", which))
            rows.append(
                (
                    f"uniform band, {which}, L = {L:g}",
                    f"K0 expansion: {ref:.4f} (k theta / (q a))",
                    f"{got:.4f} ({got / ref - 1:+.1e})",
                )
            )
    flash = markdown_table(
        ("quantity (k theta sqrt(L) / (q a) at high L)", "published / analytic", "gearfem"),
        rows,
    )
    replace_block(PAGE, "friction_flash_verification", flash)
    print(flash)
    sys.path.insert(0, str(ROOT / "tests"))
    import test_friction as T

    from gearfem.thermal.branches import continuation, steady_states

    prob, law, _ = T._lumped()
    folds, branches = T._analytic(law)
    t0 = time.perf_counter()
    with prob:
        prob.set_initial(T.TA)
        c = continuation(prob, 0.3, (0.2, 2.0), step=0.05, max_steps=2000, targets=(1.0,))
        found = steady_states(prob, {"cold": T.TA, "hot": branches[2] + 50.0})
    wall = time.perf_counter() - t0
    cross = sorted(c.crossings, key=lambda x: x.temperatures_C["max_surface"])
    rows = []
    for (s_fe, _), (s_ref, t_ref) in zip(c.turning_points, sorted(folds, reverse=True)):
        rows.append(
            (
                "turning point (heat scale)",
                f"{s_ref:.6f} at {t_ref - ZERO_CELSIUS_K:.2f} C",
                f"{s_fe:.6f} ({s_fe / s_ref - 1:+.1e})",
            )
        )
    for name, x, ref in zip(("cool", "middle", "hot"), cross, branches):
        rows.append(
            (
                f"{name} branch at scale 1 (continuation)",
                f"{ref - ZERO_CELSIUS_K:.3f} C",
                f"{x.temperatures_C['mean_bulk']:.3f} C, eigenvalue {x.eigenvalue_per_s:+.4f} /s "
                f"({'stable' if x.stable else 'unstable'})",
            )
        )
    for s in found:
        rows.append(
            (
                f"Newton from the {s.start} start",
                "",
                f"{s.temperatures_C['mean_bulk']:.3f} C ({'stable' if s.stable else 'unstable'})",
            )
        )
    rows.append(("continuation points / wall time", "", f"{len(c.points)} / {wall:.1f} s"))
    table = markdown_table(("0-D glass-transition model", "analytic", "gearfem"), rows)
    replace_block(PAGE, "friction_branches_verification", table)
    print(table)


def hysteresis(torque_Nm: float = 8.0) -> None:
    """W / (H U_max) of the cells' strain-energy pulses, and the hysteresis heat per gear."""
    case = load_case(ROOT / "tests" / "cases" / "coarse.toml").with_operating(torque_Nm=torque_Nm)
    cyc, _, _ = pipeline.cycle(case, COMM)
    mat = Material()
    H = mat.hysteresis_table()
    rows = []
    for b in BODIES:
        f = cyc.fields[b]
        o = np.argsort(f.history_angle_rad)
        U = f.u_history_J_m3[o]
        step = f.history_angle_rad[o][1] - f.history_angle_rad[o][0]
        n_rev = round(2 * math.pi / step)
        R = np.full(U.shape[1], np.nan)
        for c in range(U.shape[1]):
            s = np.zeros(n_rev)
            s[: U.shape[0]] = U[:, c]
            R[c] = B.hysteresis_loss_ratio(s)
        w = f.u_max_J_m3 * f.cell_volume_m3
        ok = np.isfinite(R)
        ratio = float(np.sum(w[ok] * R[ok]) / np.sum(w[ok]))
        e_rev = 30 * float(np.sum(w))  # J per revolution, every tooth loaded once
        f_rot = 1000.0 / 60.0
        for label, T_C in (("80 C", 80.0), ("T_g (peak H)", 144.0), ("170 C", 170.0)):
            h = float(H(T_C + ZERO_CELSIUS_K))
            for tq, scale in ((torque_Nm, 1.0), (20.0, (20.0 / torque_Nm) ** 2)):
                p = h * e_rev * scale * f_rot
                rows.append(
                    (
                        b,
                        f"{tq:g}",
                        label,
                        f"{h:.4f}",
                        f"{e_rev * scale:.3f}",
                        f"{p:.3f}",
                        f"{ratio:.2f}",
                        f"{ratio * p:.3f}",
                    )
                )
    table = markdown_table(
        (
            "gear",
            "torque N m",
            "H at",
            "H",
            "sum U_max V per turn (J)",
            "H U_max f (W)",
            "W / (H U_max), energy-weighted",
            "viscoelastic loss (W)",
        ),
        rows,
    )
    replace_block(PAGE, "friction_hysteresis", table)
    print(table)


BENCH_POINTS = ((1000.0, 8.0), (2000.0, 4.0))


def bench_laws() -> dict[str, FrictionOptions]:
    e_p = math.log(0.42 / 0.55) / math.log(70 / 20)
    return {
        "constant 0.5 (thesis)": FrictionOptions(),
        "table mu(T), PEEK-PEEK 4.3.5": FrictionOptions(
            law="table", table_C=((50.0, 75.0), (0.55, 0.40))
        ),
        "exponential, beta 0.0127/K (4.3.5)": FrictionOptions(
            mu=0.55, temperature_coefficient_per_K=math.log(0.55 / 0.40) / 25.0, reference_C=50.0
        ),
        "glass transition, mu_g 0.2 (Hanchi)": FrictionOptions(
            law="glass_transition", mu_glassy=0.2
        ),
        "glass transition, mu_g 0.1 (Hoskins)": FrictionOptions(
            law="glass_transition", mu_glassy=0.1
        ),
        "pressure, e -0.215 (4.3.5)": FrictionOptions(
            mu=0.55,
            pressure="power",
            pressure_exponent=e_p,
            pressure_reference_MPa=20.0,
            pressure_range_MPa=(15.0, 400.0),
        ),
        "sliding speed, e 0.034 (steel-PEEK 4.3.5)": FrictionOptions(
            sliding_speed="power",
            speed_exponent=math.log(0.56 / 0.48) / math.log(100.0),
            speed_reference_m_s=0.1,
            speed_range_m_s=(0.02, 2.0),
        ),
    }


def bench(out: Path, degree: int = 2) -> None:
    """Each law at the two bench points on the coarse case: field values at 900 s (when the bench
    was read) and at the steady state, the friction heat, and the steady states found."""
    base = load_case(ROOT / "tests" / "cases" / "coarse.toml")
    th = dataclasses.replace(
        base.thermal, degree=degree, duration_s=900.0, output_times_s=(), ambient_C=21.0
    )
    base = dataclasses.replace(base, thermal=th)
    rows, rises = [], {}
    for name, fr in bench_laws().items():
        for sp, tq in BENCH_POINTS:
            case = dataclasses.replace(base, friction=fr).with_operating(sp, tq)
            cyc, _, _ = pipeline.cycle(case, COMM)
            d = out / f"{len(rows):02d}"
            t0 = time.perf_counter()
            plot = name.startswith(("constant", "glass transition, mu_g 0.1")) and sp == 1000.0
            # both gears' thermal models and the IR camera's reading at the end (900 s)
            s, _, snap = pipeline.observed_thermal(
                case, d, COMM, cyc, write_fields=False, write_plot=plot
            )
            cam = pipeline.on_root(
                COMM, lambda: evaluate(case.instruments, snap, only=("camera",)).camera["end"].max_C
            )
            wall = time.perf_counter() - t0
            if plot:
                IMAGES.mkdir(parents=True, exist_ok=True)
                tag = "constant" if name.startswith("constant") else "glass_0.1"
                shutil.copy(
                    d / "thermal" / "friction_maps.png", IMAGES / f"maps_{tag}_1000rpm_8Nm.png"
                )
            f = s.get("friction", {})
            ss = s.get("steady_state_C", {})
            br = f.get("distinct_steady_states")
            rises[(name, sp)] = (s["final_temperatures_C"]["max_surface"] - 21.0, cam - 21.0)
            rows.append(
                (
                    name,
                    f"{sp:g} / {tq:g}",
                    f"{s['final_temperatures_C']['max_surface']:.1f}",
                    f"{s['final_temperatures_C']['mean_bulk']:.1f}",
                    f"{ss.get('max_surface', float('nan')):.1f}",
                    f"{s['final_balance_W']['friction_W'] / s['model_fraction']:.1f}",
                    f"{f.get('mu_heat_weighted', float('nan')):.3f}",
                    f"{f.get('contact_C_heat_weighted', float('nan')):.0f}",
                    "-" if br is None else f"{br} ({f.get('transient_branch')})",
                    f"{cam:.1f}",
                    f"{wall:.0f}",
                )
            )
            print(rows[-1], flush=True)
    table = markdown_table(
        (
            "law",
            "rpm / N m",
            "max surface at 900 s (C)",
            "bulk at 900 s (C)",
            "steady max surface (C)",
            "friction heat per gear (W)",
            "mu (heat-weighted)",
            "contact temperature (heat-weighted, C)",
            "steady states (transient's)",
            "camera_max at 900 s (C)",
            "wall s",
        ),
        rows,
    )
    ratio = markdown_table(
        (
            "law",
            "rise ratio 2000/4 over 1000/8, hottest node (900 s)",
            "the same, camera_max (900 s)",
        ),
        [
            (
                name,
                f"{rises[(name, 2000.0)][0] / rises[(name, 1000.0)][0]:.2f}",
                f"{rises[(name, 2000.0)][1] / rises[(name, 1000.0)][1]:.2f}",
            )
            for name in bench_laws()
        ]
        + [("bench (camera, thesis ch. 6: 49 and 110 C at 21 C)", "", "0.31")],
    )
    replace_block(PAGE, "friction_bench", table)
    replace_block(PAGE, "friction_bench_ratio", ratio)
    print(table)
    print(ratio)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--approximation", action="store_true")
    ap.add_argument("--verification", action="store_true")
    ap.add_argument("--hysteresis", action="store_true")
    ap.add_argument("--bench", action="store_true")
    ap.add_argument("--out", default="out/friction_bench")
    a = ap.parse_args()
    if a.approximation:
        approximation()
    if a.verification:
        verification()
    if a.hysteresis:
        hysteresis()
    if a.bench:
        bench(Path(a.out))


if __name__ == "__main__":
    main()
