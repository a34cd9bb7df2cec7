"""Friction laws, flash temperatures and several steady states (issue 15).

* laws: values, defaults (the cycle's constant mu), and bad laws refused by key;
* flash temperature: the exact moving band source against the published Jaeger/Blok values at
  high Peclet numbers and the small-argument expansion at low ones;
* the friction heat of a law recomputed from a contact history: exact on a uniform-pressure patch;
* a zero-dimensional body heated by mu(T) p v and cooled by h A (T - T_a) with the glass-transition
  law: gearfem's steady solver, stability and continuation find the analytic branches and turning
  points; CG meeting the indefinite Jacobian of the unstable branch switches to GMRES/LU.

The cycle-based checks (constant law = the cycle's flux, energy balance, 1 vs 2 ranks) are in
tests/test_cycle.py next to the cycle they use.
"""

from __future__ import annotations

import dataclasses
import math
import types

import numpy as np
import pytest
from dolfinx import fem
from mpi4py import MPI
from scipy.optimize import brentq
from thermal_meshes import box_domain

import gearfem.baselines as B
from gearfem.config import Case, case_from_dict, case_to_dict
from gearfem.contact.friction import FrictionOptions
from gearfem.core.errors import ConvergenceError, ParameterError
from gearfem.core.materials import ZERO_CELSIUS_K, Material
from gearfem.coupling.friction_heat import reference_flux, target_group_pairs
from gearfem.cycle.history import ContactHistory
from gearfem.thermal import HeatSources, ThermalBoundary, ThermalOptions, ThermalProblem
from gearfem.thermal.branches import continuation, steady_states
from gearfem.thermal.newton import Effort

C = ZERO_CELSIUS_K

# ---------------------------------------------------------------- laws


def test_default_law_is_the_cycles_constant_mu():
    law = FrictionOptions().law_for(0.5)
    T = np.array([250.0, 400.0, 700.0])
    np.testing.assert_array_equal(law.mu(T, 3e7, 1.0), 0.5)
    assert law.is_constant and not law.depends_on_temperature
    assert FrictionOptions().is_default and Case().friction_law().mu0 == 0.5
    assert FrictionOptions(mu=0.3).law_for(0.5).mu0 == 0.3


def test_law_values():
    g = FrictionOptions(
        law="glass_transition", mu_glassy=0.2, glass_transition_C=143.0, transition_width_K=5.0
    ).law_for(0.5)
    assert float(g.mu_of_T(143.0 + C)) == pytest.approx(0.35, rel=1e-14)  # s(0) = 1/2
    assert float(g.mu_of_T(143.0 + C - 50.0)) == pytest.approx(0.2, abs=1e-9)
    assert float(g.mu_of_T(143.0 + C + 50.0)) == pytest.approx(0.5, abs=1e-9)
    # 10-90 % of the step over 2 atanh(0.8) w = 2.197 w
    lo, hi = 143.0 + C - 5.0 * math.atanh(0.8), 143.0 + C + 5.0 * math.atanh(0.8)
    assert float(g.mu_of_T(lo)) == pytest.approx(0.2 + 0.3 * 0.1, rel=1e-12)
    assert float(g.mu_of_T(hi)) == pytest.approx(0.2 + 0.3 * 0.9, rel=1e-12)
    assert g.may_rise_with_temperature
    # derivative against a central difference
    T = np.linspace(100.0, 200.0, 21) + C
    fd = (g.mu_of_T(T + 1e-4) - g.mu_of_T(T - 1e-4)) / 2e-4
    np.testing.assert_allclose(g.dmu_of_T_dT(T), fd, rtol=1e-6, atol=1e-12)
    # tg default: the DMA value
    assert FrictionOptions(law="glass_transition", mu_glassy=0.2).law_for(0.5).tg_K == 143.0 + C
    # thesis pressure law: 0.55 at 20 MPa -> 0.42 at 70 MPa
    e = math.log(0.42 / 0.55) / math.log(70 / 20)
    p = FrictionOptions(
        mu=0.55, pressure="power", pressure_exponent=e, pressure_reference_MPa=20.0
    ).law_for(0.5)
    assert float(p.mu(300.0, 70e6, 1.0)) == pytest.approx(0.42, rel=1e-12)
    assert float(p.mu(300.0, 0.5e6, 1.0)) == float(p.mu(300.0, 1e6, 1.0))  # constant below range
    # table: linear, constant beyond
    t = FrictionOptions(law="table", table_C=((50.0, 75.0), (0.55, 0.40))).law_for(0.5)
    assert float(t.mu_of_T(62.5 + C)) == pytest.approx(0.475, rel=1e-12)
    assert float(t.mu_of_T(0.0 + C)) == 0.55 and float(t.mu_of_T(100.0 + C)) == 0.40
    assert not t.may_rise_with_temperature
    # products: speed factor times exponential temperature factor
    v = FrictionOptions(
        temperature_coefficient_per_K=0.01,
        sliding_speed="power",
        speed_exponent=0.05,
        speed_reference_m_s=0.1,
    ).law_for(0.5)
    assert float(v.mu(75.0 + C, 1e7, 1.0)) == pytest.approx(
        0.5 * math.exp(-0.5) * 10**0.05, rel=1e-12
    )


