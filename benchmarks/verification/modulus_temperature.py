"""What a modulus that follows temperature changes: the built-in case's cycle with each gear's
modulus taken from its steady thermal state, cell by cell and as one uniform value per gear, each
iterated with the heat, beside the constant modulus.

The structural cycle runs at the material's constant ``youngs_modulus_Pa`` (PEEK 450G: 3.7 GPa),
while the teeth run far above room temperature. The library's E(T) of PEEK 450G (tensile,
Drozdov & Christiansen 2021, ``gearfem/data/materials/peek450g.toml``) is flat to 130 C and falls
to 1.7 GPa at 180 C, where the table ends. Two ways of giving the cycle that modulus:

* **cell by cell** (:mod:`gearfem.cycle.modulus_field`): every structural cell takes
  E_c = E e(T_c), e the table relative to its first value, T_c the gear's steady temperature
  at the cell (the thermal model's cell nearest its place on the reference tooth);
* **uniform per gear**: the modulus of the teeth's volume-mean compliance at the steady state,
  1/E_eff = (1/V) sum_c V_c / E(T_c), the sum over the cells of the modelled tooth above the
  root circle, T_c the cell's mean nodal temperature (the first-order estimate).

Beyond the table's last temperature its last value is used in both, which overestimates the
modulus where the teeth run hotter (PEEK softens further above T_g); the share of the tooth
volume beyond the table is reported. Each pass after the first (the constant modulus) solves the
cycle with the modulus of the previous pass's thermal state, until E_eff moves by less than
``--tolerance`` (uniform) or no cell's modulus moves by ``--cell-tolerance`` or more (cell by
cell, the measure of ``[cycle] modulus = "thermal_state"``). Reported per bench point: the
moduli, the load sharing, the pitch and largest pressures, the transmission error, the friction
heat, the hottest surface and the IR camera's steady reading, with u_num of the case's
resolution where its refinement studies give one, and the cell-by-cell readings per pass
(docs/materials.md, block ``modulus_temperature``).

    mpirun -n 2 python benchmarks/verification/modulus_temperature.py [--points 1000/8 2000/4] \
        [--tolerance 0.02] [--cell-tolerance 0.05] [--max-passes 5] [--docs docs/materials.md]
"""

from __future__ import annotations

import argparse
import dataclasses

import numpy as np
from mpi4py import MPI
from one_case import CycleLoads, observed_fields, scratch_directory, steady_case

import gearfem  # noqa: F401  (must precede dolfinx/petsc4py)
from gearfem import pipeline
from gearfem.config import Case, load_case
from gearfem.core.doctables import markdown_table, replace_block
from gearfem.core.log import setup_logging
from gearfem.cycle.modulus_field import ModulusField
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


@dataclasses.dataclass(frozen=True)
class Pass:
    """One pass: the quantities of its cycle and steady state, each gear's uniform tooth modulus
    at that state, the cell-wise field of that state, and the moduli its cycle ran with (GPa,
    pinion / wheel: uniform, or the tooth's harmonic mean at the state its field came from)."""

    quantities: dict
    tooth: dict[str, ToothModulus]
    field: ModulusField
    used_GPa: tuple[float, float]


def one_pass(
    case: Case,
    comm,
    tables: dict,
    moduli: ModulusField | None = None,
    source: dict[str, ToothModulus] | None = None,
) -> Pass:
    """The cycle (with the modulus field ``moduli`` when given, of the state whose tooth moduli
    are ``source``) and the steady state of ``case``: :func:`read_pass` (collective)."""
    cyc, _, _ = pipeline.cycle(case, comm, moduli=moduli)
    snap = observed_fields(steady_case(case), comm, cyc)
    return read_pass(case, comm, tables, cyc, snap, source)


