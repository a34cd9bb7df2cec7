"""The structural cycle with a friction coefficient per contact (``[friction] cycle_mu = "law"``,
:mod:`gearfem.cycle.friction_field`): the field's lookup and key, the cycle's tractions and
friction power with the field's mu at every point, and the cycle ↔ heat fixed point of a law whose
mu differs between contacts."""

from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

from gearfem import pipeline
from gearfem.config import Case
from gearfem.contact.friction import FrictionOptions
from gearfem.cycle.friction_field import FrictionField
from gearfem.cycle.history import ContactHistory
from gearfem.cycle.solve import solve_cycle
from gearfem.instruments.options import TorqueMeterOptions
from gearfem.instruments.snapshot import CycleTorques
from gearfem.instruments.torque import read_torque

sys.path.insert(0, str(Path(__file__).parent))
from test_cycle import _case, _model  # the cycle tests' small pair
from test_cycle_mu import _out, _small_steady

STEP = 1e-4


def _history(points) -> ContactHistory:
    """A contact history of the given (position, body, band, x, y, z, pressure) points, every
    point of unit area and dissipation speed."""
    a = np.array(points, dtype=float)
    n = len(a)
    ones = np.ones(n)
    return ContactHistory(
        position=a[:, 0].astype(np.int64),
        body=a[:, 1].astype(np.int64),
        facet=np.arange(n),
        xi=np.zeros((n, 2)),
        point_m=a[:, 3:6],
        weight_m2=ones,
        pass_weight=0.5 * ones,
        pressure_Pa=a[:, 6],
        slip_speed_m_s=ones,
        dissipation_speed_m_s=ones,
        rolling_speed_m_s=ones,
        mate_rolling_speed_m_s=ones,
        tooth=np.zeros(n, dtype=np.int64),
        band=a[:, 2].astype(np.int64),
        half_width_m=ones,
        load_per_length_N_m=ones,
        hertz_half_width_m=ones,
        z_bin_m=0.01,
    )


CENTRES = {"pinion": np.zeros(3), "wheel": np.array([0.06, 0.0, 0.0])}
# position 0: two pinion bands (r 28-29 mm and 31-32 mm, slice 0) and one in slice 1; a wheel band
POINTS = [
    (0, 0, 0, 0.028, 0.0, 0.001, 1.0),
    (0, 0, 0, 0.029, 0.0, 0.002, 3.0),
    (0, 0, 1, 0.031, 0.0, 0.001, 1.0),
    (0, 0, 1, 0.032, 0.0, 0.002, 1.0),
    (0, 0, 2, 0.030, 0.0, 0.015, 2.0),
    (0, 1, 3, 0.06 - 0.030, 0.0, 0.001, 2.0),
    (1, 0, 4, 0.030, 0.0, 0.001, 4.0),
]


def _field(mu=(0.2, 0.4, 0.3, 0.5, 0.25)) -> FrictionField:
    return FrictionField.from_bands(_history(POINTS), CENTRES, np.arange(5), np.array(mu), STEP)


def test_a_contact_takes_the_mu_of_the_nearest_band_of_its_slice():
    f = _field()
    # the spans and heats from the points (heat: pressure x area x speed x pass weight)
    assert f.radius_m[0] == pytest.approx((0.028 * 1 + 0.029 * 3) / 4)  # heat-weighted
    np.testing.assert_allclose(f.heat, [2.0, 1.0, 1.0, 1.0, 2.0])
    assert f.mean == pytest.approx((2 * 0.2 + 0.4 + 0.3 + 0.5 + 2 * 0.25) / 7)
    z0, z1 = 0.005, 0.015
    # the nearest band's radius (28.75 and 31.5 mm), beyond them; slice 1 has its own band
    got = f.at(0, "pinion", np.array([0.0285, 0.0299, 0.0302, 0.040, 0.0285]), [z0] * 4 + [z1])
    np.testing.assert_allclose(got, [0.2, 0.2, 0.4, 0.4, 0.3])
    # a slice without a band of its own takes the nearest band of any slice
    assert f.at(0, "pinion", np.array([0.0312]), np.array([0.035]))[0] == 0.4
    # each gear's pass its own bands; a position without bands the field's mean
    assert f.at(0, "wheel", np.array([0.028]), np.array([z0]))[0] == 0.5
    assert f.at(1, "wheel", np.array([0.028]), np.array([z0]))[0] == pytest.approx(f.mean)
    assert f.at(1, "pinion", np.array([0.020]), np.array([z0]))[0] == 0.25


