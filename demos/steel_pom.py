"""A steel pinion driving a POM wheel: the two bodies, the heat they share, and VDI 2736 beside it.

Runs ``demos/steel_pom.toml`` (or ``--case``) with ``gearfem run``'s pipeline: the structural
cycle of a steel body (206 GPa, no hysteresis) against a POM one, the friction heat split between
them so that their contact temperatures agree (``[sources] heat_partition =
"contact_temperature"``; beside it the split by the thermal effusivities alone, Blok's for two
bodies that enter the contact at one temperature), each gear's own thermal model and emissivity,
and the IR camera that sees both. Prints the two gears side by side under both splits, the heat
balance of the pair (the two gears' friction heat against the cycle's friction power) and VDI
2736's flank and root temperature of the POM wheel (plastic/steel k_theta) against gearfem's.

Parameters (command-line options, defaults in brackets):
    --case FILE    the case [demos/steel_pom.toml]
    --out DIR      output directory [results/demos/steel_pom]
    --docs PAGE    also write the table into block ``steel_pom_demo`` of PAGE (docs/materials.md)

Outputs (DIR): everything ``gearfem run`` writes (summary.json last, cycle/, thermal/ of the POM
wheel, thermal_pinion/ of the steel pinion, instruments/ with the thermograms); the run with the
effusivities' split in DIR/effusivity_split.

Run:
    python demos/steel_pom.py
    mpirun -n 2 python demos/steel_pom.py --docs docs/materials.md
"""

# %% [markdown]
# # A steel pinion against a POM wheel, step by step
#
# A steel gear is an elastic body of the meshing cycle without hysteresis ($H \equiv 0$): it
# deflects about 70 times less than the POM and makes no heat of its own. The contact penalty of
# both passes comes from the softer body's modulus (docs/contact.md). The flank friction heat
# $\mu p v_s$ is generated at the contact and flows into the two bodies in proportion to their
# effusivities $b = \sqrt{k \rho c_p}$ (Blok) when both enter the contact at one temperature:
# steel's $b$ is 16 times POM's, so the steel would take about 94 %. But the steel, taking most of
# the heat with an adiabatic bore, runs hotter than the POM, and the two surfaces touching at the
# contact have one temperature: the split that makes the gears' contact temperatures (flank +
# flash) agree gives the POM more. Each gear has its own thermal model with its own conductivity
# and emissivity.

# %%
from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

from mpi4py import MPI

import gearfem  # noqa: F401  (must precede dolfinx/petsc4py)
from gearfem import pipeline
from gearfem.baselines import is_metal
from gearfem.config import load_case
from gearfem.core.doctables import markdown_table, replace_block
from gearfem.uncertainty import provenance

ROOT = Path(__file__).resolve().parent.parent
CASE = ROOT / "demos" / "steel_pom.toml"


@dataclasses.dataclass(frozen=True)
class GearReading:
    """One gear of the pair at the end of the run: heat in (W, the whole gear) and temperatures."""

    material: str
    share: float
    friction_W: float
    hysteresis_W: float
    mean_bulk_C: float
    max_surface_C: float
    steady_max_surface_C: float | None