@pytest.mark.parametrize(
    "kw, key",
    [
        ({"mu": 2.5}, "friction.mu"),
        ({"law": "glass_transition", "mu_glassy": -0.1}, "friction.mu_glassy"),
        ({"law": "glass_transition", "mu_glassy": 0.2, "transition_width_K": 0.0}, "width_K"),
        ({"law": "glass_transition"}, "friction.mu_glassy"),
        ({"law": "table", "table_C": ((80.0, 60.0), (0.5, 0.4))}, "friction.table_C"),
        ({"law": "table", "table_C": ((60.0, 80.0), (0.5, 2.4))}, "friction.table_C"),
        ({"mu_glassy": 0.2}, "friction.mu_glassy"),  # a key of another law
        ({"pressure": "power", "pressure_exponent": -0.2}, "pressure_reference_MPa"),
        ({"temperature_coefficient_per_K": -0.01}, "temperature_coefficient_per_K"),  # mu > 2
        (
            {
                "pressure": "power",
                "pressure_exponent": -0.5,
                "pressure_reference_MPa": 100.0,
            },
            "friction.pressure",
        ),  # (1 MPa / 100 MPa)^-0.5 = 10: mu = 5
        ({"contact_temperature": "bulk"}, "friction.contact_temperature"),
        ({"flash_width": "stated"}, "friction.flash_half_width_um"),  # no width stated
        ({"flash_width": "stated", "flash_half_width_um": 0.5}, "friction.flash_half_width_um"),
        ({"flash_width": "stated", "flash_half_width_um": 6e3}, "friction.flash_half_width_um"),
        ({"flash_half_width_um": 100.0}, "friction.flash_half_width_um"),  # ignored by "hertz"
    ],
)
def test_bad_laws_name_the_key(kw, key):
    with pytest.raises(ParameterError) as err:
        Case(friction=FrictionOptions(**kw))
    assert key in err.value.name, (err.value.name, key)


def test_table_file_read_keyed_and_checked(tmp_path):
    f = tmp_path / "mu.csv"
    f.write_text("# PEEK-PEEK, thesis 4.3.5\ntemperature_C,mu\n25,0.55\n50,0.55\n75,0.40\n")
    case = Case(friction=FrictionOptions(law="table", table_file=str(f)))
    assert case.friction.table_C == ((25.0, 50.0, 75.0), (0.55, 0.55, 0.40))
    # the values are in the case (what the caches hash), and the file is checked against them
    back = case_from_dict(case_to_dict(case))
    assert back.friction == case.friction
    f.write_text("temperature_C,mu\n25,0.55\n50,0.50\n75,0.40\n")
    with pytest.raises(ParameterError, match="friction.table_C"):
        case_from_dict(case_to_dict(case))
    f.write_text("temperature_C,mu\n25,0.55\n75,0.50\n50,0.40\n")
    with pytest.raises(ParameterError, match="friction.table_file"):
        Case(friction=FrictionOptions(law="table", table_file=str(f)))


# ---------------------------------------------------------------- flash temperature