def read_pass(
    case: Case,
    comm,
    tables: dict,
    cyc,
    snap,
    source: dict[str, ToothModulus] | None = None,
) -> Pass:
    """The quantities of the cycle ``cyc`` and the steady fields' snapshot ``snap`` (rank 0) of
    ``case``, each gear's tooth modulus and the modulus field at that state (collective; the cycle
    ran with the modulus of the state whose tooth moduli are ``source``, else the constant one).
    ``tables``: the E(T) of each gear whose modulus follows temperature
    (:func:`gearfem.pipeline.modulus_tables`; a steel gear keeps its constant modulus)."""
    loads = CycleLoads.of(cyc, case.operating.speed_rpm)
    c = steady_case(case)
    # the modulus the cycle ran with: uniform, or the tooth's harmonic mean of the field's state
    used = tuple(
        (source[b].modulus_Pa if source is not None else case.materials[b].youngs_modulus_Pa) / GPA
        for b in BODIES
    )

    def read():
        label = snap.label_of(None)
        i = snap.label_index(label)
        pair = GearPair(case.geometry)
        tooth = {
            b: tooth_modulus(
                snap.bodies[b],
                i,
                pair.profile(b).root_radius_m,
                tables[b],
                case.materials[b].glass_transition_C,
            )
            if b in tables
            else ToothModulus(case.materials[b].youngs_modulus_Pa, 0.0, 0.0)
            for b in BODIES
        }
        q = {
            "modulus, pinion / wheel (GPa)": used,
            "effective contact ratio": loads.effective_contact_ratio,
            "largest tooth-pair load (N)": loads.largest_load_N,
            "pitch-point pressure, band (MPa)": loads.pitch_point_band_pressure_MPa,
            "largest pressure (MPa)": loads.largest_pressure_MPa,
            "transmission error, mean (um)": loads.te_mean_um,
            "friction heat of the pair, steady (W)": snap.mesh_heat_W(label)[0],
            "hottest surface, steady (C)": max(
                snap.bodies[b].temperatures_C[label]["max_surface"] for b in BODIES
            ),
            "hottest surface, pinion / wheel, steady (C)": tuple(
                snap.bodies[b].temperatures_C[label]["max_surface"] for b in BODIES
            ),
            "bulk mean, pinion / wheel, steady (C)": tuple(
                snap.bodies[b].temperatures_C[label]["mean_bulk"] for b in BODIES
            ),
            "camera_max, steady (C)": evaluate(c.instruments, snap, only=("camera",))
            .camera[label]
            .max_C,
        }
        field = pipeline.state_modulus_field(snap, tables)
        return Pass(q, tooth, field, used)

    return pipeline.on_root(comm, read)


def uniform_fixed_point(base: Case, first: Pass, comm, tables, tolerance: float, max_passes: int):
    """The passes with each gear's uniform E_eff of the previous pass, after the constant
    modulus's ``first``, until E_eff moves by less than ``tolerance`` (relative)."""
    passes = [first]
    while len(passes) < max_passes:
        new = {b: passes[-1].tooth[b].modulus_Pa for b in BODIES}
        passes.append(one_pass(with_moduli(base, new), comm, tables))
        now = {b: passes[-1].tooth[b].modulus_Pa for b in BODIES}
        if all(abs(now[b] / new[b] - 1) < tolerance for b in BODIES):
            return passes, True
    return passes, False


def cellwise_fixed_point(base: Case, comm, tables: dict, tolerance: float, max_passes: int):
    """``[cycle] modulus = "thermal_state"`` on ``base`` at its steady state: the fixed point of
    :func:`gearfem.pipeline.thermal_stages` (the constant modulus's pass first, then the cell-wise
    field of the previous pass's state, until no cell's relative modulus moves by ``tolerance`` or
    more; ConvergenceError after ``max_passes``), each pass read by :func:`read_pass` with the
    gears' E(T) ``tables``; the largest change of a cell's modulus per pass after the first
    (collective)."""
    case = steady_case(base)
    case = dataclasses.replace(
        case,
        cycle=dataclasses.replace(
            case.cycle,
            modulus="thermal_state",
            modulus_tolerance=tolerance,
            modulus_max_passes=max_passes,
        ),
    )
    passes: list[Pass] = []

    def read(k, case_k, stages, _):
        source = passes[-1].tooth if passes else None
        passes.append(read_pass(case_k, comm, tables, stages.cycle, stages.snapshot, source))

    with scratch_directory(comm) as out:
        stages = pipeline.thermal_stages(
            case, out, comm, progress=False, write_fields=False, write_plot=False, on_pass=read
        )
    return passes, [p.change_max for p in stages.modulus.passes[1:]]


