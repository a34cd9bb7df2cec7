"""Serial and parallel runs agree (run under mpirun -n 2: COMM_SELF vs COMM_WORLD in one run)."""

from __future__ import annotations

import pytest
from dolfinx import fem
from thermal_meshes import sector_domain

from gearfem.core.materials import Material
from gearfem.thermal import GearRadii, HeatSources, ThermalBoundary, ThermalOptions, ThermalProblem


def _run(comm, linear_solver):
    dom = sector_domain(comm, teeth=2, n=(4, 8, 3))
    mat = Material()
    opts = ThermalOptions(
        duration_s=300.0,
        dt_initial_s=0.25,
        time_error_K=0.05,
        output_times_s=(100.0,),
        linear_solver=linear_solver,
    )
    u = fem.Function(fem.functionspace(dom.mesh, ("DG", 0)))
    u.x.array[:] = 3.0e5
    src = HeatSources(
        u_max=u,
        loading_frequency_Hz=1000.0 / 60.0,
        hysteresis=mat.hysteresis_table(),
        flank_flux_W_m2=4.0e4,
        flux_surfaces=dom.flux_surfaces,
    )
    with ThermalProblem(
        dom,
        mat,
        src,
        ThermalBoundary.from_options(opts, mat, 1000.0, GearRadii.thesis_gear()),
        opts,
        petsc_options_prefix=f"par_{comm.size}_{linear_solver}_",
    ) as prob:
        return prob.integrate(), prob.num_dofs


@pytest.mark.mpi
# the default solver ("direct") in the quick tier, the others in the full one
@pytest.mark.parametrize(
    "linear_solver",
    [
        pytest.param("iterative", marks=pytest.mark.slow),
        "direct",
        pytest.param("multigrid", marks=pytest.mark.slow),
    ],
)
def test_serial_and_parallel_agree(comms, linear_solver):
    serial, world = comms
    rs, n_s = _run(serial, linear_solver)
    rw, n_w = _run(world, linear_solver)
    assert n_s == n_w
    # same adaptive step sequence and the same temperatures to the solver tolerance (Newton rtol
    # 1e-10)
    assert len(rs) == len(rw)
    for a, b in zip(rs, rw):
        assert a.time_s == pytest.approx(b.time_s, rel=1e-9, abs=1e-12)
        for key, value in a.temperatures_K.items():
            assert b.temperatures_K[key] == pytest.approx(value, abs=1e-6), key
    fa, fb = rs[-1].balance, rw[-1].balance
    for key in ("hysteresis_W", "friction_W", "stored_W", "convected_W", "radiated_W"):
        assert getattr(fb, key) == pytest.approx(getattr(fa, key), rel=1e-7), key
    assert rw[-1].temperatures_K["flank_max"] > rw[-1].temperatures_K["mean_bulk"] > 296.15 + 1.0