def test_band_source_high_peclet_limits_are_jaeger_and_blok():
    """k theta sqrt(L) / (q a) as L -> infinity: Jaeger's band source 1.596 (maximum) and 1.064
    (mean) in units of q sqrt(kappa a / V) / k, i.e. divided by sqrt(2); Blok's 1.11 for the
    semi-elliptic flux with the full width (here 1.1115, as the 1D Duhamel integral of
    tests/test_baselines.py)."""
    assert B.band_source_high_peclet("uniform") == pytest.approx(2 / math.sqrt(math.pi), rel=1e-9)
    assert B.band_source_high_peclet("uniform") == pytest.approx(1.596 / math.sqrt(2), rel=2e-4)
    assert B.band_source_high_peclet("uniform", "mean") == pytest.approx(
        1.064 / math.sqrt(2), rel=2e-4
    )
    assert B.band_source_high_peclet("semi_elliptic") == pytest.approx(1.1115, abs=5e-4)
    # the exact 2D solution tends to them
    for shape, ref in (("uniform", 2 / math.sqrt(math.pi)), ("semi_elliptic", 1.1115)):
        for L, tol in ((50.0, 0.02), (500.0, 0.002)):
            got = float(B.band_source_rise(L, shape)) * math.sqrt(L)
            assert got == pytest.approx(ref, rel=tol), (shape, L, got)
    # the 2D solution is below the 1D limit (heat also spreads along the surface) and grows to it
    L = np.logspace(-2, 3, 11)
    g = B.band_source_rise(L, "semi_elliptic") * np.sqrt(L)
    assert np.all(np.diff(g) > 0) and np.all(g < B.band_source_high_peclet("semi_elliptic"))


def test_band_source_low_peclet_limit():
    """As L -> 0 the uniform band's temperature follows K0's small-argument expansion:
    (2/pi)(1 - gamma + ln 2 - ln L) at the centre and (2/pi)(3/2 - gamma - ln L) on average."""
    for L in (1e-3, 3e-3):
        for which in ("max", "mean"):
            got = float(B.band_source_rise(L, "uniform", which))
            ref = B.band_source_low_peclet_uniform(L, which)
            assert got == pytest.approx(ref, rel=5 * L * math.log(1 / L)), (L, which)
    # and below the table the expansion is used directly
    assert float(B.band_source_rise(1e-5, "uniform")) == B.band_source_low_peclet_uniform(1e-5)
    assert B.peclet_regime(0.05) == "low" and B.peclet_regime(100.0) == "high"


@pytest.mark.slow
def test_shipped_band_table_is_the_computed_one():
    """gearfem/data/band_source_rise.npz holds what compute_band_table gives (after a change of
    the quadrature: gearfem.baselines.write_band_table() writes it again). To within a few units
    in the last place, not to the bit: the quadrature's sums round differently on another CPU
    (the table written on an Intel machine differs from one computed on an AMD EPYC in 1 ulp at
    a few entries), while any change of the quadrature itself moves entries by far more."""
    for shape in B.BAND_SHAPES:
        shipped, computed = B._band_table(shape), B.compute_band_table(shape)
        for a, b in zip(shipped, computed, strict=True):
            assert a.shape == b.shape, shape
            np.testing.assert_array_max_ulp(a, b, maxulp=4)
    with pytest.raises(ParameterError, match="band shape"):
        B._band_table("triangular")


def test_fast_band_integral_matches_adaptive_quadrature():
    for shape in ("uniform", "semi_elliptic"):
        for L in (2e-3, 0.7, 40.0):
            X = np.array([-0.9, -0.3, 0.2, 0.8])
            fast = B._band_surface_rise_fast(L, shape, X)
            slow = np.array([B._band_surface_rise(L, shape, x) for x in X])
            np.testing.assert_allclose(fast, slow, rtol=1e-6)


def test_blok_partition_at_high_peclet_is_bloks_formula():
    """theta = q a / (k1/g1 + k2/g2) with g = 1.1115/sqrt(L): Blok's theta_fl (eq. 2.5 form) with
    the form factor 1.1115."""
    m = Material()
    mu, w, a, v1, v2 = 0.5, 2e4, 3e-4, 2.0, 1.2
    kappa, k = m.thermal_diffusivity_m2_s, m.thermal_conductivity_W_mK
    L1, L2 = v1 * a / (2 * kappa), v2 * a / (2 * kappa)
    g1, g2 = (float(B.band_source_rise(L, "semi_elliptic")) for L in (L1, L2))
    q = mu * w / (2 * a) * abs(v1 - v2)
    theta = q * a / (k / g1 + k / g2)
    blok = float(
        B.blok_flash_temperature_K(
            mu, w, a, v1, v2, m.thermal_effusivity, m.thermal_effusivity, 1.1115
        )
    )
    assert theta == pytest.approx(blok, rel=2e-3)  # L ~ 2000: the 2D solution within 0.1 %


# ---------------------------------------------------------------- recomputed flux


