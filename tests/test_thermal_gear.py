"""The thermal model on gear meshes from gearfem.geometry (coarse meshes, seconds each)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI
from scipy.spatial import cKDTree

from gearfem.core.materials import Material
from gearfem.geometry import GearPairGeometry, MeshOptions, build_gear_mesh
from gearfem.geometry.mesh import analytic_areas_mm2
from gearfem.pipeline import read_case, run_thermal_case
from gearfem.thermal import (
    PrescribedSources,
    ThermalBoundary,
    ThermalDomain,
    ThermalOptions,
    ThermalProblem,
)
from gearfem.thermal.lumped import gear_radii
from gearfem.thermal.source_terms import prescribed_heat_sources

COARSE = MeshOptions(
    size_flank_mm=0.3,
    size_tip_mm=0.3,
    size_root_mm=0.3,
    size_tooth_mm=0.8,
    size_body_mm=3.0,
    layers=2,
    teeth_in_model=2,
)


@pytest.fixture(scope="module")
def cache(tmp_path_factory) -> Path:
    comm = MPI.COMM_WORLD
    path = str(tmp_path_factory.mktemp("meshcache")) if comm.rank == 0 else None
    return Path(comm.bcast(path, root=0))


def _problem(gm, flanks="drive", degree=2, prefix="gear_", periodic=True, **opts):
    dom = ThermalDomain.from_gear_mesh(gm, "pinion", flux_flanks=flanks)
    if not periodic:  # cut faces adiabatic even where the mesh's are periodic
        dom = dataclasses.replace(dom, periodic=None)
    mat = Material()
    o = ThermalOptions(degree=degree, **opts)
    prof = gm.pair.profile("pinion")
    bnd = ThermalBoundary.from_options(o, mat, 1000.0, gear_radii(prof))
    src = prescribed_heat_sources(
        PrescribedSources(flank_heat_per_gear_W=40.0, flanks=flanks), dom, mat, 1000.0, prof.teeth
    )
    return ThermalProblem(dom, mat, src, bnd, o, petsc_options_prefix=prefix)


@pytest.mark.mpi
def test_domain_from_pair_and_single_body_meshes(cache):
    """Roles, areas and volume of the pinion from a pair mesh (submesh) and from a single-body mesh
    equal the exact outline values (curved P2 geometry: relative 1e-4, as the geometry tests)."""
    g = GearPairGeometry()
    exact = analytic_areas_mm2(g, COARSE)
    for bodies in (("pinion", "wheel"), ("pinion",)):
        gm = build_gear_mesh(g, COARSE, MPI.COMM_WORLD, cache_dir=cache, bodies=bodies)
        with _problem(gm, prefix=f"dom{len(bodies)}_", mode="steady") as prob:
            rec = prob.solve_steady()
        dom = prob.domain
        assert dom.model_fraction == pytest.approx(2 / 30) and dom.teeth_modelled == 2
        areas = prob.role_areas_m2()
        teeth = sum(v for k, v in exact.items() if k.startswith("pinion_tooth")) * 1e-6
        assert areas["teeth"] == pytest.approx(teeth, rel=1e-4)
        assert areas["sides"] == pytest.approx(2 * exact["pinion_side_front"] * 1e-6, rel=1e-4)
        assert areas["bore"] == pytest.approx(exact["pinion_bore"] * 1e-6, rel=1e-4)
        assert areas["cuts"] == pytest.approx(2 * exact["pinion_cut_start"] * 1e-6, rel=1e-4)
        assert prob.volume_m3 == pytest.approx(
            exact["pinion_side_front"] * g.face_width_mm * 1e-9, rel=1e-4
        )
        assert rec.balance.friction_W == pytest.approx(40.0 * 2 / 30, rel=1e-12)
        assert rec.balance.relative_imbalance < 1e-9


@pytest.mark.slow
def test_sector_with_adiabatic_cuts_equals_full_gear_for_symmetric_heating(cache):
    """Cuts at mid-gap are symmetry planes of the full gear when both flanks are heated alike, so
    the
    2-tooth sector with adiabatic cuts has the full gear's solution: over the monitored temperatures
    the two P2 solutions (different meshes) differ by far less than P1 and P2 on the same mesh (an
    estimate of the P1 discretisation error, an upper bound of the P2 one)."""
    g = GearPairGeometry(teeth_pinion=16, teeth_wheel=16, bore_radius_mm=8.0)
    uniform = dataclasses.replace(COARSE, refined_teeth=0)  # every tooth meshed alike
    full = build_gear_mesh(
        g,
        dataclasses.replace(uniform, teeth_in_model=16),
        MPI.COMM_WORLD,
        cache_dir=cache,
        bodies=("pinion",),
    )
    sector = build_gear_mesh(g, uniform, MPI.COMM_WORLD, cache_dir=cache, bodies=("pinion",))
    T = {}
    for name, gm, degree in (("full", full, 2), ("sector", sector, 2), ("sector_p1", sector, 1)):
        with _problem(
            gm, flanks="both", degree=degree, prefix=f"sym_{name}_", mode="steady"
        ) as prob:
            assert (prob.domain.model_fraction == 1.0) == (name == "full")
            T[name] = prob.solve_steady().temperatures_K
    keys = (
        "mean_bulk",
        "flank_mean",
        "coast_flank_mean",
        "root_mean",
        "tip_mean",
        "flank_max",
        "root_max",
    )
    diff = max(abs(T["sector"][k] - T["full"][k]) for k in keys)
    p1_error = max(abs(T["sector"][k] - T["sector_p1"][k]) for k in keys)
    assert diff <= 0.1 * p1_error, (diff, p1_error)  # measured: 0.16 K against 22 K
    assert T["full"]["flank_mean"] - T["full"]["mean_bulk"] > 10.0  # a real gradient was compared


@pytest.mark.mpi
@pytest.mark.slow
def test_periodic_one_tooth_sector_equals_full_gear_for_drive_flank_heating(cache):
    """Drive-flank heating breaks the mirror symmetry about the cut planes, so adiabatic cuts are
    wrong; a one-tooth sector with its cut faces tied periodically (``periodic_cuts``) has the
    whole gear's field. Steady and after 600 s of heating, over the monitored temperatures it is
    closer to the whole gear than a quarter of the adiabatic cuts' error; the end face's nodes
    carry the start face's values at the turned points; the heat balance closes. Runs on 1 and
    on 2 ranks (the tie's DOFs are gathered across ranks)."""
    comm = MPI.COMM_WORLD
    g = GearPairGeometry(teeth_pinion=16, teeth_wheel=16, bore_radius_mm=8.0)
    uniform = dataclasses.replace(COARSE, refined_teeth=0)
    full = build_gear_mesh(
        g,
        dataclasses.replace(uniform, teeth_in_model=16),
        comm,
        cache_dir=cache,
        bodies=("pinion",),
    )
    one = dataclasses.replace(uniform, teeth_in_model=1, periodic_cuts=True)
    sector = build_gear_mesh(g, one, comm, cache_dir=cache, bodies=("pinion",))
    keys = ("mean_bulk", "flank_mean", "coast_flank_mean", "root_mean", "tip_mean", "flank_max")
    steady, transient = {}, {}
    for name, gm, tied in (
        ("full", full, False),
        ("adiabatic", sector, False),
        ("periodic", sector, True),
    ):
        for mode, out in (("steady", steady), ("transient", transient)):
            opts = {"mode": mode} if mode == "steady" else {"duration_s": 600.0}
            with _problem(gm, prefix=f"per_{name}_{mode}_", periodic=tied, **opts) as prob:
                assert (prob.domain.periodic is not None) == tied
                if mode == "steady":
                    rec = prob.solve_steady()
                else:
                    rec = prob.integrate()[-1]
                out[name] = rec.temperatures_K
                assert rec.balance.relative_imbalance < 1e-9
                if tied and mode == "steady":
                    assert prob.num_unknowns < prob.num_dofs
                    # the end face's DOFs carry the start face's values at the turned points
                    X = prob.V.tabulate_dof_coordinates()
                    start, end = (prob._dofs(2, (c,)) for c in prob.domain.cuts)
                    xs = np.concatenate(comm.allgather(prob.domain.periodic.image(X[start])))
                    ts = np.concatenate(comm.allgather(prob.T.x.array[start]))
                    d, i = cKDTree(xs).query(X[end])
                    assert len(end) == 0 or d.max() < 1e-12
                    assert len(end) == 0 or np.abs(prob.T.x.array[end] - ts[i]).max() < 1e-9
    for out, measured in ((steady, (1.03, 0.17)), (transient, (None, None))):
        adiabatic = max(abs(out["adiabatic"][k] - out["full"][k]) for k in keys)
        periodic = max(abs(out["periodic"][k] - out["full"][k]) for k in keys)
        assert adiabatic > 0.3, (adiabatic, measured)  # an error there to remove
        assert periodic < 0.25 * adiabatic, (periodic, adiabatic, measured)


@pytest.mark.mpi
def test_cli_case_runs_and_writes(cache, tmp_out):
    case_text = """
    [mesh]
    size_flank_mm = 0.3
    size_tip_mm = 0.3
    size_root_mm = 0.3
    layers = 2
    teeth_in_model = 2
    [operating]
    speed_rpm = 1000.0
    [thermal]
    duration_s = 120.0
    output_times_s = [60.0]
    degree = 1
    [sources]
    mode = "prescribed"
    flank_heat_per_gear_W = 40.0
    u_max_J_m3 = 2.0e4
    """
    path = tmp_out / "case.toml"
    if MPI.COMM_WORLD.rank == 0:
        path.write_text(case_text.replace("\n    ", "\n"))
    MPI.COMM_WORLD.barrier()
    summary = run_thermal_case(read_case(path), tmp_out / "cli", cache_dir=cache)
    assert summary["complete"] and summary["time_s"] == 120.0
    assert summary["generated_per_gear_W"] > 40.0  # friction plus hysteresis
    assert summary["convection_correlations"]["teeth_in_range"]
    lump = summary["lumped_estimate"]
    assert lump["theta_ss_K"] > 0 and lump["tau_s"] > 0
    if MPI.COMM_WORLD.rank == 0:
        assert (tmp_out / "cli" / "thermal_summary.json").exists()


@pytest.mark.mpi
def test_cell_field_transfer_from_the_pair_mesh(cache):
    """A DG0 field on the pair mesh (U_max of the cycle) arrives cell by cell on the pinion submesh:
    a field equal to each cell's centroid x-coordinate stays equal to it."""
    import numpy as np
    from dolfinx import fem
    from dolfinx import mesh as dmesh

    gm = build_gear_mesh(GearPairGeometry(), COARSE, MPI.COMM_WORLD, cache_dir=cache)
    dom = ThermalDomain.from_gear_mesh(gm, "pinion")
    assert dom.parent_cells is not None

    def centroid_field(msh, axis):
        Q = fem.functionspace(msh, ("DG", 0))
        f = fem.Function(Q)
        tdim = msh.topology.dim
        n = msh.topology.index_map(tdim).size_local + msh.topology.index_map(tdim).num_ghosts
        mid = dmesh.compute_midpoints(msh, tdim, np.arange(n, dtype=np.int32))
        f.x.array[Q.dofmap.list[:n, 0]] = mid[:, axis]
        return f

    moved = dom.cell_field_from_parent(centroid_field(gm.mesh, 0))
    assert np.allclose(moved.x.array, centroid_field(dom.mesh, 0).x.array, rtol=0, atol=1e-12)
    # the submesh holds pinion cells only: centroids within the pinion's tip circle about the origin
    r = np.hypot(centroid_field(dom.mesh, 0).x.array, centroid_field(dom.mesh, 1).x.array)
    assert np.all(r < gm.pair.profile("pinion").tip_radius_m)
