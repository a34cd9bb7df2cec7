"""Verification of the thermal solver against analytic and manufactured solutions.

* steady MMS with convection + radiation boundaries (and k(T)): L2 order 2 (P1) and 3 (P2);
* transient MMS, solution quadratic in space (exact in P2) so only the time error remains:
  fixed-step BDF2 converges with order 2, also with c_p(T);
* lumped limit (very high k, uniform source, convection only): theta = P/(hA)(1 - exp(-t/tau));
* radiation-only cooling of a lumped body: the implicit closed-form solution t(T);
* heat balance of every step, with every source and boundary type switched on.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import ufl
from dolfinx import fem
from mpi4py import MPI
from scipy.optimize import brentq
from thermal_meshes import box_domain, sector_domain, square_domain

from gearfem.core.gci import grid_convergence, least_squares_convergence
from gearfem.core.materials import ZERO_CELSIUS_K, Material, TemperatureTable
from gearfem.core.materials import STEFAN_BOLTZMANN_W_m2K4 as SIGMA
from gearfem.thermal import (
    GearRadii,
    HeatSources,
    SurfaceExchange,
    ThermalBoundary,
    ThermalOptions,
    ThermalProblem,
)
from gearfem.thermal.properties import table_ufl

TA = 296.15  # 23 C
H_TEETH, H_SIDES, EPS = 10.0, 5.0, 0.9
ALL_EDGES = ("left", "right", "bottom", "top")


def _l2(comm, expr) -> float:
    return math.sqrt(
        comm.allreduce(
            fem.assemble_scalar(fem.form(expr**2 * ufl.dx(metadata={"quadrature_degree": 8}))),
            op=MPI.SUM,
        )
    )


def _mms_sources(dom, mat, T_exact, dT_dt=None):
    """Volumetric source and boundary flux making T_exact(x, t) the solution with convection
    h = H_TEETH on x = 0, 1 ('teeth'), H_SIDES on y = 0, 1 ('sides') and radiation EPS to TA."""
    n = ufl.FacetNormal(dom.mesh)
    k, cp = mat.conductivity(), mat.specific_heat()

    def q(x, t):
        T = T_exact(x, t)
        out = -ufl.div(table_ufl(k, T) * ufl.grad(T))
        if dT_dt is not None:
            out = out + mat.density_kg_m3 * table_ufl(cp, T) * dT_dt(x, t)
        return out

    def g(x, t):
        T = T_exact(x, t)
        h = ufl.conditional(ufl.gt(abs(n[0]), 0.5), H_TEETH, H_SIDES)
        return (
            h * (T - TA) + EPS * SIGMA * (T**4 - TA**4) + table_ufl(k, T) * ufl.dot(ufl.grad(T), n)
        )

    return HeatSources(volumetric_W_m3=q, flank_flux_W_m2=g, flux_surfaces=ALL_EDGES)


def _mms_options(**kw):
    return ThermalOptions(
        h_teeth_W_m2K=H_TEETH,
        h_sides_W_m2K=H_SIDES,
        emissivity=EPS,
        ambient_C=TA - ZERO_CELSIUS_K,
        **kw,
    )


def _mms_steady_errors(degree: int, sizes, k_of_T: bool) -> list[float]:
    """L2 errors of the steady manufactured solution on n x n meshes of the unit square."""
    mat = Material(
        density_kg_m3=1.0,
        specific_heat_J_kgK=1.0,
        thermal_conductivity_W_mK=2.0,
        conductivity_table=((0.0, 200.0), (1.5, 3.0)) if k_of_T else None,
    )

    def T_exact(x, t):
        return 330.0 + 40.0 * ufl.sin(1.5 * x[0] + 0.5) * ufl.cos(2.0 * x[1])

    errors = []
    for n in sizes:
        dom = square_domain(MPI.COMM_WORLD, n)
        opts = _mms_options(degree=degree, mode="steady")
        prob = ThermalProblem(
            dom,
            mat,
            _mms_sources(dom, mat, T_exact),
            ThermalBoundary.from_options(opts, mat, 0.0, None),
            opts,
            petsc_options_prefix=f"mms_s{degree}{n}_",
        )
        rec = prob.solve_steady()
        assert rec.balance.relative_imbalance < 1e-9
        errors.append(_l2(dom.comm, prob.T - T_exact(ufl.SpatialCoordinate(dom.mesh), 0.0)))
    return errors


@pytest.mark.parametrize("degree, sizes, order", [(1, (8, 16, 32), 2.0), (2, (4, 8, 16), 3.0)])
@pytest.mark.parametrize("k_of_T", [False, True])
def test_mms_spatial_order(degree, sizes, order, k_of_T):
    """Steady manufactured solution: L2 error falls as h^(p+1) (rates from three meshes)."""
    errors = _mms_steady_errors(degree, sizes, k_of_T)
    rates = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert rates[-1] == pytest.approx(order, abs=0.1), (errors, rates)
    assert rates[0] > order - 0.3


@pytest.mark.parametrize("degree, sizes", [(1, (8, 12, 18)), (2, (4, 6, 9))])
def test_gci_recovers_the_mms_order_and_brackets_the_error(degree, sizes):
    """The refinement tool (gearfem.core.gci) on a quantity with a known exact value: the L2
    error (exact value 0) on three meshes with r = 1.5. It recovers the order p + 1 and its
    uncertainty of the finest value, and that of the medium one, bracket the true errors of those
    values."""
    errors = _mms_steady_errors(degree, sizes, k_of_T=False)
    conv = grid_convergence(errors, [1.0 / n for n in sizes], formal_order=degree + 1)
    assert conv.observed_order == pytest.approx(degree + 1, abs=0.15), conv
    assert conv.asymptotic
    assert conv.gci >= abs(errors[-1] - 0.0)  # the exact value of an error norm is 0
    assert abs(conv.extrapolated) < 0.2 * errors[-1]
    # a case in the middle of the study (gearfem converge --case-level middle): the medium
    # value's uncertainty brackets its error too
    assert conv.gci_at(1) >= abs(errors[1] - 0.0)


@pytest.mark.parametrize("degree, sizes", [(1, (6, 9, 13, 20)), (2, (3, 5, 7, 11))])
def test_least_squares_recovers_the_mms_order_on_four_meshes(degree, sizes):
    """The four-level procedure (``gearfem converge --levels 4``) on the same manufactured
    problem, with unequal ratios: it recovers the order p + 1, and the uncertainty of every level
    brackets that level's true error (the exact value of an error norm is 0)."""
    errors = _mms_steady_errors(degree, sizes, k_of_T=False)
    conv = least_squares_convergence(errors, [1.0 / n for n in sizes], formal_order=degree + 1)
    assert conv.observed_order == pytest.approx(degree + 1, abs=0.2), conv
    assert conv.asymptotic
    for level, e in enumerate(conv.values):
        assert conv.gci_at(level) >= abs(e)