def _patch_cycle(p0: float, v: float, n: int = 10, area: float = 1e-6):
    """A contact history of one flat facet under a uniform pressure p0, sliding at v (per unit
    pinion speed), one position, the revolution average over the whole turn."""
    z = np.zeros(n, dtype=np.int64)
    hist = ContactHistory(
        position=z,
        body=z,
        facet=z,
        xi=np.zeros((n, 2)),
        point_m=np.zeros((n, 3)),
        weight_m2=np.full(n, area / n),
        pass_weight=np.full(n, 0.5),
        pressure_Pa=np.full(n, p0),
        slip_speed_m_s=np.full(n, v),
        dissipation_speed_m_s=np.full(n, v),
        rolling_speed_m_s=np.full(n, 0.02),
        mate_rolling_speed_m_s=np.full(n, 0.01),
        tooth=z,
        band=z,
        half_width_m=np.full(n, 2e-4),
        load_per_length_N_m=np.full(n, p0 * 4e-4),
        hertz_half_width_m=np.full(n, 2e-4),
        z_bin_m=area / 4e-4,
    )
    fields = types.SimpleNamespace(
        facet_image_index=np.array([[0]]),
        facet_image_area_m2=np.array([[area]]),
        pitch_angle_rad=2 * math.pi,  # this gear's pitch: the pinion's (a ratio of 1)
    )
    return types.SimpleNamespace(
        history=hist,
        fields={"pinion": fields},
        pitch_angle_rad=2 * math.pi,
        phi_rad=np.zeros(1),
        info={"pinion_flank_heat_raw_over_total": 1.0},
    )


@pytest.mark.parametrize("p0_MPa", [5.0, 30.0, 70.0, 300.0])
def test_pressure_law_exact_on_a_uniform_patch(p0_MPa):
    p0, v, speed = p0_MPa * 1e6, 0.01, 1000.0
    omega = 2 * math.pi * speed / 60
    e = math.log(0.42 / 0.55) / math.log(70 / 20)
    opts = FrictionOptions(
        mu=0.55,
        pressure="power",
        pressure_exponent=e,
        pressure_reference_MPa=20.0,
        pressure_range_MPa=(10.0, 100.0),
    )
    law = opts.law_for(0.5)
    mats = {"pinion": Material(), "wheel": Material()}
    q, state, _bands = reference_flux(_patch_cycle(p0, v), "pinion", law, mats, speed, 300.0)
    pb = min(max(p0_MPa, 10.0), 100.0)
    mu = 0.55 * (pb / 20.0) ** e
    assert q[0] == pytest.approx(mu * p0 * v * omega, rel=1e-13)
    np.testing.assert_allclose(state.mu, mu, rtol=1e-13)
    # at the flank temperature only, a temperature-independent law has no flash dependence
    q2, _, _ = reference_flux(
        _patch_cycle(p0, v), "pinion", law, mats, speed, 500.0, contact_temperature="flank"
    )
    assert q2[0] == q[0]


# ---------------------------------------------------------------- several steady states (0-D)


class LumpedFriction:
    """A SurfaceFluxModel q = mu(T) p v on the surfaces ``outer`` of a box."""

    def __init__(self, dom, law, q0: float, declare_rising: bool = True) -> None:
        Q = fem.functionspace(dom.mesh, ("DG", 0))
        self.value, self.slope = fem.Function(Q), fem.Function(Q)
        self.surfaces = ("outer",)
        self.law, self.q0 = law, q0
        self.may_rise_with_temperature = declare_rising and law.may_rise_with_temperature

    def update(self, Tbar: np.ndarray) -> None:
        on = Tbar > 0
        self.value.x.array[:] = np.where(on, self.law.mu_of_T(Tbar) * self.q0, 0.0)
        self.slope.x.array[:] = np.where(on, self.law.dmu_of_T_dT(Tbar) * self.q0, 0.0)


H, Q0 = 25.0, 40000.0
AREA, AREA_F = 2 * 0.02 * 0.02 + 4 * 0.02 * 0.01, 4 * 0.02 * 0.01
TA = 296.15


def _lumped(declare_rising: bool = True, prefix: str = "zd_"):
    """A box of very high conductivity (Biot ~ 3e-5) heated on its four sides by mu(T) p v with
    the glass-transition law and cooled by h on all faces: h A (T - T_a) = s mu(T) q0 A_f."""
    dom = box_domain(MPI.COMM_WORLD, n=(2, 2, 2))
    mat = Material(thermal_conductivity_W_mK=1e4)
    law = FrictionOptions(
        law="glass_transition", mu_glassy=0.1, mu_rubbery=0.5, transition_width_K=5.0
    ).law_for(0.5)
    opts = ThermalOptions(
        h_teeth_W_m2K=H, h_sides_W_m2K=H, emissivity=0.0, mode="steady", degree=1,
        newton_atol_W=1e-9,
    )  # fmt: skip
    model = LumpedFriction(dom, law, Q0, declare_rising)
    bnd = ThermalBoundary.from_options(opts, mat, 0.0, None)
    prob = ThermalProblem(
        dom, mat, HeatSources(flank_flux_model=model), bnd, opts, petsc_options_prefix=prefix
    )
    return prob, law, mat