def gear_reading(thermal: dict, material: str) -> GearReading:
    """The :class:`GearReading` of one gear's thermal summary (the model's fraction scaled up)."""
    frac = thermal["model_fraction"]
    bal, final = thermal["final_balance_W"], thermal["final_temperatures_C"]
    return GearReading(
        material,
        thermal["friction_heat_fraction"],
        bal["friction_W"] / frac,
        bal["hysteresis_W"] / frac,
        final["mean_bulk"],
        final["max_surface"],
        thermal.get("steady_state_C", {}).get("max_surface"),
    )


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--case", default=str(CASE))
    p.add_argument("--out", default="results/demos/steel_pom")
    p.add_argument("--docs", default=None, help="write block steel_pom_demo into this page")
    args = p.parse_args(argv)
    comm = MPI.COMM_WORLD

    # %% [markdown]
    # ## 1. The case: two materials from the library
    #
    # ``[material] name = "steel"`` and ``[material_wheel] name = "POM"`` take the library's
    # constants, each with its source (docs/materials.md); the POM's H(T) is the case file's.

    # %%
    case = load_case(args.case)
    mats = case.materials
    effusivity = dataclasses.replace(
        case, sources=dataclasses.replace(case.sources, heat_partition="fixed")
    )

    # %% [markdown]
    # ## 2. The runs: cycle, both thermal models, instruments
    #
    # ``pipeline.run`` is what ``gearfem run`` does: the cycle (cached by its inputs), the thermal
    # model of ``[thermal] body`` (the POM wheel) and of the other gear (the camera sees both),
    # the instruments, ``summary.json`` last. With ``heat_partition = "contact_temperature"`` it
    # runs both gears' thermal models again until the pinion's share of the friction heat makes
    # the gears' heat-weighted contact temperatures agree (a few runs); the run with the
    # effusivities' split shares the cycle.

    # %%
    runs = {
        "contact temperatures": pipeline.run(case, args.out, comm, progress=False),
        "effusivities": pipeline.run(
            effusivity, Path(args.out) / "effusivity_split", comm, progress=False
        ),
    }
    summary = runs["contact temperatures"]

    # %% [markdown]
    # ## 3. The two gears side by side, and the heat balance of the pair
    #
    # The friction heat the two thermal models take in adds up to the cycle's friction power at
    # this speed, under either split.

    # %%
    other = "pinion" if case.thermal.body == "wheel" else "wheel"
    gears = {
        (split, body): gear_reading(
            run.thermal if body == case.thermal.body else run.thermal_other, mats[body].name
        )
        for split, run in runs.items()
        for body in (case.thermal.body, other)
    }
    friction_total = sum(
        g.friction_W for (split, _), g in gears.items() if split == "contact temperatures"
    )
    balance = friction_total / summary.cycle.friction_power_W - 1.0
    h = summary.headline
    rows = [
        (
            split,
            body,
            g.material,
            f"{g.share:.3f}",
            f"{g.friction_W:.2f}",
            f"{g.hysteresis_W:.3f}",
            f"{g.mean_bulk_C:.1f}",
            f"{g.max_surface_C:.1f}",
            f"{g.steady_max_surface_C:.1f}" if g.steady_max_surface_C is not None else "",
        )
        for (split, body), g in sorted(gears.items())
    ]
    table = markdown_table(
        (
            "heat split by",
            "gear",
            "material",
            "share of the friction heat",
            "friction heat (W)",
            "hysteresis heat (W)",
            f"bulk at {h.time_s:g} s (C)",
            f"max surface at {h.time_s:g} s (C)",
            "steady max surface (C)",
        ),
        rows,
    )
    split = summary.heat_split
    searched = "; ".join(f"{p.fraction_pinion:.3f}: {p.difference_K:+.1f} K" for p in split.passes)
    polymer = next(b for b in ("wheel", "pinion") if not is_metal(mats[b]))
    gear = {"pinion": 1, "wheel": 2}[polymer]
    vdi = {part: summary.baselines[f"vdi2736_{part}{gear}_C"] for part in ("flank", "root")}
    hot = gears[("contact temperatures", polymer)]
    point = (
        f"{case.name}: {case.operating.speed_rpm:g} rpm, {case.operating.torque_Nm:g} N m, "
        f"mu {case.contact.friction_coefficient:g}, ambient {case.thermal.ambient_C:g} C."
    )
    text = (
        f"{table}\n\n{point} The split by contact temperatures took {len(split.passes)} runs "
        f"of both gears (the pinion's share: the heat-weighted contact temperatures' difference "
        f"at {h.time_s:g} s; {searched}). The two "
        f"gears' friction heat, {friction_total:.3f} W, against the cycle's friction power "
        f"{summary.cycle.friction_power_W:.3f} W: {balance:+.1e}. Effective contact ratio "
        f"{summary.cycle.effective_contact_ratio:.3f} (rigid teeth "
        f"{summary.cycle.theoretical_contact_ratio:.3f}). VDI 2736 (k_theta "
        f"{summary.baselines['vdi2736_k_theta_flank']:g} / "
        f"{summary.baselines['vdi2736_k_theta_root']:g}) for the {mats[polymer].name} {polymer}: "
        f"flank {vdi['flank']:.1f} C, root {vdi['root']:.1f} C, against gearfem's steady max "
        f"surface {hot.steady_max_surface_C:.1f} C and bulk {hot.mean_bulk_C:.1f} C "
        f"at {h.time_s:g} s (split by contact temperatures). IR camera (both gears, emissivity "
        f"setting {case.instruments.camera.emissivity_setting:g}): camera_max "
        f"{h.camera_max_C:.1f} C (effusivities' split: "
        f"{runs['effusivities'].headline.camera_max_C:.1f} C). "
        f"Written by `mpirun -n {comm.size} python demos/steel_pom.py --docs "
        f"{args.docs or 'docs/materials.md'}`."
    )
    if comm.rank == 0:
        print(text)

    # %% [markdown]
    # ## 4. Into the documentation (``--docs``)

    # %%
    if args.docs and comm.rank == 0:
        replace_block(ROOT / args.docs, "steel_pom_demo", text, provenance(case))
    comm.barrier()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