def test_the_fields_key_and_change_follow_its_rounded_mu():
    f = _field()
    # mu on the step's grid: a change below half a step is the same field and key
    same = _field((0.2 + 0.3 * STEP, 0.4, 0.3, 0.5, 0.25))
    assert same.mu[0] == 0.2 and same.digest() == f.digest()
    moved = _field((0.2 + STEP, 0.4, 0.3, 0.5, 0.25))
    assert moved.digest() != f.digest()
    # the change from the mu a cycle had at each band: from one mu, and from another field
    # heat-weighted mean and largest move: from one mu, and from another field
    heat = np.array([2.0, 1.0, 1.0, 1.0, 2.0])
    moves = np.abs(np.array([0.2, 0.4, 0.3, 0.5, 0.25]) - 0.3)
    assert f.change_from(0.3) == pytest.approx((np.sum(heat * moves) / 7, 0.2))
    assert moved.change_from(f) == pytest.approx((2 * STEP / 7, STEP))
    # bands below the heat share do not count in the largest: band 3 (0.5, heat 1) against 2
    assert f.change_from(0.2, heat_share=0.75)[1] == pytest.approx(0.05)
    # stored and read back
    back = FrictionField.from_arrays(f.arrays(), f.z_bin_m, f.step)
    assert back.digest() == f.digest()
    # a cycle solved with a field is another cycle than the one-mu cycle and than another field's
    case = Case()
    keys = {pipeline.case_cycle_key(case, friction_field=g) for g in (None, f, moved)}
    assert len(keys) == 3
    assert pipeline.case_cycle_key(case, friction_field=same) == pipeline.case_cycle_key(
        case, friction_field=f
    )


def test_bad_fields_are_refused_by_name():
    from gearfem.core.errors import ParameterError

    h = _history(POINTS)
    with pytest.raises(ParameterError, match="friction field mu"):
        FrictionField.from_bands(h, CENTRES, np.arange(5), np.array([0.2, -0.1, 0, 0, 0]), STEP)
    with pytest.raises(ParameterError, match="friction field band"):
        FrictionField.from_bands(h, CENTRES, np.array([7]), np.array([0.2]), STEP)
    with pytest.raises(ParameterError, match="friction field"):
        FrictionField.from_bands(h, CENTRES, np.arange(5), np.array([0.2]), STEP)


#: Positions of the cycle with a field of one mu compared with the constant cycle: the first
#: ones of the loaded cycle (its angles, from a model solved from rest as well), in single and
#: double contact; equal to round-off position by position, so the whole cycle adds no check.
UNIFORM_POSITIONS = 3


@pytest.fixture(scope="module")
def cycles():
    """The cycle tests' loaded cycle (8 N m, mu 0.5); its first :data:`UNIFORM_POSITIONS`
    positions again with a field of 0.5 at every band; and the whole cycle with the pinion's pass
    at 0.2, the wheel's at 0.4."""
    case = _case(8.0, 0.5)
    constant = pipeline.cycle(case, MPI.COMM_WORLD)[0]  # cached: test_cycle.py's fixture loaded
    h = constant.history
    bands = np.unique(h.band)
    body = np.zeros(len(bands), dtype=np.int64)
    body[np.searchsorted(bands, h.band)] = h.body
    centres = {b: np.asarray(v) for b, v in constant.info["centres_m"].items()}

    def field(mu_pinion, mu_wheel):
        mu = np.where(body == 0, mu_pinion, mu_wheel)
        return FrictionField.from_bands(h, centres, bands, mu, STEP)

    uniform = solve_cycle(
        _model(case),
        pitches=UNIFORM_POSITIONS / case.cycle.positions_per_pitch,
        check_periodicity=False,
        friction_field=field(0.5, 0.5),
    )
    model = _model(case)
    split = solve_cycle(model, friction_field=field(0.2, 0.4))
    return constant, uniform, split, model


@pytest.mark.slow
def test_a_field_of_one_mu_is_the_constant_cycle(cycles):
    constant, uniform, _, _ = cycles
    assert len(uniform.te_m) == UNIFORM_POSITIONS
    first = slice(0, UNIFORM_POSITIONS)
    for name in ("te_m", "pinion_torque_Nm", "friction_power_W_per_rad_s", "p_max_Pa"):
        np.testing.assert_allclose(
            getattr(uniform, name),
            getattr(constant, name)[first],
            rtol=1e-12,
            atol=0.0,
            err_msg=name,
        )
    assert uniform.friction_field is not None and constant.friction_field is None