def _analytic(law):
    """The 0-D model: scale s(T) = h A (T - Ta) / (mu(T) q0 A_f); turning points where
    mu = (T - Ta) mu'(T); branches at s = 1."""

    def s(T):
        return H * AREA * (T - TA) / (float(law.mu_of_T(T)) * Q0 * AREA_F)

    def g(T):
        return float(law.mu_of_T(T)) - (T - TA) * float(law.dmu_of_T_dT(T))

    Ts = np.linspace(law.tg_K - 60, law.tg_K + 60, 2001)
    gs = [g(t) for t in Ts]
    folds = [brentq(g, Ts[i], Ts[i + 1], xtol=1e-12) for i in range(2000) if gs[i] * gs[i + 1] < 0]
    br = [
        brentq(lambda T: s(T) - 1.0, a, b, xtol=1e-12)
        for a, b in ((TA + 1, folds[0]), (folds[0], folds[1]), (folds[1], 3000.0))
    ]
    return [(s(f), f) for f in folds], br


def test_zero_dimensional_branches_stability_and_turning_points():
    prob, law, mat = _lumped()
    folds, branches = _analytic(law)
    assert len(folds) == 2 and len(branches) == 3  # an S-curve: three states at s = 1
    with prob:
        # Newton from a cold and a hot start finds the stable branches
        res = steady_states(prob, {"cold": TA, "hot": branches[2] + 50.0})
        assert all(r.converged and r.stable for r in res)
        for r, ref in zip(res, (branches[0], branches[2])):
            assert r.temperatures_C["mean_bulk"] + C == pytest.approx(ref, abs=2e-3)
        # the slowest time constant of a stable lumped state: C / (h A) (mu' ~ 0 there)
        cap = mat.density_kg_m3 * mat.specific_heat_J_kgK * 0.02 * 0.02 * 0.01
        assert res[0].eigenvalue_per_s == pytest.approx(H * AREA / cap, rel=1e-3)
        # continuation in the heat scale through both turning points finds all three
        prob.set_initial(TA)
        c = continuation(prob, 0.3, (0.2, 2.0), step=0.05, max_steps=2000, targets=(1.0,))
        assert len(c.turning_points) == 2
        for (s_fe, _), (s_ref, _) in zip(c.turning_points, sorted(folds, reverse=True)):
            assert s_fe == pytest.approx(s_ref, rel=1e-4)
        got = sorted(x.temperatures_C["mean_bulk"] + C for x in c.crossings)
        np.testing.assert_allclose(got, branches, atol=2e-3)
        stable = [
            x.stable for x in sorted(c.crossings, key=lambda x: x.temperatures_C["max_surface"])
        ]
        assert stable == [True, False, True]
        # the middle state: lambda = (h A - s mu'(T) q0 A_f) / C < 0
        mid = branches[1]
        lam = (H * AREA - float(law.dmu_of_T_dT(mid)) * Q0 * AREA_F) / cap
        middle = sorted(c.crossings, key=lambda x: x.temperatures_C["max_surface"])[1]
        assert middle.eigenvalue_per_s == pytest.approx(lam, rel=1e-3)


def test_cg_meeting_an_indefinite_jacobian_switches_to_gmres_lu():
    """A model that does not declare its heat may rise gets CG/Cholesky; at the unstable state
    the Jacobian is indefinite: the solver must switch (and converge), not fail."""
    prob, law, _ = _lumped(declare_rising=False, prefix="zd_cg_")
    _, branches = _analytic(law)
    with prob:
        assert prob._symmetric  # CG chosen a priori
        prob.set_initial(branches[1] + 0.01)
        rec = prob.solve_steady()
        assert rec.temperatures_K["mean_bulk"] == pytest.approx(branches[1], abs=2e-3)
        assert prob._steady_solver.switched_to_general
    prob2, _, _ = _lumped(prefix="zd_gm_")
    with prob2:
        assert not prob2._symmetric  # a law that may rise: GMRES/LU from the start