@pytest.mark.parametrize("cp_of_T", [False, True])
def test_mms_temporal_order(cp_of_T):
    """T = 300 + s(x) sin(2t), s quadratic (exact in P2): the error is the BDF2 time error, order
    2."""
    mat = Material(
        density_kg_m3=1.0,
        specific_heat_J_kgK=1.0,
        thermal_conductivity_W_mK=1.0,
        specific_heat_table=((0.0, 100.0), (0.8, 1.6)) if cp_of_T else None,
    )

    def s(x):
        return 20.0 + 10.0 * x[0] ** 2 + 5.0 * x[1]

    def T_exact(x, t):
        return 300.0 + s(x) * ufl.sin(2.0 * t)

    def dT_dt(x, t):
        return 2.0 * s(x) * ufl.cos(2.0 * t)

    dom = square_domain(MPI.COMM_WORLD, 4)
    errors = []
    for dt in (1 / 32, 1 / 64, 1 / 128, 1 / 256):
        opts = _mms_options(
            degree=2,
            duration_s=1.0,
            time_stepping="fixed",
            dt_initial_s=dt,
            dt_min_s=dt,
            initial_C=300.0 - ZERO_CELSIUS_K,
        )
        prob = ThermalProblem(
            dom,
            mat,
            _mms_sources(dom, mat, T_exact, dT_dt),
            ThermalBoundary.from_options(opts, mat, 0.0, None),
            opts,
            petsc_options_prefix="mms_t_",
        )
        recs = prob.integrate()
        assert len(recs) == round(1.0 / dt) + 1 and recs[-1].time_s == 1.0
        assert max(r.balance.relative_imbalance for r in recs[1:]) < 1e-9
        errors.append(_l2(dom.comm, prob.T - T_exact(ufl.SpatialCoordinate(dom.mesh), 1.0)))
    rates = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert rates[-1] == pytest.approx(2.0, abs=0.1), (errors, rates)
    assert np.all(np.diff(np.abs(rates - 2.0)) < 0), rates  # approaching 2 monotonically


