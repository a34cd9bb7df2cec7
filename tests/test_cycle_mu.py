"""The structural cycle solved at the friction law's mu (``[friction] cycle_mu = "law"``, issue 44):
the cycle ↔ heat fixed point of :func:`gearfem.pipeline.thermal_stages`, and the glass
transition's T_g taken from the pair's polymer.

The fixed point is checked where its answer is known: a constant law of mu 0.3 on a cycle solved
at 0.5 dissipates 0.3/0.5 of the cycle's friction power (the law's heat is the cycle's contact
history at the law's mu), so the law's effective mu is 0.3 after one pass, and the second cycle,
solved at 0.3, is its fixed point: the run's readings are those of a run whose cycle is solved
at 0.3 outright. A loop allowed one pass raises ConvergenceError and leaves no summary.
"""

from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

import pytest
from mpi4py import MPI

from gearfem import pipeline
from gearfem.cli import cycle_mu_note
from gearfem.config import Case
from gearfem.contact.friction import FrictionOptions
from gearfem.core.errors import ConvergenceError, ParameterError
from gearfem.core.material_library import library_material
from gearfem.coupling.options import SourceOptions
from gearfem.cycle.options import CycleOptions
from gearfem.instruments.options import TorqueMeterOptions
from gearfem.instruments.torque import TorqueReading
from gearfem.thermal.options import ThermalOptions

sys.path.insert(0, str(Path(__file__).parent))
from test_cycle import TINY  # the cycle tests' small pair mesh


def _small_steady() -> Case:
    """The thesis pair on the small mesh of the cycle tests at 3 positions per pitch (what the
    couplings' tests check, their passes and fixed points, does not depend on sampling the path of
    contact finely), steady, without the camera (the torque meters read both gears)."""
    case = Case(mesh=TINY, cycle=CycleOptions(positions_per_pitch=3, check_periodicity=False))
    return dataclasses.replace(
        case,
        thermal=ThermalOptions(mode="steady", degree=1, output_times_s=()),
        instruments=dataclasses.replace(
            case.instruments, camera=dataclasses.replace(case.instruments.camera, enabled=False)
        ),
    )


def _out(comm: MPI.Comm, factory, name: str) -> Path:
    return Path(comm.bcast(str(factory.mktemp(name)) if comm.rank == 0 else None))


@pytest.mark.slow
@pytest.mark.parametrize("cycle_mu", ["law", "effective"])
def test_the_cycle_is_solved_again_at_the_laws_effective_mu(tmp_path_factory, cycle_mu):
    """A constant law: its mu per contact band is its one mu, so both couplings take the same
    two cycles (the second with the law's 0.3 at every contact) and read the same."""
    comm = MPI.COMM_WORLD
    base = _small_steady()
    law = dataclasses.replace(base, friction=FrictionOptions(mu=0.3, cycle_mu=cycle_mu))
    out = _out(comm, tmp_path_factory, "law")
    got = pipeline.run(law, out, comm, progress=False)
    loop = got.cycle_mu
    assert loop is not None and len(loop.passes) == 2
    first, second = loop.passes
    # pass 0: the cycle at the case's 0.5; the law dissipates 0.3/0.5 of its friction power
    assert first.mu_cycle == 0.5
    assert first.friction_power_law_W == pytest.approx(0.6 * first.friction_power_cycle_W, rel=1e-6)
    assert first.mu_effective == pytest.approx(0.3, rel=1e-6)
    # pass 1: the cycle at 0.3 (the effective mu on the cycle_mu_step grid) is the fixed point
    assert second.mu_cycle == law.friction.rounded_cycle_mu(first.mu_effective) == 0.3
    assert abs(second.change) < 1e-6
    if cycle_mu == "law":  # the law's mu at every band, 0.3 (moved by 0.2 from the first cycle)
        assert first.mu_band_range == pytest.approx((0.3, 0.3), abs=1e-12)
        assert first.field_change == pytest.approx(0.2, abs=1e-12)
        assert got.cycle is not None
    else:
        assert first.field_change is None and first.mu_band_range is None
    assert second.cycle_key != first.cycle_key and loop.mu == second.mu_cycle
    # the run reads what a run with its cycle solved at that mu reads
    c = got.cycle
    at = dataclasses.replace(
        base,
        contact=dataclasses.replace(base.contact, friction_coefficient=second.mu_cycle),
        friction=FrictionOptions(mu=0.3),
    )
    ref = pipeline.run(at, _out(comm, tmp_path_factory, "ref"), comm, progress=False)
    assert ref.cycle_mu is None
    assert c.friction_power_W == pytest.approx(ref.cycle.friction_power_W, rel=1e-12)
    assert got.instruments.torque.torque_loss_Nm == pytest.approx(
        ref.instruments.torque.torque_loss_Nm, rel=1e-9
    )
    assert got.headline.max_surface_temperature_C == pytest.approx(
        ref.headline.max_surface_temperature_C, abs=1e-9
    )
    # the torque meters' friction power is the last pass's law power
    assert got.instruments.torque.friction_power_W == pytest.approx(
        second.friction_power_law_W, rel=1e-12
    )
    # summary.json keeps the passes
    assert pipeline.RunSummary.read(out / "summary.json").cycle_mu == loop


