"""Every polymer of the materials library runs the chain (issue 45): a case file naming it runs the
structural cycle and both gears' steady thermal models on a small mesh, and what depends on the
material follows it. The teeth's bending and shear make most of the transmission error and
scale as 1/E (linear elasticity; the contact penalty is proportional to E, ``[contact]
penalty_factor``); the contact itself does not scale (the gaps between the undeformed flanks do
not), so the ratio of transmission errors sits a little below the ratio of moduli (measured: POM
-0.9 %, PA66 -0.9 % from E_PEEK / E; the Poisson ratios, 0.35 and 0.39 against 0.40, barely
matter). For the same reason the friction power at one torque and mu rises with the compliance:
softer teeth share the load over a longer path of contact, further into the fast sliding near
the tips (measured: PA66 +4.1 %, POM +5.2 %). A steel pinion against a POM wheel runs the cycle
as a body without hysteresis. One rank (the serial tier); slow tests: three cycles of 6 positions
and two of 3, with their thermal runs (about 90 s).
"""

from __future__ import annotations

import dataclasses
import itertools
import sys
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

import gearfem  # noqa: F401
from gearfem import pipeline
from gearfem.config import case_from_dict
from gearfem.core.errors import ParameterError
from gearfem.core.material_library import library_material, library_names
from gearfem.cycle.options import CycleOptions
from gearfem.thermal.options import ThermalOptions

sys.path.insert(0, str(Path(__file__).parent))
from test_cycle import TINY  # the cycle tests' small pair mesh

#: A loss fraction H(T) for a polymer the library has none for: test input, not data.
TEST_HYSTERESIS = [[20.0, 150.0], [0.01, 0.05]]
POLYMERS = tuple(n for n in library_names() if library_material(n).kind == "polymer")


#: Positions per pitch of the library test: the longer path of contact of the softer teeth shows
#: in the friction power only with positions near the tips (measured: PA66 +4.1 %, POM +5.2 % at 6
#: positions; +0.5 % and +0.6 % at 3).
POSITIONS = 6
#: Positions per pitch of the steel/POM tests: the ratio of transmission errors and the heat split
#: do not depend on the sampling of the path of contact.
STEEL_POSITIONS = 3


def _case(name: str, positions: int = POSITIONS):
    table = {"name": name}
    if "hysteresis" not in library_material(name).tables:
        table["hysteresis"] = TEST_HYSTERESIS
    case = case_from_dict({"name": f"small {name} pair", "material": table})
    return dataclasses.replace(
        case,
        mesh=TINY,
        cycle=CycleOptions(positions_per_pitch=positions, check_periodicity=False),
        thermal=ThermalOptions(mode="steady", degree=1, output_times_s=()),
        instruments=dataclasses.replace(
            case.instruments, camera=dataclasses.replace(case.instruments.camera, enabled=False)
        ),
    )


@pytest.mark.slow
def test_every_library_polymer_runs_a_coarse_chain(tmp_path_factory):
    assert set(POLYMERS) == {"PEEK 450G", "POM", "PA66"}
    comm = MPI.COMM_SELF
    got = {}
    for name in POLYMERS:
        case = _case(name)
        mat = case.material
        assert mat.name == name and mat.youngs_modulus_Pa == library_material(name).value(
            "youngs_modulus_Pa"
        )
        cyc, _, _ = pipeline.cycle(case, comm)
        out = Path(tmp_path_factory.mktemp(name.replace(" ", "_")))
        main, _, _ = pipeline.observed_thermal(case, out, comm, cyc, write_fields=False)
        steady = main["final_temperatures_C"]  # the steady state (mode "steady")
        got[name] = (mat, cyc, steady)
        ambient_C = case.thermal.ambient_C
        assert steady["mean_bulk"] > ambient_C, name
        assert steady["max_surface"] > steady["mean_bulk"], name
    peek_mat, peek_cyc, _ = got["PEEK 450G"]

    for name in POLYMERS:
        mat, cyc, _ = got[name]
        te = float(np.mean(cyc.te_m)) / float(np.mean(peek_cyc.te_m))
        assert te == pytest.approx(peek_mat.youngs_modulus_Pa / mat.youngs_modulus_Pa, rel=0.03), (
            name
        )
    # softer teeth mesh over a longer path of contact, into the sliding near the tips
    by_E = sorted(POLYMERS, key=lambda n: -got[n][0].youngs_modulus_Pa)
    pf = [float(np.mean(got[n][1].friction_power_W_per_rad_s)) for n in by_E]
    assert all(b > a for a, b in itertools.pairwise(pf)), dict(zip(by_E, pf))
    assert pf[-1] < 1.15 * pf[0]


