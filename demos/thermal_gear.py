"""Temperature of one polymer gear with prescribed heat sources, step by step.

The thermal model of gearfem on its own (no contact cycle): one gear of the thesis pair, a
fractional model of a few teeth with adiabatic cut faces, friction heat on the drive flanks and
hysteresis heat in the volume, convection and radiation on teeth and sides.

Parameters (command-line options, defaults in brackets):
    --speed-rpm N          pinion speed, rpm [1000]
    --flank-heat-W Q       friction heat into the whole gear, spread over the drive flanks, W [40]
    --u-max-J-m3 U         uniform maximum strain energy density for hysteresis, J/m^3 [2e4]
    --duration-s T         simulated time, s [600]
    --teeth N              teeth in the model [2]
    --size-mm H            element size on the teeth, mm [0.4]
    --out DIR              output directory [results/demos/thermal_gear]

Outputs (in DIR): thermal_history.csv, thermal_history.png, thermal_summary.json (written last),
temperature.bp/ (VTX field for ParaView).

Run:
    python demos/thermal_gear.py
    mpirun -n 2 python demos/thermal_gear.py --out results/demos/thermal_gear_np2
"""

# %% [markdown]
# # A gear's temperature, step by step
#
# Strong form solved by :class:`~gearfem.thermal.ThermalProblem` (temperature $T$ in kelvin):
#
# $$ \frac{\partial e(T)}{\partial t} = \nabla\cdot(k \nabla T) + H(T)\,U_{max}\,f
#    \quad\text{in the gear,} $$
# $$ -k \frac{\partial T}{\partial n} = h\,(T - T_\infty) + \varepsilon\sigma (T^4 - T_\infty^4)
#    - q_f \quad\text{on teeth and sides}, \qquad -k\frac{\partial T}{\partial n} = 0
#    \quad\text{on the bore and cut faces,} $$
#
# with $e(T) = \rho\int c_p\,dT$, the loss fraction $H(T)$ of PEEK, the loading frequency
# $f = n/60$, the friction flux $q_f$ on the drive flanks, and the thesis's convection
# correlations for the teeth and the sides (eq. 5.1-5.6), which depend on the speed.
#
# The steps: a mesh of one gear → :class:`~gearfem.thermal.ThermalDomain` (surface roles) →
# :class:`~gearfem.thermal.ThermalBoundary` (exchange coefficients) → heat sources →
# :class:`~gearfem.thermal.ThermalProblem` → integrate in time and write the outputs.

# %%
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import gearfem  # noqa: F401  (must precede dolfinx/petsc4py with the PyPI wheel)

# isort: split
from mpi4py import MPI

from gearfem.config import load_case
from gearfem.core.materials import ZERO_CELSIUS_K
from gearfem.geometry import MeshOptions, build_gear_mesh
from gearfem.thermal import (
    PrescribedSources,
    ThermalBoundary,
    ThermalDomain,
    ThermalOptions,
    ThermalProblem,
    prescribed_heat_sources,
)
from gearfem.thermal.lumped import gear_radii
from gearfem.thermal.outputs import solve_and_write


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--speed-rpm", type=float, default=1000.0, help="pinion speed, rpm")
    p.add_argument("--flank-heat-W", type=float, default=40.0, help="friction heat per gear, W")
    p.add_argument("--u-max-J-m3", type=float, default=2.0e4, help="U_max for hysteresis, J/m^3")
    p.add_argument("--duration-s", type=float, default=600.0, help="simulated time, s")
    p.add_argument("--teeth", type=int, default=2, help="teeth in the model")
    p.add_argument("--size-mm", type=float, default=0.4, help="element size on the teeth, mm")
    p.add_argument("--out", type=Path, default=Path("results/demos/thermal_gear"))
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    comm = MPI.COMM_WORLD

    # %% [markdown]
    # ## 1. Mesh of one gear
    # The thesis pair's geometry; only the pinion is meshed (``bodies=("pinion",)``), which
    # balances the mesh over the ranks. Curved P2 tetrahedra, named facet groups per tooth.

    # %%
    case = load_case(None)  # the built-in thesis case: geometry and PEEK 450G
    options = MeshOptions(
        teeth_in_model=args.teeth,
        layers=2,
        size_flank_mm=args.size_mm,
        size_tip_mm=args.size_mm,
        size_root_mm=args.size_mm,
        size_tooth_mm=2.0 * args.size_mm,
        size_body_mm=3.0,
    )
    gm = build_gear_mesh(case.geometry, options, comm, bodies=("pinion",))

    # %% [markdown]
    # ## 2. Domain and boundary
    # The domain sorts the facets into roles (teeth, sides, bore, cuts). The boundary model
    # evaluates the convection correlations at this speed with the gear's radii; emissivity from
    # the material, ambient 23 C.

    # %%
    domain = ThermalDomain.from_gear_mesh(gm, "pinion", flux_flanks="drive")
    material = case.material
    profile = gm.pair.profile("pinion")
    thermal = ThermalOptions(duration_s=args.duration_s, output_times_s=(args.duration_s,))
    boundary = ThermalBoundary.from_options(thermal, material, args.speed_rpm, gear_radii(profile))
    for role, ex in boundary.exchanges().items():
        if comm.rank == 0:
            h = ex.h(thermal.ambient_C + ZERO_CELSIUS_K)
            print(f"  {role:6s}: h = {float(h):7.2f} W/(m² K), emissivity {ex.emissivity:.2f}")

    # %% [markdown]
    # ## 3. Heat sources
    # Prescribed here: ``flank_heat_per_gear_W`` spread uniformly over the drive flanks (scaled
    # to the modelled sector), and a uniform $U_{max}$ whose hysteresis heat is
    # $H(T)\,U_{max}\,n/60$. The contact cycle provides both as fields in the full chain
    # (:func:`gearfem.coupling.heat_sources.cycle_heat_sources`).

    # %%
    prescribed = PrescribedSources(
        flank_heat_per_gear_W=args.flank_heat_W, flanks="drive", u_max_J_m3=args.u_max_J_m3
    )
    sources = prescribed_heat_sources(prescribed, domain, material, args.speed_rpm, profile.teeth)

    # %% [markdown]
    # ## 4. Solve and write
    # BDF2 with adaptive steps; every step's heat balance (generated = stored + convected +
    # radiated) is recorded. ``solve_and_write`` writes the history, a plot, the field and the
    # summary (last).

    # %%
    with ThermalProblem(
        domain, material, sources, boundary, thermal, petsc_options_prefix="demo_thermal_"
    ) as problem:
        records, _ = solve_and_write(problem, args.out)
    last = records[-1]
    if comm.rank == 0:
        b, T = last.balance, last.temperatures_K
        print(
            f"t = {last.time_s:g} s: max surface {T['max_surface'] - ZERO_CELSIUS_K:.1f} C, "
            f"mean bulk {T['mean_bulk'] - ZERO_CELSIUS_K:.1f} C; heat in the model "
            f"{b.generated_W:.3f} W, relative imbalance {b.relative_imbalance:.1e}"
        )
        print(f"wrote {args.out}/thermal_history.csv, thermal_history.png, thermal_summary.json")
    return 0


if __name__ == "__main__":
    sys.exit(main())