def _lumped_box(**mat_kw):
    dom = box_domain(MPI.COMM_WORLD, n=(2, 2, 2))
    mat = Material(thermal_conductivity_W_mK=1.0e3, **mat_kw)  # Biot number h L / k ~ 3e-4
    vol = 0.02 * 0.02 * 0.01
    area = 2 * 0.02 * 0.02 + 4 * 0.02 * 0.01
    return dom, mat, vol, area


def test_lumped_limit_exponential():
    """High k, uniform source P, convection only: theta(t) = P/(hA) (1 - exp(-hA t / (rho c V)))."""
    dom, mat, vol, area = _lumped_box()
    h, P = 25.0, 4.0
    opts = ThermalOptions(
        h_teeth_W_m2K=h,
        h_sides_W_m2K=h,
        emissivity=0.0,
        duration_s=1000.0,
        dt_initial_s=0.5,
        time_error_K=0.01,
        output_times_s=(100.0, 500.0),
    )
    src = HeatSources(volumetric_W_m3=P / vol)
    prob = ThermalProblem(
        dom,
        mat,
        src,
        ThermalBoundary.from_options(opts, mat, 0.0, None),
        opts,
        petsc_options_prefix="lumped_",
    )
    recs = prob.integrate()
    theta_ss = P / (h * area)
    tau = mat.density_kg_m3 * mat.specific_heat_J_kgK * vol / (h * area)
    t = np.array([r.time_s for r in recs])
    theta = np.array([r.temperatures_K["mean_bulk"] for r in recs]) - TA
    exact = theta_ss * (1.0 - np.exp(-t / tau))
    assert np.max(np.abs(theta - exact)) < 0.01 * theta_ss
    spread = max(r.temperatures_K["max_surface"] - r.temperatures_K["mean_bulk"] for r in recs)
    assert spread < 1e-3 * theta_ss  # lumped indeed
    assert {100.0, 500.0, 1000.0} <= set(t.tolist())  # output times are hit exactly


def test_radiation_only_cooling_matches_ode():
    """C dT/dt = -eps sigma A (T^4 - Ta^4): t(T) = C/(eps sigma A) (F(T0) - F(T)),
    F(T) = ln((T - a)/(T + a))/(4 a^3) - arctan(T/a)/(2 a^3), a = Ta."""
    dom, mat, vol, area = _lumped_box()
    T0 = 573.15
    opts = ThermalOptions(
        convection="none",
        emissivity=0.9,
        duration_s=3000.0,
        initial_C=T0 - ZERO_CELSIUS_K,
        dt_initial_s=0.5,
        time_error_K=0.01,
    )
    prob = ThermalProblem(
        dom,
        mat,
        HeatSources(),
        ThermalBoundary.from_options(opts, mat, 0.0, None),
        opts,
        petsc_options_prefix="radiation_",
    )
    recs = prob.integrate()
    a = TA
    C = mat.density_kg_m3 * mat.specific_heat_J_kgK * vol
    K = C / (0.9 * SIGMA * area)

    def F(T):
        return math.log((T - a) / (T + a)) / (4 * a**3) - math.atan(T / a) / (2 * a**3)

    def T_exact(t):
        return brentq(lambda T: K * (F(T0) - F(T)) - t, a + 1e-9, T0)

    errs = [abs(r.temperatures_K["mean_bulk"] - T_exact(r.time_s)) for r in recs[1:]]
    assert max(errs) < 0.01 * (T0 - TA)
    assert recs[-1].temperatures_K["mean_bulk"] - TA < 0.5 * (T0 - TA)  # cooled substantially
    for r in recs[1:]:
        assert r.balance.convected_W == 0.0 and r.balance.radiated_W > 0.0