def test_flash_table_matches_the_volterra_solution():
    """The tabulated contact solution (bilinear in flank temperature and flash per unit mu) against
    the Volterra equation solved directly; a constant mu_T is reproduced exactly, and for it the
    largest flash temperature is theta0 mu (the band source's maximum)."""
    from gearfem.coupling.friction_heat import FlashTable, _profile

    law = FrictionOptions(law="glass_transition", mu_glassy=0.15).law_for(0.5)
    tab = FlashTable.build(law, 400.0)
    rng = np.random.default_rng(3)
    T = rng.uniform(300.0, 600.0, 400)
    th0 = rng.uniform(0.0, 400.0, 400)
    a, s = tab.weights(th0)
    mu, dmu, theta = tab.lookup(a, s, T)
    mu_ref, theta_ref = _profile(law, T, th0)
    assert np.max(np.abs(mu - mu_ref)) < 5e-3
    assert np.max(np.abs(theta - theta_ref)) < 0.01 * 400.0
    # mu rises with the flank temperature, and with the flash (heat feeds the glass transition)
    assert np.all(dmu >= -1e-12)
    lo = tab.lookup(*tab.weights(np.array([0.0])), np.array(400.0))[0]
    hi = tab.lookup(*tab.weights(np.array([200.0])), np.array(400.0))[0]
    assert float(hi[0]) > float(lo[0])
    const = FrictionOptions(mu=0.4, law="constant").law_for(0.5)
    m, t = _profile(const, np.full(3, 350.0), np.array([0.0, 50.0, 300.0]))
    np.testing.assert_allclose(m, 0.4, rtol=1e-14)
    np.testing.assert_allclose(t, 0.4 * np.array([0.0, 50.0, 300.0]), rtol=1e-12)


@pytest.mark.parametrize("dense", [True, False])
def test_target_group_pairs_are_numpys_unique(monkeypatch, dense):
    """The (target, group) pairs of the friction flux's instances, by the dense marking and by
    the sort it falls back to for many keys: np.unique of the keys with its inverse, exactly."""
    if not dense:
        monkeypatch.setattr("gearfem.coupling.friction_heat.DENSE_PAIR_KEYS", 0)
    rng = np.random.default_rng(5)
    nt, ng = 300, 40
    target = rng.integers(0, nt, 20000).astype(np.int32)
    group = rng.integers(0, ng, 20000)
    pair, pt, pg = target_group_pairs(target, group, nt, ng)
    unique, inverse = np.unique(target.astype(np.int64) * ng + group, return_inverse=True)
    np.testing.assert_array_equal(pair, inverse.ravel())
    np.testing.assert_array_equal(pt * ng + pg, unique)
    np.testing.assert_array_equal(pt[pair], target)
    np.testing.assert_array_equal(pg[pair], group)


def test_a_probes_effort_caps_newtons_work():
    """A steady solve given an Effort stops at its iterations with the solver's reason, one
    within it ends as without; an effort outside the solver's own is refused by name."""
    prob, law, _ = _lumped(prefix="zd_effort_")
    _, states = _analytic(law)
    with prob:
        prob.set_initial(TA)
        full = prob.solve_steady()
        its = full.newton_iterations
        assert its >= 2
        prob.set_initial(TA)
        with pytest.raises(ConvergenceError) as err:
            prob.solve_steady(Effort(max_it=its - 1))
        assert err.value.reason.startswith("DIVERGED_MAX_IT") and err.value.iteration == its - 1
        prob.set_initial(TA)
        capped = prob.solve_steady(Effort(max_it=its, max_halvings=10))
        assert capped.newton_iterations == its
        assert capped.temperatures_K["mean_bulk"] == pytest.approx(states[0], abs=2e-3)
    with pytest.raises(ParameterError, match="max_it"):
        Effort(max_it=0)
    with pytest.raises(ParameterError, match="max_halvings"):
        Effort(max_it=5, max_halvings=13)


