"""The README's headline table, written from a finished main job.

Reads ``RESULT_DIR/summary.json`` of ``./dev.sh run`` (the built-in case at 1000 rpm / 8 N m) and,
with ``--other``, the summary of the same case at 2000 rpm / 4 N m (``demos/bench_camera.py``
writes it to ``results/bench_2000rpm_4Nm``), and writes the headline (each number with its
numerical uncertainty u_num, next to what it is compared with) into block ``readme_headline`` of
README.md, headed by the provenance the runs recorded (resolution key, code hash, commit:
gearfem.claims), so that a change of the model marks the headline stale until it is rerun.

    ./dev.sh run && python benchmarks/headline.py results/thesis [--other results/bench_2000rpm_4Nm]
"""

from __future__ import annotations

import argparse
from pathlib import Path

from gearfem.core.doctables import Provenance, markdown_table, replace_block
from gearfem.core.errors import ParameterError
from gearfem.pipeline import RunSummary

ROOT = Path(__file__).resolve().parent.parent


def _pm(value: float, u: float | None, fmt: str, unit: str) -> str:
    text = f"{value:{fmt}} ± {u:{fmt}}" if u is not None else f"{value:{fmt}}"
    return f"{text} {unit}".strip()


def headline(main: RunSummary, other: RunSummary | None) -> tuple[str, Provenance | None]:
    h, c, b = main.headline, main.cycle, main.baselines
    u = h.u_num or {}
    cam = main.instruments.camera if main.instruments is not None else {}
    at = "900" if "900" in cam else "end"
    title = (
        f"quantity ({main.speed_rpm:g} rpm, {main.torque_Nm:g} N m; end of the {h.time_s:g} s run)"
    )
    rows = [
        (
            "effective contact ratio (load sharing from the contact solve)",
            _pm(c.effective_contact_ratio, u.get("effective_contact_ratio"), ".2f", ""),
            f"{c.theoretical_contact_ratio:.2f} for rigid teeth",
        ),
        (
            "friction heat of the pair",
            _pm(h.friction_power_W, u.get("friction_power_W"), ".1f", "W"),
            "",
        ),
        (
            "pitch-point pressure (the pitch-point band's Hertz profile of its load)",
            f"{c.pitch_point_band_pressure_MPa:.1f} MPa",
            f"Hertz at the pitch point, nominal load {b['hertz_pitch_p0_Pa'] / 1e6:.1f} MPa",
        ),
        (
            "bulk temperature of the pinion",
            _pm(h.mean_bulk_temperature_C, u.get("mean_bulk_temperature_C"), ".1f", "C"),
            "",
        ),
        (
            "hottest surface temperature (the field's maximum)",
            _pm(h.max_surface_field_C, u.get("max_surface_field_C"), ".1f", "C"),
            f"VDI 2736 flank {h.vdi2736_flank_C:.0f} C",
        ),
    ]
    if at in cam:
        r = cam[at]
        rows.append(
            (
                f"IR camera reading `camera_max` at {at} s",
                f"**{r.max_C:.1f} C**, u_num {u.get('camera_max_C', float('nan')):.1f} K, "
                f"aim {r.aim_std_C:.1f} K",
                "bench 110 ± 3 C",
            )
        )
    prov = Provenance(**main.provenance) if main.provenance else None
    if other is not None:
        oc = other.instruments.camera if other.instruments is not None else {}
        oat = "900" if "900" in oc else "end"
        if oat in oc:
            rows.append(
                (
                    f"the same at {other.speed_rpm:g} rpm / {other.torque_Nm:g} N m",
                    f"**{oc[oat].max_C:.1f} C**",
                    "bench 49 ± 3 C",
                )
            )
        op = Provenance(**other.provenance) if other.provenance else None
        if prov is not None and op is not None:
            if op.resolution != prov.resolution:
                raise ParameterError(
                    "--other",
                    op.resolution,
                    f"a run at the main job's resolution {prov.resolution}",
                )
            prov = Provenance(prov.resolution, {**op.code, **prov.code}, prov.commit, prov.date)
    table = markdown_table((title, "gearfem", "compare with"), rows)
    note = (
        f"\n\nu_num: numerical standard uncertainty from the refinement studies of resolution "
        f"{prov.resolution if prov else '?'}; the camera's aim: the unknown sub-pixel position of "
        "its pixel grid on the gears. Written by `python benchmarks/headline.py` from the runs' "
        "summary.json."
    )
    return table + note, prov


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("result", help="the main job's output directory (results/thesis)")
    ap.add_argument("--other", default=None, help="the 2000 rpm / 4 N m run's output directory")
    ap.add_argument("--readme", default=str(ROOT / "README.md"))
    a = ap.parse_args()
    main_run = RunSummary.read(Path(a.result) / "summary.json")
    other = RunSummary.read(Path(a.other) / "summary.json") if a.other else None
    text, prov = headline(main_run, other)
    print(text)
    replace_block(a.readme, "readme_headline", text, prov)


if __name__ == "__main__":
    main()