@pytest.mark.mpi
def test_heat_balance_closes_every_step():
    """Everything on (H(T) hysteresis, flank flux with mu(T) factor, film-temperature h(T), k(T),
    c_p(T),
    radiation, bore heat path): generated = stored + convected + radiated + bore at every step to
    the
    Newton tolerance, and the heat content change equals the time integral of the net flow."""
    dom = sector_domain(MPI.COMM_WORLD, teeth=2)
    mat = Material(
        conductivity_table=((20.0, 150.0), (0.25, 0.30)),
        specific_heat_table=((20.0, 150.0), (1100.0, 1900.0)),
    )
    opts = ThermalOptions(
        air_properties="film",
        bore_h_W_m2K=50.0,
        duration_s=600.0,
        dt_initial_s=0.25,
        time_error_K=0.05,
    )
    boundary = ThermalBoundary.from_options(opts, mat, 1000.0, GearRadii.thesis_gear())
    assert callable(boundary.teeth.h_W_m2K)
    Q = fem.functionspace(dom.mesh, ("DG", 0))
    u_max = fem.Function(Q)
    u_max.x.array[:] = 2.0e5
    src = HeatSources(
        u_max=u_max,
        loading_frequency_Hz=1000.0 / 60.0,
        hysteresis=mat.hysteresis_table(),
        flank_flux_W_m2=4.0e4,
        flux_surfaces=dom.flux_surfaces,
        flux_temperature_factor=lambda T: 1.0 - 0.002 * (T - TA),
    )
    with ThermalProblem(dom, mat, src, boundary, opts, petsc_options_prefix="balance_") as prob:
        E0 = prob.heat_content_J()
        recs = prob.integrate()
        E1 = prob.heat_content_J()
    b = recs[-1].balance
    assert (
        b.hysteresis_W > 0
        and b.friction_W > 0
        and b.convected_W > 0
        and b.radiated_W > 0
        and b.bore_W > 0
    )
    for r in recs[1:]:
        b = r.balance
        assert abs(b.imbalance_W) <= 0.005 * b.generated_W
        assert abs(b.imbalance_W) <= 1e-8 * b.generated_W  # exact up to the Newton tolerance
    # content check independent of the BDF2 quotient: Delta E = int (gen - losses) dt (trapezoid,
    # from t_1)
    t = np.array([r.time_s for r in recs[1:]])
    net = np.array(
        [
            r.balance.generated_W - r.balance.convected_W - r.balance.radiated_W - r.balance.bore_W
            for r in recs[1:]
        ]
    )
    gen = np.array([r.balance.generated_W for r in recs[1:]])
    dE = E1 - E0
    first = recs[1].balance.stored_W * recs[1].dt_s  # backward-Euler first step
    integral = first + np.trapezoid(net, t)
    assert abs(dE - integral) <= 0.005 * (gen[0] * recs[1].dt_s + np.trapezoid(gen, t))
    assert max(recs[-1].temperatures_K.values()) > TA + 20.0  # it did heat up


def test_custom_boundary_object_extension():
    """A model extension passes its own ThermalBoundary (T-dependent h, ambient offset) without
    solver changes;
    with h(T) = h0 + c (T - Ta) and no radiation the lumped steady state solves h(theta) theta A =
    P."""
    dom, mat, vol, area = _lumped_box()
    offset, h0, c, P = 2.0, 10.0, 0.1, 3.0
    amb = TA + offset
    ex = SurfaceExchange(lambda T: h0 + c * (T - amb), amb, 0.0)
    bnd = ThermalBoundary(teeth=ex, sides=ex)
    opts = ThermalOptions(mode="steady")
    prob = ThermalProblem(
        dom, mat, HeatSources(volumetric_W_m3=P / vol), bnd, opts, petsc_options_prefix="ext_"
    )
    prob.solve_steady()
    theta = (-h0 + math.sqrt(h0**2 + 4 * c * P / area)) / (2 * c)  # c theta^2 + h0 theta - P/A = 0
    assert prob.temperatures_K()["mean_bulk"] - amb == pytest.approx(theta, rel=1e-4)


def test_hysteresis_source_uses_local_temperature():
    """Uniform U_max, lumped body held at steady state by convection: q = H(T) U f with T the
    solution,
    so P = H(T_ss) U f V = h A (T_ss - Ta) (solved by bisection on the table)."""
    dom, mat, vol, area = _lumped_box()
    H = TemperatureTable.from_celsius([20.0, 100.0, 140.0], [0.002, 0.004, 0.04], "H")
    U, f, h = 5.0e5, 50.0, 20.0
    Q = fem.functionspace(dom.mesh, ("DG", 0))
    u = fem.Function(Q)
    u.x.array[:] = U
    opts = ThermalOptions(h_teeth_W_m2K=h, h_sides_W_m2K=h, emissivity=0.0, mode="steady")
    src = HeatSources(u_max=u, loading_frequency_Hz=f, hysteresis=H)
    prob = ThermalProblem(
        dom,
        mat,
        src,
        ThermalBoundary.from_options(opts, mat, 0.0, None),
        opts,
        petsc_options_prefix="hyst_",
    )
    prob.solve_steady()
    T_ss = brentq(
        lambda T: H(T) * U * f * vol - h * area * (T - TA), TA, TA + 50.0
    )  # the lower root
    assert prob.temperatures_K()["mean_bulk"] == pytest.approx(T_ss, abs=1e-3)