def test_cool_branch_fold_brackets_the_turning_point():
    """The fold search (gearfem.thermal.branches.trace_lowest_branch) on the 0-D glass model:
    traced from a fifth of the heat, the cool branch ends at the analytic turning point (scale
    1.3089 at 130.2 C), which its bracket holds; in the ambient (the law's temperatures shifted,
    gearfem.diagnose.margins) the cool branch at full heat ends where the shifted law's turning
    point reaches scale 1."""
    from gearfem.diagnose.margins import _shifted
    from gearfem.thermal.branches import TOLERANCE, trace_lowest_branch

    prob, law, _ = _lumped(prefix="zd_fold_")
    folds, _ = _analytic(law)
    s_fold = max(s for s, _ in folds)  # the cool branch's end
    with prob:
        fold, x = trace_lowest_branch(prob, prob.set_friction_scale, 0.2, 3.0, 1.0)
        x.destroy()
        assert fold.cool < s_fold < fold.gone
        assert fold.gone - fold.cool <= 2 * TOLERANCE
        assert fold.fold == pytest.approx(s_fold, abs=TOLERANCE)
        # every temperature shifted by d: the law sees T + d, i.e. its transition moved down
        opts = FrictionOptions(
            law="glass_transition", mu_glassy=0.1, mu_rubbery=0.5, transition_width_K=5.0
        )
        model = prob.sources.flank_flux_model

        def shift(d):
            model.law = _shifted(opts, d).law_for(0.5)

        def cool_end_scale(d):
            sl = _shifted(opts, d).law_for(0.5)
            g = lambda T: float(sl.mu_of_T(T)) - (T - TA) * float(sl.dmu_of_T_dT(T))
            Ts = np.linspace(sl.tg_K - 60, sl.tg_K + 20, 4001)
            gs = [g(t) for t in Ts]
            T_f = next(brentq(g, Ts[i], Ts[i + 1]) for i in range(4000) if gs[i] * gs[i + 1] < 0)
            return H * AREA * (T_f - TA) / (float(sl.mu_of_T(T_f)) * Q0 * AREA_F)

        d_ref = brentq(lambda d: cool_end_scale(d) - 1.0, -20.0, 40.0, xtol=1e-9)
        shift(-20.0)
        prob.set_friction_scale(1.0)
        fold, x = trace_lowest_branch(prob, shift, -20.0, 60.0, 60.0)
        x.destroy()
        assert fold.cool < d_ref < fold.gone
        assert fold.fold == pytest.approx(d_ref, abs=TOLERANCE * 60.0)


def test_lowest_steady_state_is_where_the_transient_from_ambient_ends():
    """Without the transient (gearfem.thermal.branches.lowest_steady_state): on the 0-D glass
    model the lowest branch at the full heat is the cool state (103.0 C); with 1.5 times the heat,
    past the cool branch's fold at 1.3089, it is the hot one, which the transient from ambient
    reaches too."""
    from gearfem.thermal.branches import LOWEST_TOLERANCE, lowest_steady_state

    prob, law, _ = _lumped(prefix="zd_low_")
    folds, branches = _analytic(law)
    s_fold = max(s for s, _ in folds)
    model = prob.sources.flank_flux_model
    with prob:
        rec, how = lowest_steady_state(prob)
        assert how.branch == "lowest" and how.fold_scale is None
        assert rec.temperatures_K["mean_bulk"] == pytest.approx(branches[0], abs=2e-3)
        assert prob.friction_scale == 1.0
        model.q0 = 1.5 * Q0
        rec, how = lowest_steady_state(prob)
        assert how.branch == "above the fold"
        # the fold bracketed to LOWEST_TOLERANCE of the heat scale (the run-away's start)
        assert how.fold_scale * 1.5 == pytest.approx(s_fold, abs=LOWEST_TOLERANCE * 1.5)
        s_of = lambda T: H * AREA * (T - TA) / (float(law.mu_of_T(T)) * 1.5 * Q0 * AREA_F)
        hot = brentq(lambda T: s_of(T) - 1.0, branches[2] - 300.0, 3000.0)
        assert rec.temperatures_K["mean_bulk"] == pytest.approx(hot, abs=2e-3)
        prob.set_initial(TA)
        prob.integrate(duration_s=20000.0)
        assert prob.temperatures_K()["mean_bulk"] == pytest.approx(hot, abs=0.5)


def test_a_continuation_that_passed_a_fold_is_lowered_to_the_state_from_ambient(monkeypatch):
    """A continuation whose steps passed a small fold (a part of the contacts switching, the
    states a per cent apart in heat) ends above the state the transient reaches; the state Newton
    reaches from ambient, below it everywhere, is taken instead. Here the continuation is made to
    end on the 0-D model's hot state (423 C): the cool one (103.0 C) is returned."""
    from gearfem.thermal import branches as br

    prob, law, _ = _lumped(prefix="zd_lower_")
    _, states = _analytic(law)

    def ends_hot(problem, settle_s, max_settles):
        problem.set_initial(states[2] + 50.0)
        return problem.solve_steady(), br.LowestState("lowest", None, 1)

    monkeypatch.setattr(br, "_continued_lowest_state", ends_hot)
    with prob:
        rec, how = br.lowest_steady_state(prob)
        assert how.branch == "from ambient, below the continuation's" and how.solves == 2
        assert rec.temperatures_K["mean_bulk"] == pytest.approx(states[0], abs=2e-3)
        assert prob.temperatures_K()["mean_bulk"] == pytest.approx(states[0], abs=2e-3)
        # a continuation that ends on the state from ambient keeps it (and its label)
        monkeypatch.setattr(
            br,
            "_continued_lowest_state",
            lambda p, *a: (p.solve_steady(), br.LowestState("lowest", None, 1)),
        )
        rec, how = br.lowest_steady_state(prob)
        assert how.branch == "lowest" and how.solves == 3
        assert rec.temperatures_K["mean_bulk"] == pytest.approx(states[0], abs=2e-3)