@pytest.mark.slow
def test_a_steel_pinion_against_a_pom_wheel_runs_the_cycle():
    """A steel gear is an elastic body without hysteresis: the cycle of a steel pinion against a
    POM wheel passes its own revolution-average check (which the slave's own modulus in the
    penalty failed: 1.96 of the mesh's friction power on the steel pinion's reference tooth), and
    its transmission error follows the bodies' compliances: with teeth that bend as 1/E, steel
    against POM gives (1/E_steel + 1/E_POM) / (2/E_POM) of POM against POM (0.507), a little less
    for the contact that does not scale (measured 0.467 at 3 positions per pitch, 0.477 at 6).
    The friction heat splits by effusivity, about 0.94 into the steel (the heat
    itself and its balance: tests/test_demos.py, the steel/POM demo)."""
    comm = MPI.COMM_SELF
    pom = {"name": "POM", "hysteresis": TEST_HYSTERESIS}
    cases = {}
    for label, pinion in (("steel/POM", {"name": "steel"}), ("POM/POM", pom)):
        case = case_from_dict({"name": label, "material": pinion, "material_wheel": pom})
        cases[label] = dataclasses.replace(
            _case("POM", STEEL_POSITIONS),
            name=label,
            material=case.material,
            material_wheel=case.material_wheel,
        )
    steel = cases["steel/POM"].material
    assert steel.name == "steel" and steel.glass_transition_C is None
    assert steel.hysteresis_table()(400.0) == 0.0
    te = {}
    for label, case in cases.items():
        cyc, _, _ = pipeline.cycle(case, comm)
        te[label] = float(np.mean(cyc.te_m))
    E_steel, E_pom = steel.youngs_modulus_Pa, cases["POM/POM"].material.youngs_modulus_Pa
    bending = (1 / E_steel + 1 / E_pom) / (2 / E_pom)
    assert 0.9 * bending < te["steel/POM"] / te["POM/POM"] < bending, te

    case = cases["steel/POM"]
    fractions = case.sources.heat_fractions(case.materials)
    b_steel = library_material("steel").effusivity_W_s05_m2K
    b_pom = library_material("POM").effusivity_W_s05_m2K
    assert fractions["pinion"] == pytest.approx(b_steel / (b_steel + b_pom), rel=1e-12)
    assert 0.9 < fractions["pinion"] < 0.97


@pytest.mark.slow
def test_the_heat_split_by_contact_temperature_equates_the_gears_contact_temperatures(
    tmp_path_factory,
):
    """``[sources] heat_partition = "contact_temperature"`` on the steel/POM pair: at the
    effusivities' split the steel pinion takes about 0.94 of the friction heat and its contact
    temperature (flank + flash, heat-weighted) is the higher; the split that equates them gives
    the steel less; both gears' friction heat still adds up to the cycle's friction power, each its
    share of it."""
    comm = MPI.COMM_SELF
    pom = {"name": "POM", "hysteresis": TEST_HYSTERESIS}
    steel = case_from_dict({"material": {"name": "steel"}, "material_wheel": pom})
    case = dataclasses.replace(
        _case("POM", STEEL_POSITIONS),
        name="steel/POM",
        material=steel.material,
        material_wheel=steel.material_wheel,
    )
    case = dataclasses.replace(
        case, sources=dataclasses.replace(case.sources, heat_partition="contact_temperature")
    )
    effusivity_share = case.sources.heat_fractions(case.materials)["pinion"]
    cyc, _, _ = pipeline.cycle(case, comm)
    out = Path(tmp_path_factory.mktemp("split"))
    # one gear's thermal run cannot solve a split over both gears: it says where it is solved
    with pytest.raises(ParameterError, match=r"sources\.heat_partition.*gearfem run"):
        pipeline.thermal(case, out / "one_gear", comm, cyc, write_fields=False)
    main, others, _ = pipeline.observed_thermal(case, out, comm, cyc, write_fields=False)
    split = pipeline.HeatSplit.from_json(main["heat_split"])
    first, last = split.passes[0], split.passes[-1]
    assert first.fraction_pinion == pytest.approx(effusivity_share, rel=1e-12)
    assert first.difference_K > 10.0 * split.tolerance_K  # the steel runs hotter at contact
    assert abs(last.difference_K) < split.tolerance_K and len(split.passes) >= 2
    assert 0.0 < last.fraction_pinion < effusivity_share
    # the friction heat of both gears is the cycle's friction power, each gear its share
    omega = 2.0 * np.pi * case.operating.speed_rpm / 60.0
    power = float(np.mean(cyc.friction_power_W_per_rad_s)) * omega
    heat = {main["body"]: main, **others}
    share = {"pinion": last.fraction_pinion, "wheel": 1.0 - last.fraction_pinion}
    for body, summ in heat.items():
        assert summ["friction_heat_fraction"] == pytest.approx(share[body], rel=1e-12)
        whole_gear = summ["friction"]["friction_W_model"] / summ["model_fraction"]
        assert whole_gear == pytest.approx(share[body] * power, rel=1e-6), body