def test_lumped_estimate_equals_high_conductivity_steady_state():
    """With k -> large the steady FE solution is uniform and solves the same scalar balance as the
    one-node estimate used for plausibility checks (convection + radiation)."""
    from gearfem.thermal.lumped import lumped_estimate

    dom, mat, vol, _area = _lumped_box()
    P = 2.0
    opts = ThermalOptions(h_teeth_W_m2K=20.0, h_sides_W_m2K=30.0, mode="steady")
    prob = ThermalProblem(
        dom,
        mat,
        HeatSources(volumetric_W_m3=P / vol),
        ThermalBoundary.from_options(opts, mat, 0.0, None),
        opts,
        petsc_options_prefix="lumpest_",
    )
    rec = prob.solve_steady()
    est = lumped_estimate(prob, rec.balance.generated_W)
    assert est["area_teeth_m2"] == pytest.approx(4 * 0.02 * 0.01) and est[
        "area_sides_m2"
    ] == pytest.approx(8e-4)
    assert rec.temperatures_K["mean_bulk"] - TA == pytest.approx(est["theta_ss_K"], rel=1e-3)
    assert est["tau_s"] == pytest.approx(
        mat.density_kg_m3 * mat.specific_heat_J_kgK * vol * est["theta_ss_K"] / P
    )


def test_newton_failure_raises_convergence_error():
    """A Newton budget too small for the radiation nonlinearity fails with the reason and the
    time."""
    from gearfem.core.errors import ConvergenceError

    dom, mat, _vol, _area = _lumped_box()
    opts = ThermalOptions(
        convection="none",
        emissivity=0.9,
        initial_C=500.0,
        duration_s=10.0,
        time_stepping="fixed",
        dt_initial_s=5.0,
        newton_max_it=1,
        newton_rtol=1e-14,
        newton_atol_W=1e-14,
    )
    prob = ThermalProblem(
        dom,
        mat,
        HeatSources(),
        ThermalBoundary.from_options(opts, mat, 0.0, None),
        opts,
        petsc_options_prefix="fail_",
    )
    with pytest.raises(ConvergenceError) as err:
        prob.integrate()
    assert "DIVERGED_MAX_IT" in err.value.reason and "t = 5 s" in err.value.step


def test_flux_function_with_temperature_factor_lumped_steady():
    """Flux given as a Function (the cycle stage's form) times a factor 1 - c (T - Ta) (the
    mu(T)/mu_ref
    hook), on a lumped body: P0 (1 - c theta) = h A theta, so theta = P0 / (h A + c P0)."""
    dom, mat, _vol, area = _lumped_box()
    h, q0, c = 25.0, 2000.0, 0.004
    flux = fem.Function(fem.functionspace(dom.mesh, ("Lagrange", 1)))
    flux.x.array[:] = q0
    opts = ThermalOptions(h_teeth_W_m2K=h, h_sides_W_m2K=h, emissivity=0.0, mode="steady")
    src = HeatSources(
        flank_flux_W_m2=flux,
        flux_surfaces=("outer",),
        flux_temperature_factor=lambda T: 1.0 - c * (T - TA),
    )
    prob = ThermalProblem(
        dom,
        mat,
        src,
        ThermalBoundary.from_options(opts, mat, 0.0, None),
        opts,
        petsc_options_prefix="fluxfn_",
    )
    rec = prob.solve_steady()
    P0 = q0 * 4 * 0.02 * 0.01  # the 'outer' faces
    theta = P0 / (h * area + c * P0)
    assert rec.temperatures_K["mean_bulk"] - TA == pytest.approx(theta, rel=1e-4)
    assert rec.balance.friction_W == pytest.approx(P0 * (1 - c * theta), rel=1e-4)