@pytest.mark.slow
def test_each_pass_takes_its_fields_mu_and_the_energy_balances(cycles):
    """The pinion's pass at 0.2 and the wheel's at 0.4: every contact point of the last position
    carries its pass's mu, and the torque loss is the friction power of those mu (the energy
    balance of the cycle tests, 1.5 % at 12 positions), between the cycles at one mu."""
    constant, _, split, model = cycles
    for ps, pts in zip(model.interface.passes, model.problem.last_points[0]):
        want = 0.2 if ps.slave.body == "pinion" else 0.4
        assert pts.num_points and np.all(pts.mu == want), ps.slave.body
    r = read_torque(TorqueMeterOptions(), CycleTorques.of(split), 1000.0)
    assert r.friction_power_W == pytest.approx(r.cycle_friction_power_W, rel=0.015)
    # two passes of weight 1/2: about the friction power of one mu of 0.3, well below 0.5's
    ratio = split.mean_friction_power_W_per_rad_s() / constant.mean_friction_power_W_per_rad_s()
    assert 0.5 < ratio < 0.7, ratio


@pytest.mark.slow
def test_the_mean_mu_of_a_field_cycle_weights_each_pass_by_its_heat(cycles):
    """The constant mu that dissipates a field cycle's friction power is the mean of the passes'
    0.2 and 0.4 weighted by each pass's heat per unit mu, ∫ p ŝ·v_T dA from the contact history,
    not the cycle's fallback mu (0.5, contacts without a band); one mu: that mu."""
    constant, _, split, _ = cycles
    assert constant.mean_friction_coefficient() == constant.friction_coefficient == 0.5
    h = split.history
    w = h.pressure_Pa * h.dissipation_speed_m_s * h.weight_m2 * h.pass_weight
    w_pinion, w_wheel = float(np.sum(w[h.of("pinion")])), float(np.sum(w[h.of("wheel")]))
    want = (0.2 * w_pinion + 0.4 * w_wheel) / (w_pinion + w_wheel)
    assert split.friction_coefficient == 0.5
    assert split.mean_friction_coefficient() == pytest.approx(want, rel=1e-9)
    assert 0.25 < want < 0.35, want  # both passes carry heat


@pytest.mark.slow
def test_a_law_whose_mu_differs_between_contacts_reaches_its_fixed_point(tmp_path_factory):
    """mu falling with the contact temperature (0.5 at 20 C to 0.2 at 200 C): the contacts run at
    different temperatures, so the law's mu differs between bands; the loop stops when it moves
    by less than the tolerance at every loaded band, where the cycle's friction power is the
    law's (each contact at the law's mu), with mu still spread over the bands: no one-mu cycle
    (``cycle_mu = "effective"``, tests/test_cycle_mu.py) dissipates it contact by contact."""
    comm = MPI.COMM_WORLD
    base = _small_steady()
    law = FrictionOptions(law="table", table_C=((20.0, 200.0), (0.5, 0.2)), cycle_mu="law")
    got = pipeline.run(
        dataclasses.replace(base, friction=law), _out(comm, tmp_path_factory, "f"), comm,
        progress=False,
    )  # fmt: skip
    loop = got.cycle_mu
    assert loop is not None and 2 <= len(loop.passes) <= law.cycle_mu_max_passes
    last = loop.passes[-1]
    assert last.field_change < law.cycle_mu_tolerance <= loop.passes[0].field_change
    lo, hi = last.mu_band_range
    assert 0.2 <= lo < hi - 0.01 and hi <= 0.5, (lo, hi)
    # at the fixed point the cycle dissipates what the law does, contact by contact
    assert last.friction_power_law_W == pytest.approx(last.friction_power_cycle_W, rel=0.02)
    # the law's effective mu is read against the field's heat-weighted mean mu, not the fallback
    for p in loop.passes[1:]:
        assert 0.2 <= p.mu_cycle_mean <= 0.5, p.mu_cycle_mean  # the law's range
        assert p.mu_effective == pytest.approx(
            p.mu_cycle_mean * p.friction_power_law_W / p.friction_power_cycle_W, rel=1e-12
        )
    assert loop.passes[0].mu_cycle_mean == loop.passes[0].mu_cycle == 0.5
    assert last.mu_effective == pytest.approx(last.mu_cycle_mean, rel=0.02)