@pytest.mark.slow
def test_a_fixed_point_not_reached_is_an_error_without_a_summary(tmp_path_factory):
    comm = MPI.COMM_WORLD
    base = _small_steady()
    one = dataclasses.replace(
        base, friction=FrictionOptions(mu=0.3, cycle_mu="law", cycle_mu_max_passes=1)
    )
    out = _out(comm, tmp_path_factory, "one")
    with pytest.raises(ConvergenceError, match=r"cycle mu per pass: 0\.5000") as err:
        pipeline.run(one, out, comm, progress=False)
    assert err.value.iteration == 1 and "1000 rpm / 8 N m" in err.value.step
    assert not (out / "summary.json").exists()


def test_cycle_mu_and_heat_split_options_are_checked_by_name():
    with pytest.raises(ParameterError, match="friction.cycle_mu"):
        FrictionOptions(cycle_mu="sometimes")
    with pytest.raises(ParameterError, match="friction.cycle_mu_tolerance"):
        FrictionOptions(cycle_mu_tolerance=0.0)
    with pytest.raises(ParameterError, match="friction.cycle_mu_max_passes"):
        FrictionOptions(cycle_mu_max_passes=0)
    with pytest.raises(ParameterError, match="sources.contact_temperature_tolerance_K"):
        SourceOptions(heat_partition="contact_temperature", contact_temperature_tolerance_K=0.0)
    with pytest.raises(ParameterError, match="sources.heat_partition"):
        SourceOptions(mode="prescribed", heat_partition="contact_temperature")
    # the law's mu is read by the torque meters from both gears' heat
    no_meters = dataclasses.replace(Case().instruments, torque=TorqueMeterOptions(enabled=False))
    with pytest.raises(ParameterError, match=r"friction.cycle_mu.*instruments.torque"):
        Case(friction=FrictionOptions(cycle_mu="law"), instruments=no_meters)
    # the law's defaults that follow the cycle's mu are pinned to the case's
    glass = FrictionOptions(law="glass_transition", mu_glassy=0.13)
    assert glass.pinned_to(0.5).mu_rubbery == 0.5
    assert FrictionOptions().pinned_to(0.5).mu == 0.5
    case = dataclasses.replace(Case(), friction=dataclasses.replace(glass, cycle_mu="law"))
    moved = pipeline.case_at_cycle_mu(case, 0.2)
    assert moved.contact.friction_coefficient == 0.2
    assert moved.friction_law().mu_rubbery == 0.5 and moved.friction_law().mu_glassy == 0.13


def test_the_glass_step_sits_at_the_pairs_polymers_glass_transition():
    glass = FrictionOptions(law="glass_transition", mu_glassy=0.13)
    # PEEK 450G: the DMA's 143 C, as before
    assert Case(friction=glass).friction.glass_transition_C == 143.0
    pom = library_material("POM").to_material(hysteresis=((20.0, 100.0), (0.01, 0.02)))
    steel = library_material("steel").to_material()
    pom_tg = library_material("POM").value("glass_transition_C")
    # a POM wheel against a steel pinion: the POM's
    pair = Case(material=steel, material_wheel=pom, friction=glass)
    assert pair.friction.glass_transition_C == pom_tg
    assert pair.friction_law().tg_K == pytest.approx(pom_tg + 273.15)
    # a given T_g stays; two polymers of different T_g, or two steels, need one
    given = dataclasses.replace(glass, glass_transition_C=120.0)
    assert (
        Case(material=steel, material_wheel=pom, friction=given).friction.glass_transition_C
        == 120.0
    )
    with pytest.raises(ParameterError, match="friction.glass_transition_C.*several"):
        Case(material_wheel=pom, friction=glass)
    with pytest.raises(ParameterError, match="friction.glass_transition_C.*no glass"):
        Case(material=steel, friction=glass)


def test_gearfem_run_says_when_the_law_runs_at_another_mu_than_the_cycle():
    """The note of ``gearfem run``: the law's effective mu from the torque meters' two friction
    powers, said when it differs from the cycle's by the fixed point's tolerance or more."""

    def reading(p_law: float, source: str = "law") -> TorqueReading:
        return TorqueReading(8.2, 8.0, 0.2, 0.97, p_law, 60.0, 0.057, 0.001, 0.04, source=source)

    case = Case()  # the cycle's mu 0.5, tolerance 0.005
    note = cycle_mu_note(case, reading(15.6), None)
    assert note is not None and "effective mu is 0.1300" in note and 'cycle_mu = "law"' in note
    assert cycle_mu_note(case, reading(60.0 * 0.996), None) is None  # within the tolerance
    assert cycle_mu_note(case, reading(15.6, source="cycle"), None) is None
    loop = pipeline.CycleMuLoop(
        passes=(pipeline.CycleMuPass(0.13, 0.13, 15.6, 15.6, "k", 1.0),), tolerance=0.005
    )
    assert cycle_mu_note(case, reading(15.6), loop) is None  # solved at the law's mu already
