"""Contact output helpers: the gathered point table and the Hertz pressure profile."""

from __future__ import annotations

import math

import numpy as np
import pytest
from mpi4py import MPI
from scipy.integrate import quad

from gearfem.contact import ContactOptions
from gearfem.contact.output import gather_points, summary
from gearfem.contact.verification import block_case, hertz_line_contact, hertz_pressure


def test_hertz_pressure_is_the_ellipse_carrying_the_force():
    """∫ p dx over the contact equals the force per length P' (Johnson eq. 4.41/4.43), p = 0
    outside."""
    P, R, E, nu = 1.7e3, 0.02, 3.8e9, 0.4
    a, p0 = hertz_line_contact(P, R, R, E, nu, E, nu)
    integral, _ = quad(lambda x: float(hertz_pressure(x, a, p0)), -a, a)
    assert integral == pytest.approx(P, rel=1e-9)
    assert hertz_pressure(np.array([0.0, 0.5 * a, a, 1.5 * a, -2 * a]), a, p0) == pytest.approx(
        [p0, p0 * math.sqrt(0.75), 0.0, 0.0, 0.0], rel=1e-14, abs=0.0
    )


@pytest.mark.mpi
def test_gathered_points_carry_the_contact_force_and_agree_on_1_and_2_ranks(distinct_comms):
    """Sliding block (μ = 0.3, gross slip): the table's forces equal the interface totals, its shear
    is μ p and tangential, and the serial and parallel tables agree row by row."""
    mu = 0.3
    opts = ContactOptions(method="penalty", penalty_Pa_m=100.0, friction_coefficient=mu)
    tables = []
    for comm in distinct_comms:
        case = block_case(
            comm, opts, compression_m=1e-3, upper_velocity_m_s=(1.0, 0.0, 0.0), clamped=True
        )
        prob = case.problem
        prob.solve("sliding")
        t = gather_points(prob)
        n_local = sum(p.num_points for p in prob.last_points[0])
        assert t.num_points == comm.allreduce(n_local, op=MPI.SUM)
        assert t.slaves == ("lower_zmax", "upper_zmin")
        # force on surface a (the lower block): its slave traction (pass 0) minus pass 1's
        sign = np.where(t.pass_index == 0, 1.0, -1.0)[:, None]
        f_normal = np.sum(sign * (t.weight * t.pressure)[:, None] * t.normal, axis=0)
        f_shear = np.sum(sign * t.weight[:, None] * t.shear, axis=0)
        s = summary(prob)
        np.testing.assert_allclose(f_normal, s.normal_force_N, rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(f_shear, s.tangential_force_N, rtol=1e-12, atol=1e-15)
        on = t.pressure > 0.0
        np.testing.assert_allclose(
            np.linalg.norm(t.shear[on], axis=1), mu * t.pressure[on], rtol=1e-9
        )
        np.testing.assert_allclose(np.einsum("pd,pd->p", t.shear, t.normal), 0.0, atol=1e-15)
        # the interface is the plane z = 0 before deformation; the compressed blocks have moved
        np.testing.assert_allclose(t.x_reference[:, 2], 0.0, atol=1e-14)
        assert np.max(np.abs(t.x[:, 2] - t.x_reference[:, 2])) > 1e-4
        tables.append(t)
    serial, world = tables[0], tables[-1]
    assert world.num_points == serial.num_points
    np.testing.assert_array_equal(world.pass_index, serial.pass_index)
    np.testing.assert_allclose(world.x, serial.x, rtol=0, atol=1e-12)
    # weights are areas of the deformed facets: they carry the displacement gradients, which agree
    # between rank counts to the Newton tolerance (1e-10 measured), not to round-off
    np.testing.assert_allclose(world.weight, serial.weight, rtol=1e-9)
    np.testing.assert_allclose(world.pressure, serial.pressure, rtol=1e-8, atol=1e-14)