def _cell(v) -> str:
    if isinstance(v, tuple):
        return " / ".join(f"{x:.3g}" for x in v)
    return f"{v:.4g}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", nargs="+", default=["1000/8", "2000/4"], help="SPEED/TORQUE")
    ap.add_argument("--tolerance", type=float, default=0.02)
    ap.add_argument("--cell-tolerance", type=float, default=0.05)
    ap.add_argument("--max-passes", type=int, default=5)
    ap.add_argument("--case", default=None, help="case file (default: the built-in case)")
    ap.add_argument(
        "--block",
        default="modulus_temperature",
        choices=(
            "modulus_temperature",
            "modulus_temperature_steel_pom",
            "modulus_temperature_steel_pa66",
        ),
        help="block of --docs to write (the built-in case's, the steel/POM, steel/PA66 pairs')",
    )
    ap.add_argument("--docs", default=None)
    a = ap.parse_args()
    setup_logging("WARNING")
    comm = MPI.COMM_WORLD
    builtin = load_case(a.case)
    tables = pipeline.modulus_tables(builtin)
    parts = []
    for point in a.points:
        speed, torque = (float(s) for s in point.split("/"))
        base = builtin.with_operating(speed_rpm=speed, torque_Nm=torque)
        cell, cell_changes = cellwise_fixed_point(
            base, comm, tables, a.cell_tolerance, a.max_passes
        )
        first = cell[0]  # the constant modulus's pass, which both fixed points start from
        uni, uni_settled = uniform_fixed_point(base, first, comm, tables, a.tolerance, a.max_passes)
        q0, qu, qc = first.quantities, uni[-1].quantities, cell[-1].quantities
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
        unc = run_uncertainty(base, {k: q0[q] for q, k in keys.items()})
        if unc is not None:
            u = {q: unc.u_num(k) for q, k in keys.items()}
        diff = lambda x, y: "" if isinstance(x, tuple) else f"{y - x:+.3g}"
        rows = [
            (
                q,
                _cell(q0[q]),
                _cell(qu[q]),
                _cell(qc[q]),
                diff(q0[q], qc[q]),
                f"{u[q]:.2g}" if u.get(q) is not None else "",
            )
            for q in q0
        ]
        m0 = first.tooth
        rows.append(
            (
                "tooth volume above T_g / beyond the E(T) table, constant-modulus state (%)",
                " / ".join(
                    f"{100 * m0[b].above_glass_transition:.0f}, {100 * m0[b].beyond_table:.0f}"
                    if b in tables
                    else "–"
                    for b in BODIES
                ),
                "",
                "",
                "",
                "",
            )
        )
        steps = lambda passes: " -> ".join(
            "(" + ", ".join(f"{x:.3g}" for x in p.used_GPa) + ")" for p in passes
        )
        trace = lambda passes, q: " -> ".join(f"{p.quantities[q]:.4g}" for p in passes)
        head = (
            f"**{speed:g} rpm / {torque:g} N m**: uniform E_eff {len(uni)} passes, "
            f"{'settled' if uni_settled else 'not settled'}; cell by cell {len(cell)} passes, "
            "settled, the largest change of a cell's "
            "modulus between a pass's field and its state's "
            + " -> ".join(f"{100 * x:.1f} %" for x in cell_changes)
            + f". Pinion, wheel in GPa, each pass's cycle: uniform {steps(uni)}; cell by cell, "
            f"the tooth's harmonic mean, {steps(cell)}. Cell by cell, per pass: hottest surface "
            f"{trace(cell, 'hottest surface, steady (C)')} C, camera "
            f"{trace(cell, 'camera_max, steady (C)')} C, TE "
            f"{trace(cell, 'transmission error, mean (um)')} um"
        )
        table_md = markdown_table(
            ("quantity", "constant modulus", "uniform E_eff of the thermal state",
             "E(T) cell by cell", "difference, cell by cell", "u_num at the case"),
            rows,
        )  # fmt: skip
        parts.append(head + "\n\n" + table_md)
    if a.case is not None:
        mats = builtin.materials
        last = {b: f"{t.T_K[-1] - 273.15:.0f} C" for b, t in tables.items()}
        note = (
            f"\n\nCase '{builtin.name}' ({a.case}; {mats['pinion'].name} pinion, "
            f"{mats['wheel'].name} wheel), the steady state at each point; the columns as "
            "above. The moduli from the library's E(T) of "
            + ", ".join(
                f"the {b}'s {mats[b].name} (its last value beyond {last[b]})" for b in tables
            )
            + "; a steel gear keeps its modulus. No refinement study of this resolution: no "
            f"u_num. `mpirun -n {comm.size} python benchmarks/verification/modulus_temperature.py "
            f"--case {a.case} --points {' '.join(a.points)} --block {a.block}`."
        )
    else:
        note = _builtin_note(comm, a.points)
    text = "\n\n".join(parts) + note
    if comm.rank == 0:
        print(text)
        if a.docs:
            replace_block(a.docs, a.block, text, provenance(builtin))


def _builtin_note(comm, points) -> str:
    return (
        "\n\nThe built-in case (PEEK 450G, constant mu 0.5), each bench point's steady state; "
        "the second and third columns the last pass of each fixed point, whose cycle ran with "
        "the modulus of the pass before: each gear's E_eff (the harmonic volume mean of the "
        "library's E(T) over the modelled tooth) or each cell's E(T_c) "
        "(gearfem.cycle.modulus_field); beyond 180 C the table's last value, 1.7 GPa, which "
        "overestimates the modulus there. u_num "
        "from the refinement studies of the case's resolution (at 1000 rpm / 8 N m). `mpirun -n "
        f"{comm.size} python benchmarks/verification/modulus_temperature.py "
        f"--points {' '.join(points)}`."
    )


if __name__ == "__main__":
    main()