def test_steady_runs_of_a_rising_law_take_the_lowest_steady_state(tmp_path):
    """``[thermal] mode = "steady"`` with a flux that may rise (gearfem.thermal.outputs): the
    run's steady state is the lowest one, not Newton's from the initial field, and the summary
    says how it was found."""
    from gearfem.thermal.outputs import solve_and_write

    prob, law, _ = _lumped(prefix="zd_sw_")
    _, branches = _analytic(law)
    with prob:
        prob.set_initial(branches[2] + 50.0)  # a hot initial field: Newton alone would stay hot
        records, summ = solve_and_write(prob, tmp_path, write_fields=False, write_plot=False)
    assert summ["steady_state_search"]["branch"] == "lowest"
    assert records[-1].temperatures_K["mean_bulk"] == pytest.approx(branches[0], abs=2e-3)


def test_the_cycle_mu_is_rounded_to_a_grid_inside_the_tolerance():
    """The "law" fixed point solves each cycle at the effective mu rounded to a fiftieth of the
    tolerance: two runs whose effective mu differs in round-off key the same cycle, and the
    rounding stays within half a step of the value."""
    f = FrictionOptions(law="glass_transition", mu_glassy=0.13, cycle_mu="law")
    assert f.cycle_mu_step == pytest.approx(1e-4)
    mu = 0.263758123
    assert f.rounded_cycle_mu(mu) == f.rounded_cycle_mu(mu + 1e-12) == 0.2638
    assert abs(f.rounded_cycle_mu(mu) - mu) <= 0.5 * f.cycle_mu_step
    assert f.rounded_cycle_mu(0.5) == 0.5
    coarse = dataclasses.replace(f, cycle_mu_tolerance=0.05)
    assert coarse.rounded_cycle_mu(mu) == 0.264
    # the band model is built (and checked) once per options
    assert f.band_model is f.band_model


def test_a_margin_in_a_parameter_whose_rise_cools_counts_the_other_way():
    """The fold margin in the stated flash half-width (gearfem.diagnose.margins): a wider contact
    runs cooler, so the cool branch is traced from the widest width down and the margin is the
    stated width minus the fold's. A fold at 145 um above a stated 100 um: the point lands hot
    (-45 um), fragile against ± 50 um, robust against ± 40 um; a fold at 60 um: lands cool
    (+40 um). A parameter whose rise heats counts fold minus value (the torque, mu_g)."""
    from gearfem.diagnose.margins import _margin
    from gearfem.thermal.branches import Fold

    point = (2000.0, 4.0, 21.0)
    at_145 = Fold(cool=150.0, gone=140.0, limit=33.3, solves=9)
    hot = _margin(point, "pinion", "flash half-width", "um", 100.0, at_145, 50.0, heat_falls=True)
    assert hot.fold == 145.0 and hot.margin == -45.0 and hot.lands == "hot" and hot.fragile
    robust = _margin(
        point, "pinion", "flash half-width", "um", 100.0, at_145, 40.0, heat_falls=True
    )
    assert not robust.fragile
    at_60 = Fold(cool=65.0, gone=55.0, limit=33.3, solves=9)
    cool = _margin(point, "wheel", "flash half-width", "um", 100.0, at_60, 50.0, heat_falls=True)
    assert cool.margin == 40.0 and cool.lands == "cool" and cool.fragile
    rises = _margin(point, "wheel", "torque", "N m", 4.0, Fold(5.0, 6.0, 12.0, 9), 0.04)
    assert rises.margin == 1.5 and rises.lands == "cool" and not rises.fragile
    # no fold within the range: cool over all of it (the branch reached the narrowest width)
    beyond = Fold(cool=33.3, gone=None, limit=33.3, solves=12)
    none = _margin(point, "wheel", "flash half-width", "um", 100.0, beyond, 50.0, heat_falls=True)
    assert none.margin is None and none.lands == "cool" and not none.fragile
