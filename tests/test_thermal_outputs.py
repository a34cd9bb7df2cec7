"""Output files: CSV history with the balance, VTX field, plot, summary written last."""

from __future__ import annotations

import csv
import json

import pytest
from mpi4py import MPI
from thermal_meshes import sector_domain

from gearfem.core.errors import ConvergenceError
from gearfem.core.materials import Material
from gearfem.thermal import (
    GearRadii,
    PrescribedSources,
    ThermalBoundary,
    ThermalOptions,
    ThermalProblem,
)
from gearfem.thermal.outputs import solve_and_write
from gearfem.thermal.source_terms import prescribed_heat_sources


def _problem(comm, **kw):
    dom = sector_domain(comm, teeth=2)
    mat = Material()
    opts = ThermalOptions(
        **({"duration_s": 60.0, "output_times_s": (30.0,), "dt_initial_s": 0.5} | kw)
    )
    src = prescribed_heat_sources(
        PrescribedSources(flank_heat_per_gear_W=40.0, u_max_J_m3=1e5), dom, mat, 1000.0, 30
    )
    bnd = ThermalBoundary.from_options(opts, mat, 1000.0, GearRadii.thesis_gear())
    return ThermalProblem(dom, mat, src, bnd, opts, petsc_options_prefix="out_")


@pytest.mark.mpi
def test_run_writes_complete_outputs(tmp_out):
    with _problem(MPI.COMM_WORLD) as prob:
        records, summ = solve_and_write(prob, tmp_out / "run")
    out = tmp_out / "run"
    if MPI.COMM_WORLD.rank == 0:
        with open(out / "thermal_history.csv") as fh:
            rows = list(csv.DictReader(fh))
        assert len(rows) == len(records) and float(rows[-1]["time_s"]) == 60.0
        for col in (
            "T_max_surface_C",
            "T_mean_bulk_C",
            "T_flank_mean_C",
            "T_flank_max_C",
            "T_root_mean_C",
            "T_root_max_C",
            "generated_W",
            "stored_W",
            "convected_W",
            "radiated_W",
            "imbalance_W",
        ):
            assert col in rows[0]
        last = rows[-1]
        gen = float(last["generated_W"])
        assert gen == pytest.approx(float(last["hysteresis_W"]) + float(last["friction_W"]))
        assert abs(float(last["imbalance_W"])) < 1e-8 * gen
        s = json.loads((out / "thermal_summary.json").read_text())
        assert (
            s["complete"] and s["steps"] == len(records) - 1 and s["ranks"] == MPI.COMM_WORLD.size
        )
        assert s["model_fraction"] == pytest.approx(2 / 30)
        # where the run's time went: every accepted step's Newton iterations each took a
        # residual after the step's first one; a factorisation is made at a Jacobian only
        work = s["transient_solver"]
        assert work["residuals"] >= s["steps"] + s["newton_iterations"]
        assert 1 <= work["factorisations"] <= work["jacobians"] <= work["residuals"]
        assert work["krylov_iterations"] >= s["newton_iterations"]
        timed_s = work["jacobian_s"] + work["residual_s"] + work["linear_solve_s"]
        assert 0.0 < timed_s < s["wall_time_s"]
        assert (out / "thermal_history.png").stat().st_size > 0
        assert (out / "temperature.bp").is_dir()
        assert not (out / "thermal_history.csv.partial").exists()
    assert (
        summ["final_temperatures_C"]["flank_max"] > summ["final_temperatures_C"]["mean_bulk"] > 23.0
    )


def test_failed_run_leaves_no_summary(tmp_path, monkeypatch):
    prob = _problem(MPI.COMM_SELF)
    calls = {"n": 0}
    original = prob.try_step

    def failing(dt):
        calls["n"] += 1
        if calls["n"] > 5:
            raise ConvergenceError("thermal Newton (SNES)", "DIVERGED_TEST (-99)", step="test")
        return original(dt)

    monkeypatch.setattr(prob, "try_step", failing)
    with pytest.raises(ConvergenceError):
        solve_and_write(prob, tmp_path / "run")
    assert not (tmp_path / "run" / "thermal_summary.json").exists()
    assert not (tmp_path / "run" / "thermal_history.csv").exists()


def test_steady_mode_writes_one_row(tmp_path):
    prob = _problem(MPI.COMM_SELF, mode="steady")
    records, _summ = solve_and_write(prob, tmp_path / "steady", write_fields=False)
    assert len(records) == 1 and records[0].balance.stored_W == 0.0
    assert records[0].balance.relative_imbalance < 1e-9
    assert (tmp_path / "steady" / "thermal_summary.json").exists()


def test_a_sector_of_other_teeth_compiles_no_new_forms():
    """The thermal forms integrate over subdomain ids of their own (the roles, the flux, the
    monitors), not the mesh's facet tags: the same problem on a sector of three teeth, whose
    groups are more and numbered otherwise, compiles nothing the two-tooth sector's did not; and
    its role areas are those of the facet tags' measure."""
    import ufl
    from dolfinx import fem

    from gearfem.core.forms import num_kept
    from gearfem.thermal.domain import ROLES

    def build(teeth: int) -> ThermalProblem:
        dom = sector_domain(MPI.COMM_SELF, teeth=teeth)
        mat = Material()
        opts = ThermalOptions(duration_s=60.0, dt_initial_s=0.5)
        src = prescribed_heat_sources(
            PrescribedSources(flank_heat_per_gear_W=40.0, u_max_J_m3=1e5), dom, mat, 1000.0, 30
        )
        bnd = ThermalBoundary.from_options(opts, mat, 1000.0, GearRadii.thesis_gear())
        return ThermalProblem(dom, mat, src, bnd, opts, petsc_options_prefix=f"tags{teeth}_")

    with build(2) as two:
        two.solve_steady()
        kept = num_kept()
    with build(3) as three:
        three.solve_steady()
        assert num_kept() == kept
        dom = three.domain
        ds = ufl.Measure("ds", domain=dom.mesh, subdomain_data=dom.facet_tags)
        for role, area in three.role_areas_m2().items():
            expected = fem.assemble_scalar(fem.form(1.0 * ds(dom.role_tags(role))))
            assert area == pytest.approx(expected, rel=1e-12), role
        assert set(three.role_areas_m2()) == {r for r in ROLES if getattr(dom, r)}
