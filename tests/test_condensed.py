"""The condensed contact solver against exact relations and against the full solver.

Static condensation is exact, so the condensed solver must reproduce the full solver to its
Newton tolerance: the compliance from the MUMPS Schur complement equals [K⁻¹]_cc computed column
by column; the contact patch test is passed to round-off; the Hertz case gives the full solver's
pressures; the whole displacement recovered by back-substitution equals u_c on the contact
nodes. A surface set that misses a contact is reported by tooth. The gear cycle comparisons are in
tests/test_cycle.py.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.sparse as sp
from dolfinx.mesh import entities_to_geometry
from mpi4py import MPI
from test_cycle import _case, _model

from gearfem import pipeline
from gearfem.contact import ContactOptions, condensed
from gearfem.contact.compliance import (
    Condensation,
    body_dofs,
    compliance_by_solves,
    spd_inverse,
)
from gearfem.contact.condensed import CondensedContactProblem
from gearfem.contact.verification import block_case, compare_hertz, hertz_case
from gearfem.core.errors import ConvergenceError, ParameterError, UncoveredContactError
from gearfem.core.petsc import cholesky_factor, schur_complement
from gearfem.cycle import CycleOptions, GearContactModel
from gearfem.cycle.cache import compliance_store

_PATCH = ContactOptions(method="penalty", penalty_Pa_m=100.0)
HERTZ = ContactOptions(search_distance_rel=2.0)


def test_schur_complement_compliance_equals_the_inverse_by_solves():
    """C = S⁻¹ from MUMPS's Schur complement equals [K⁻¹]_cc from one solve per column (the
    lower block: 297 contact DOFs of 1297), and the condensation stores exactly it."""
    case = block_case(MPI.COMM_SELF, _PATCH, solver="condensed")
    prob = case.problem
    cond = prob.condensation
    b = prob.body_dofs["lower"]
    Kb = cond.matrices["lower"]
    S = schur_complement(Kb, b.contact_in_free, "test_schur_")
    np.testing.assert_allclose(S, S.T, rtol=0, atol=1e-12 * np.abs(S).max())
    C = spd_inverse(S)
    pc, scope = cholesky_factor(Kb, "test_solves_")
    try:
        ref = compliance_by_solves(pc, Kb.getSize()[0], b.contact_in_free)
    finally:
        pc.destroy()
        scope.clear()
    assert np.abs(C - ref).max() <= 1e-10 * np.abs(ref).max()
    assert np.abs(cond.compliance["lower"] - C).max() <= 1e-12 * np.abs(C).max()
    assert np.all(np.linalg.eigvalsh(ref) > 0.0)  # a compliance: symmetric positive definite


def test_a_body_without_supports_is_reported():
    """A floating body (no Dirichlet condition) has no compliance: MUMPS's null pivot is an
    error naming the factorisation, not a garbage matrix."""
    case = block_case(MPI.COMM_SELF, _PATCH)
    prob = case.problem
    md = case.mesh_data
    cells = {"upper": md.cell_tags.find(md.physical_groups["upper"].tag)}
    surf = prob.interfaces[0].b
    contact = (3 * surf.gathered().blocks[:, :, None] + np.arange(3)).ravel()
    dofs = body_dofs(prob.V, cells, np.zeros_like(prob.fixed_mask()), {"upper": contact})
    with pytest.raises(ConvergenceError, match="MUMPS"):
        Condensation(prob.K_full, dofs, MPI.COMM_SELF)


@pytest.mark.mpi
@pytest.mark.parametrize(
    "hexahedra", [False, pytest.param(True, marks=pytest.mark.slow)], ids=["tet10", "hex27"]
)
def test_condensed_patch_test_uniform_pressure(distinct_comms, hexahedra):
    """The patch test of tests/test_contact.py with the condensed solver: p = δ / (H/E + 1/ε) at
    every point to round-off on 1 and 2 ranks, and the recovered volume field equals u_c on c."""
    delta, E, eps, H = 1e-3, 1.0, 100.0, 1.0
    p_exact = delta / (H / E + 1.0 / eps)
    for comm in distinct_comms:
        case = block_case(
            comm,
            _PATCH,
            compression_m=delta,
            youngs_modulus_Pa=E,
            hexahedra=hexahedra,
            solver="condensed",
        )
        prob = case.problem
        assert isinstance(prob, CondensedContactProblem)
        prob.solve("patch")
        p = np.concatenate([pts.pressure for pts in prob.last_points[0]])
        pmin = comm.allreduce(p.min(initial=np.inf), op=MPI.MIN)
        pmax = comm.allreduce(p.max(initial=-np.inf), op=MPI.MAX)
        assert pmin == pytest.approx(p_exact, rel=1e-10)
        assert pmax == pytest.approx(p_exact, rel=1e-10)
        assert prob.back_substitution_error < 1e-10
        # the prescribed compression reaches the body through the lift ū (no contact force)
        assert np.abs(prob.ubar).max() > 0.0


def test_condensed_sliding_block_is_gross_slip():
    """Coulomb gross slip through the condensed system: |t_T| = μ p at every contact point and the
    force ratio is μ (the friction part of the non-symmetric tangent, and the bordered-free
    Newton)."""
    mu = 0.3
    opts = ContactOptions(method="penalty", penalty_Pa_m=100.0, friction_coefficient=mu)
    case = block_case(
        MPI.COMM_WORLD,
        opts,
        compression_m=1e-3,
        upper_velocity_m_s=(1.0, 0.0, 0.0),
        clamped=True,
        solver="condensed",
    )
    prob = case.problem
    prob.solve("sliding")
    fn, ft = prob.contact_force()
    assert np.linalg.norm(ft) == pytest.approx(mu * np.linalg.norm(fn), rel=1e-8)
    for pts in prob.last_points[0]:
        on = pts.pressure > 0
        tt = (pts.traction - pts.pressure[:, None] * pts.normal)[on]
        np.testing.assert_allclose(np.linalg.norm(tt, axis=1), mu * pts.pressure[on], rtol=1e-9)


@pytest.mark.mpi
@pytest.mark.slow
def test_condensed_hertz_matches_the_full_solver(distinct_comms):
    """Hertz line contact (h = 14 mm): the condensed solver gives the full solver's force, peak
    pressure and half-width (the same discrete problem; they differ by the Newton and Uzawa
    tolerances, which the two reach from different first iterates), on 1 and 2 ranks."""
    out = {}
    for solver in ("full", "condensed"):
        for comm in distinct_comms:
            case = hertz_case(comm, HERTZ, contact_size=0.014, solver=solver)
            rep = case.problem.solve("hertz")
            tol = case.problem.interfaces[0].penetration_tolerance()
            assert rep.constraint_penetration_m <= tol
            out[solver, comm.size] = compare_hertz(case)
    full = out["full", 1]
    for key, r in out.items():
        assert r.force_per_length_N_m == pytest.approx(full.force_per_length_N_m, rel=1e-4), key
        assert r.p0_fe_Pa == pytest.approx(full.p0_fe_Pa, rel=1e-3), key
        assert r.a_fe_m == pytest.approx(full.a_fe_m, rel=1e-3), key
    # the condensed solver on 1 and on all ranks: the same iterates
    one, world = out["condensed", 1], out["condensed", MPI.COMM_WORLD.size]
    assert world.force_per_length_N_m == pytest.approx(one.force_per_length_N_m, rel=1e-8)
    assert world.p0_fe_Pa == pytest.approx(one.p0_fe_Pa, rel=1e-8)


def test_refinement_with_an_earlier_lu_solves_the_new_system_or_gives_up():
    """The active-set solve's iterative refinement: with the LU of a nearby system (contact
    stiffness changed by 0.1 %) it reaches the new system's solution (residual 1e-12 of the
    right-hand side, solution within 1e-10 of the direct solve); with the LU of a system five
    times stiffer it gives up (None) instead of returning a poor direction."""
    rng = np.random.default_rng(7)
    n = 300
    B = rng.standard_normal((n, n)) / math.sqrt(n)
    C = B @ B.T + 0.1 * np.eye(n)  # a compliance: symmetric positive definite
    k = rng.uniform(1.0, 1e3, n)
    rhs = rng.standard_normal((n, 2))
    lu = sla.lu_factor(np.eye(n) + k[:, None] * C)
    near = sp.diags(k * (1.0 + 1e-3 * rng.uniform(-1, 1, n))).tocsr()
    x = CondensedContactProblem._refine(lu, near, C, rhs)
    exact = np.linalg.solve(np.eye(n) + near @ C, rhs)
    assert x is not None
    assert np.abs(x - exact).max() <= 1e-10 * np.abs(exact).max()
    assert CondensedContactProblem._refine(lu, sp.diags(5.0 * k).tocsr(), C, rhs) is None


@pytest.mark.slow
def test_condensed_hertz_reuses_factorisations_and_keeps_the_answer(monkeypatch):
    """Hertz line contact (h = 14 mm) on the condensed solver: with the refinement on the last LU
    it factorises fewer times than it takes Newton directions, and gives the force and the peak
    pressure of the solve that factorises at every direction to 1e-9."""
    out = {}
    for passes in (condensed.REFINE_PASSES, 0):
        monkeypatch.setattr(condensed, "REFINE_PASSES", passes)
        case = hertz_case(MPI.COMM_SELF, HERTZ, contact_size=0.014, solver="condensed")
        case.problem.solve("hertz")
        out[passes] = (compare_hertz(case), case.problem.info, len(case.problem.active_sizes))
    (reuse, info, directions), (fresh, info0, directions0) = out.values()
    assert info0["dense_factorizations"] == directions0
    assert info["dense_factorizations"] < directions
    assert reuse.force_per_length_N_m == pytest.approx(fresh.force_per_length_N_m, rel=1e-9)
    assert reuse.p0_fe_Pa == pytest.approx(fresh.p0_fe_Pa, rel=1e-9)


def test_condensed_non_convergence_names_reason_step_and_iteration():
    """The rotated patch test needs several Newton steps (the projection points move between
    iterates); allowed one, the condensed Newton fails with the driver's reason, the step label and
    the iteration, like the full solver."""
    opts = ContactOptions(
        method="penalty", penalty_Pa_m=100.0, newton_max_it=1, newton_rtol=1e-12, newton_atol_N=0.0
    )
    case = block_case(
        MPI.COMM_SELF,
        opts,
        compression_m=1e-3,
        motion_angle_rad=math.radians(30.0),
        solver="condensed",
    )
    with pytest.raises(ConvergenceError) as err:
        case.problem.solve("rotated step")
    assert "DIVERGED_MAX_IT" in err.value.reason
    assert err.value.step.startswith("rotated step") and err.value.iteration == 1
    assert "condensed" in err.value.solver


def test_condensed_solver_refuses_loads_and_unknown_solvers():
    case = block_case(MPI.COMM_SELF, _PATCH)
    prob = case.problem
    with pytest.raises(ParameterError, match="traction_form"):
        CondensedContactProblem(
            prob.V,
            1.0,
            1.0,
            prob.bcs,
            prob.interfaces,
            prob.motions,
            _PATCH,
            bodies={},
            traction_form=prob.a,
        )
    with pytest.raises(ParameterError, match="solver"):
        block_case(MPI.COMM_SELF, _PATCH, solver="condensd")


# ------------------------------------------------------------------------------------------------
# gears: the surface set and its guard
# ------------------------------------------------------------------------------------------------


def _tiny_case(**cycle):
    return _case(8.0, 0.5, **cycle)


def test_cycle_solver_option_is_validated():
    with pytest.raises(ParameterError, match=r"cycle\.solver") as err:
        CycleOptions(solver="condenced")
    assert "condensed" in str(err.value) and "full" in str(err.value)
    with pytest.raises(ParameterError, match=r"cycle\.condensed_margin_pitches"):
        CycleOptions(condensed_margin_pitches=-0.1)


def test_condensed_surfaces_follow_the_roll_of_the_involute():
    """The roll parameter of a flank point is the contact parameter S of the rigid pair touching
    there: 0 at the operating pitch radius and g_a at the pinion's tip form radius (−g_f at the
    wheel's); the condensed surfaces of the first 3° hold, on the pair at the pitch point, the
    facets around the pitch radius and not those at the tip or the root, and nothing of the
    teeth out of reach."""
    case = _tiny_case(solver="condensed", condensed_margin_pitches=0.1, pitches=3 / 12)
    case = dataclasses.replace(case, cycle=dataclasses.replace(case.cycle, check_periodicity=False))
    m = _model(case)
    pair = m.pair
    for b, prof, end in (
        ("pinion", pair.pinion, pair.recess_length_m),
        ("wheel", pair.wheel, -pair.approach_length_m),
    ):
        pitch = m.roll_parameter(b, np.array([prof.operating_pitch_radius_m]))[0]
        tip = m.roll_parameter(b, np.array([prof.tip_form_radius_m]))[0]
        assert abs(pitch) < 1e-15 and abs(tip - end) < 1e-15
    x = m.gm.mesh.geometry.x
    center = np.asarray(m.gm.center("pinion"))[:2]
    held = np.zeros(0)
    tooth2 = m.gm.facets(*m._contact_names("pinion", [2]))
    mine = np.intersect1d(m.contact_facets["pinion"], tooth2)
    if len(mine):
        mid = x[entities_to_geometry(m.gm.mesh, 2, mine)].mean(axis=1)
        held = np.hypot(*(mid[:, :2] - center).T)
    radii = np.concatenate(MPI.COMM_WORLD.allgather(held))
    r_w = pair.pinion.operating_pitch_radius_m
    assert radii.min() < r_w < radii.max()
    assert radii.max() < pair.pinion.tip_form_radius_m and radii.min() > pair.pinion.base_radius_m
    assert m.contact_teeth == {"pinion": [1, 2], "wheel": [1, 2]}


@pytest.mark.slow
def test_a_contact_outside_the_condensed_surfaces_names_the_tooth():
    """With a margin of 0.1 base pitch, the condensed surfaces of the first 3° of the cycle hold
    the pair in rigid contact there near the pitch point (pinion tooth 2, wheel tooth 1) and the
    ends of the next pairs' flanks. At 2° the loaded soft teeth bring the next pair into contact
    lower on its flank (the full solver carries 21 N on pinion tooth 1 there): the guard finds
    the penetration of the facets left out and names their teeth."""
    case = _tiny_case(solver="condensed", condensed_margin_pitches=0.1, pitches=3 / 12)
    case = dataclasses.replace(case, cycle=dataclasses.replace(case.cycle, check_periodicity=False))
    m = _model(case)
    m.solve_position(0.0, "pitch point")  # one pair carries the load: nothing missed
    with pytest.raises(UncoveredContactError) as err:
        m.solve_position(math.radians(2.0), "pinion angle 2 deg")
    msg = str(err.value)
    assert "pinion tooth 1" in msg and "wheel tooth 2" in msg and "2 deg" in msg
    assert "condensed_margin_pitches" in msg
    depth = float(msg.split("by ")[1].split(" m")[0])
    assert depth > 1e-6  # a real penetration, not round-off


@pytest.mark.slow
def test_compliance_store_serves_the_next_model(tmp_path):
    """A second model of the same mesh and material (another torque) takes the gears'
    compliances from the store, bit for bit, and gives the same first position as a fresh one."""
    case = _tiny_case(solver="condensed", pitches=1 / 12)
    case = dataclasses.replace(case, cycle=dataclasses.replace(case.cycle, check_periodicity=False))
    store = compliance_store(case.geometry, case.mesh, case.materials, tmp_path)
    gm = pipeline.pair_mesh(case, MPI.COMM_WORLD)
    models = []
    for torque, st in ((8.0, store), (4.0, store), (4.0, None)):
        models.append(GearContactModel(gm, case.materials, case.contact, torque, case.cycle, st))
    first, again, fresh = models
    assert not any(first.problem.info["compliance_from_store"].values())
    assert all(again.problem.info["compliance_from_store"].values())
    if MPI.COMM_WORLD.rank == 0:
        for b in ("pinion", "wheel"):
            np.testing.assert_array_equal(
                again.problem.condensation.compliance[b], first.problem.condensation.compliance[b]
            )
    again.solve_position(0.0, "stored")
    fresh.solve_position(0.0, "fresh")
    assert again.transmission_error_m() == pytest.approx(fresh.transmission_error_m(), rel=1e-12)
