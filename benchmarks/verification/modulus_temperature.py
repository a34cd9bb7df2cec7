"""What a modulus that follows temperature would change, to first order: the built-in case's cycle
with each gear's uniform modulus taken from its steady thermal state, iterated with the heat, beside
the constant modulus.

The structural cycle runs at the material's constant ``youngs_modulus_Pa`` (PEEK 450G: 3.7 GPa),
while the teeth run far above room temperature. The library's E(T) of PEEK 450G (tensile,
Drozdov & Christiansen 2021, ``gearfem/data/materials/peek450g.toml``) is flat to 130 C and falls
to 1.7 GPa at 180 C, where the table ends. Cell-wise E(T) is not in the cycle; this script
measures what a uniform modulus per gear does, the one with the teeth's volume-mean compliance at
the steady state:

    1/E_eff = (1/V) sum_c V_c / E(T_c),

the sum over the cells of the modelled tooth above the root circle, T_c the cell's mean nodal
temperature of the steady state (the gear's own thermal model). Beyond the table's last
temperature the last value is used, so E_eff overestimates the modulus where the teeth run
hotter (PEEK softens further above T_g); the share of the tooth volume beyond the table is
reported. Each pass solves the cycle with both gears' E_eff of the
previous pass's thermal state, until E_eff moves by less than ``--tolerance`` (relative); the first
pass is the constant modulus. Reported per bench point: the moduli, the load sharing, the pitch
and largest pressures, the transmission error, the friction heat, the hottest surface and the IR
camera's steady reading, with u_num of the case's resolution where its refinement studies give
one (docs/materials.md, block ``modulus_temperature``).

    mpirun -n 2 python benchmarks/verification/modulus_temperature.py [--points 1000/8 2000/4] \
        [--tolerance 0.02] [--max-passes 3] [--docs docs/materials.md]
"""

from __future__ import annotations

import argparse
import dataclasses

import numpy as np
from mpi4py import MPI
from one_case import CycleLoads, observed_fields, steady_case

import gearfem  # noqa: F401  (must precede dolfinx/petsc4py)
from gearfem import pipeline
from gearfem.config import Case, load_case
from gearfem.core.doctables import markdown_table, replace_block
from gearfem.core.log import setup_logging
from gearfem.core.material_library import library_material
from gearfem.geometry.involute import GearPair
from gearfem.instruments.evaluate import evaluate
from gearfem.instruments.snapshot import BodyField
from gearfem.uncertainty import provenance, run_uncertainty

GPA = 1e9
BODIES = ("pinion", "wheel")


@dataclasses.dataclass(frozen=True)
class ToothModulus:
    """One gear's effective modulus at a thermal state, and how much of its tooth the table
    covers."""

    modulus_Pa: float
    above_glass_transition: float  # share of the tooth volume above T_g
    beyond_table: float  # share above the table's last temperature (its last value used)


def tooth_modulus(
    field: BodyField, label: int, root_radius_m: float, table, glass_transition_C: float
) -> ToothModulus:
    """E_eff of one gear: the harmonic volume mean of E(T) over its modelled tooth (the cells whose
    centroid lies outside the root circle) at the snapshot's ``label``."""
    x = field.nodes_m[field.cells[:, :4]]  # (c, 4, 3) vertices
    vol = np.abs(np.einsum("ij,ij->i", np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]),
                           x[:, 3] - x[:, 0])) / 6.0  # fmt: skip
    centroid = x.mean(axis=1) - field.center_m
    tooth = np.hypot(centroid[:, 0], centroid[:, 1]) > root_radius_m
    T_K = field.temperature_K[label][field.cells].mean(axis=1)
    v, t = vol[tooth], T_K[tooth]
    share = lambda mask: float(v[mask].sum() / v.sum())
    return ToothModulus(
        modulus_Pa=float(v.sum() / np.sum(v / table(t))),
        above_glass_transition=share(t > glass_transition_C + 273.15),
        beyond_table=share(t > table.T_K[-1]),
    )


def with_moduli(case: Case, moduli: dict[str, float]) -> Case:
    """``case`` with each gear's modulus (Pa)."""
    mats = case.materials
    return dataclasses.replace(
        case,
        material=dataclasses.replace(mats["pinion"], youngs_modulus_Pa=moduli["pinion"]),
        material_wheel=dataclasses.replace(mats["wheel"], youngs_modulus_Pa=moduli["wheel"]),
    )


def one_pass(case: Case, comm, table) -> tuple[dict[str, float], dict[str, ToothModulus]]:
    """The cycle and the steady state of ``case``: its quantities and each gear's tooth modulus
    at that state (collective)."""
    cyc, _, _ = pipeline.cycle(case, comm)
    loads = CycleLoads.of(cyc, case.operating.speed_rpm)
    c = steady_case(case)
    snap = observed_fields(c, comm, cyc)

    def read():
        label = snap.label_of(None)
        i = snap.label_index(label)
        pair = GearPair(case.geometry)
        moduli = {
            b: tooth_modulus(
                snap.bodies[b],
                i,
                pair.profile(b).root_radius_m,
                table,
                case.materials[b].glass_transition_C,
            )
            for b in BODIES
        }
        q = {
            "modulus, pinion / wheel (GPa)": (
                case.materials["pinion"].youngs_modulus_Pa / GPA,
                case.materials["wheel"].youngs_modulus_Pa / GPA,
            ),
            "effective contact ratio": loads.effective_contact_ratio,
            "largest tooth-pair load (N)": loads.largest_load_N,
            "pitch-point pressure, band (MPa)": loads.pitch_point_band_pressure_MPa,
            "largest pressure (MPa)": loads.largest_pressure_MPa,
            "transmission error, mean (um)": loads.te_mean_um,
            "friction heat of the pair, steady (W)": snap.mesh_heat_W(label)[0],
            "hottest surface, steady (C)": max(
                snap.bodies[b].temperatures_C[label]["max_surface"] for b in BODIES
            ),
            "camera_max, steady (C)": evaluate(c.instruments, snap, only=("camera",))
            .camera[label]
            .max_C,
        }
        return q, moduli

    return pipeline.on_root(comm, read)


def fixed_point(base: Case, comm, table, tolerance: float, max_passes: int):
    """The passes at one operating point: the constant modulus first, then each gear's E_eff of
    the previous pass, until it moves by less than ``tolerance`` (relative)."""
    passes = []
    case = base
    for _ in range(max_passes):
        q, moduli = one_pass(case, comm, table)
        passes.append((q, moduli))
        used = {b: case.materials[b].youngs_modulus_Pa for b in BODIES}
        new = {b: moduli[b].modulus_Pa for b in BODIES}
        if len(passes) > 1 and all(abs(new[b] / used[b] - 1) < tolerance for b in BODIES):
            return passes, True
        case = with_moduli(base, new)
    return passes, False


def _cell(v) -> str:
    if isinstance(v, tuple):
        return " / ".join(f"{x:.3g}" for x in v)
    return f"{v:.4g}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", nargs="+", default=["1000/8", "2000/4"], help="SPEED/TORQUE")
    ap.add_argument("--tolerance", type=float, default=0.02)
    ap.add_argument("--max-passes", type=int, default=3)
    ap.add_argument("--docs", default=None)
    a = ap.parse_args()
    setup_logging("WARNING")
    comm = MPI.COMM_WORLD
    builtin = load_case(None)
    lib = library_material(builtin.material.name or "PEEK 450G")
    table = lib.tables["youngs_modulus_Pa"].table()
    parts = []
    for point in a.points:
        speed, torque = (float(s) for s in point.split("/"))
        base = builtin.with_operating(speed_rpm=speed, torque_Nm=torque)
        passes, settled = fixed_point(base, comm, table, a.tolerance, a.max_passes)
        first, last = passes[0][0], passes[-1][0]
        u = {}
        keys = {
            "effective contact ratio": "effective_contact_ratio",
            "pitch-point pressure, band (MPa)": "pitch_point_band_pressure_MPa",
            "largest pressure (MPa)": "max_contact_pressure_MPa",
            "transmission error, mean (um)": "transmission_error_mean_um",
            "friction heat of the pair, steady (W)": "friction_power_W",
            "hottest surface, steady (C)": "max_surface_field",
            "camera_max, steady (C)": "camera_max",
        }
        unc = run_uncertainty(base, {k: first[q] for q, k in keys.items()})
        if unc is not None:
            u = {q: unc.u_num(k) for q, k in keys.items()}
        rows = [
            (
                q,
                _cell(first[q]),
                _cell(last[q]),
                "" if isinstance(first[q], tuple) else f"{last[q] - first[q]:+.3g}",
                f"{u[q]:.2g}" if u.get(q) is not None else "",
            )
            for q in first
        ]
        m0 = passes[0][1]
        rows.append(
            (
                "tooth volume above T_g / beyond the E(T) table, constant-modulus state (%)",
                " / ".join(
                    f"{100 * m0[b].above_glass_transition:.0f}, {100 * m0[b].beyond_table:.0f}"
                    for b in BODIES
                ),
                "",
                "",
                "",
            )
        )
        moduli = " -> ".join(
            "(" + ", ".join(f"{m[b].modulus_Pa / GPA:.3g}" for b in BODIES) + ")" for _, m in passes
        )
        head = (
            f"**{speed:g} rpm / {torque:g} N m**: {len(passes)} passes, "
            f"{'settled' if settled else 'not settled'} (E_eff pinion, wheel in GPa at each "
            f"pass's steady state: {moduli})"
        )
        table_md = markdown_table(
            ("quantity", "constant modulus", "modulus of the thermal state", "difference",
             "u_num at the case"),
            rows,
        )  # fmt: skip
        parts.append(head + "\n\n" + table_md)
    note = (
        "\n\nThe built-in case (PEEK 450G, constant mu 0.5), each bench point's steady state; the "
        "second column the last pass, whose cycle ran with each gear's E_eff of the pass before "
        "(the harmonic volume mean of the library's E(T) over the modelled tooth; beyond 180 C "
        "the table's last value, 1.7 GPa, which overestimates the modulus there). u_num "
        "from the refinement studies of the case's resolution (at 1000 rpm / 8 N m). `mpirun -n "
        f"{comm.size} python benchmarks/verification/modulus_temperature.py "
        f"--points {' '.join(a.points)}`."
    )
    text = "\n\n".join(parts) + note
    if comm.rank == 0:
        print(text)
        if a.docs:
            replace_block(a.docs, "modulus_temperature", text, provenance(builtin))


if __name__ == "__main__":
    main()
