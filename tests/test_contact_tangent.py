"""The geometric contact tangent (gearfem.contact.tangent) against finite differences.

One contact point between a curved P2 slave facet and a curved P2 master facet (patches of two
spheres of radius 50 mm, 10 mm facets, nodes perturbed by 0.2 mm), the residual
r = −W p [N_s d ; −N_m(ζ) d] built from the solver's own kinematics (closest-point projection,
tangents, unit normal), p = ⟨λ − εg⟩ with λ fixed, d = n − μ ŝ with a frozen slip direction.
The interface's tangent today is the part through the gap, W ε ρ γᵀ; with the geometric part the
tangent is the derivative of the residual to the finite differences' accuracy, and symmetric
without friction.
"""

from __future__ import annotations

import dataclasses

import basix
import numpy as np
import pytest
import scipy.sparse as sp
from mpi4py import MPI

from gearfem.contact.kinematics import evaluate, project, unit_normal
from gearfem.contact.options import ContactOptions
from gearfem.contact.rigid import RigidMotion
from gearfem.contact.tangent import PointGeometry, frozen_slip_jacobian, geometric_tangent
from gearfem.contact.verification import hertz_case
from gearfem.core.facets import FacetReference

REF = FacetReference.create(basix.CellType.tetrahedron, 2)
#: The P2 triangle's nodes on the reference facet, in the element's order.
NODES_REF = np.asarray(REF.element.points, dtype=np.float64)
H, RADIUS = 0.01, 0.05
W, EPS, LAM = 0.7, 1e3, 0.5


def _patch(centre_z: float, sign: float, shift, rng) -> np.ndarray:
    p = NODES_REF * H + np.asarray(shift)
    z = centre_z + sign * (RADIUS - np.sqrt(RADIUS**2 - (p**2).sum(axis=1)))
    return np.column_stack([p, z]) + 2e-4 * rng.standard_normal((len(p), 3))


def _state(coords: np.ndarray, xi_s: np.ndarray, s0: np.ndarray, mu: float):
    """Residual and geometry of the point at xi_s for nodal coordinates [slave; master]."""
    ns = len(NODES_REF)
    xs_nodes, xm_nodes = coords[:ns], coords[ns:]
    x, _, _, Ns = evaluate(REF, xs_nodes[None], xi_s[None])
    zeta, _ = project(REF, xm_nodes[None], x, np.array([[0.3, 0.3]]), iterations=60, tol=1e-15)
    xm, t1, t2, Nm, (x11, x12, x22) = evaluate(REF, xm_nodes[None], zeta, derivatives=2)
    normal, _ = unit_normal(t1, t2, np.array([-1.0]))  # the master faces the slave (-z)
    gap = np.einsum("pd,pd->p", x - xm, normal)
    n = normal[0]
    st = s0 - (s0 @ n) * n
    s_hat = np.linalg.norm(s0) * st / np.linalg.norm(st)
    d = n - mu * s_hat
    p = max(LAM - EPS * gap[0], 0.0)
    r = np.concatenate([-W * p * Ns[0][:, None] * d, W * p * Nm[0][:, None] * d]).ravel()
    dN = REF.tabulate(zeta, 1)[1:3, 0]  # (2, nn)
    tau = np.stack([t1[0], t2[0]])
    b = np.array([[x11[0] @ n, x12[0] @ n], [x12[0] @ n, x22[0] @ n]])
    geo = PointGeometry(
        Ns=Ns,
        Nm=Nm,
        dNm=dN[None],
        tau=tau[None],
        curvature=b[None],
        normal=normal,
        gap=gap,
    )
    return r, geo, p, d


def _rho(Ns, Nm, v):
    return np.concatenate([Ns[:, None] * v, -Nm[:, None] * v]).ravel()


@pytest.mark.parametrize("mu", [0.0, 0.3])
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_geometric_tangent_is_the_derivative_of_the_residual(mu, seed):
    rng = np.random.default_rng(seed)
    master = _patch(0.0, 1.0, (-0.003, -0.004), rng)  # a bowl z >= 0
    slave = _patch(-2e-5, -1.0, (-0.004, -0.003), rng)  # a cap just below it
    coords = np.concatenate([slave, master])
    xi_s = np.array([0.3, 0.25]) + 0.1 * rng.random(2)
    s0 = np.array([0.8, 0.6, 0.0])
    _, geo, p, d = _state(coords, xi_s, s0, mu)
    assert p > 0.0  # in contact: the pressure's slope is eps
    Ns, Nm, n = geo.Ns[0], geo.Nm[0], geo.normal[0]
    frozen = W * EPS * np.outer(_rho(Ns, Nm, d), _rho(Ns, Nm, n))
    U, V = geometric_tangent(geo, np.array([W * p]), d[None], mu, s0[None])
    geometric = U[0] @ V[0].T
    assert np.linalg.matrix_rank(geometric, tol=1e-10 * np.linalg.norm(geometric)) <= 4
    step = 1e-7
    fd = np.zeros((coords.size, coords.size))
    for j in range(coords.size):
        e = np.zeros(coords.size)
        e[j] = step
        plus = _state(coords + e.reshape(coords.shape), xi_s, s0, mu)[0]
        minus = _state(coords - e.reshape(coords.shape), xi_s, s0, mu)[0]
        fd[:, j] = (plus - minus) / (2.0 * step)
    scale = np.linalg.norm(fd)
    # the gap-only tangent misses a part of the derivative; with the geometric part it is exact
    assert np.linalg.norm(fd - frozen) / scale > 1e-2
    assert np.linalg.norm(fd - frozen - geometric) / scale < 1e-7
    if mu == 0.0:
        full = frozen + geometric
        assert np.linalg.norm(full - full.T) / np.linalg.norm(full) < 1e-9


def test_frozen_slip_jacobian():
    """∂ŝ/∂n against finite differences, and zero without a frozen direction."""
    rng = np.random.default_rng(0)
    s0 = rng.standard_normal((4, 3))
    n = rng.standard_normal((4, 3))
    n /= np.linalg.norm(n, axis=1)[:, None]

    def s_hat(nv):
        st = s0 - np.einsum("pd,pd->p", s0, nv)[:, None] * nv
        return st * (np.linalg.norm(s0, axis=1) / np.linalg.norm(st, axis=1))[:, None]

    J = frozen_slip_jacobian(s0, n)
    for k in range(3):
        e = np.zeros(3)
        e[k] = 1e-7
        fd = (s_hat(n + e) - s_hat(n - e)) / 2e-7
        assert np.allclose(J[:, :, k], fd, rtol=1e-6, atol=1e-7)
    assert np.all(frozen_slip_jacobian(np.zeros_like(n), n) == 0.0)


def test_torque_border_names_a_bad_role():
    from gearfem.contact.tangent import torque_border
    from gearfem.core.errors import ParameterError

    with pytest.raises(
        ParameterError, match=r"^controlled = 'wheel' is not allowed; allowed: 'slave' or 'master'"
    ):
        torque_border(*[None] * 10, "wheel")


def _rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    a = axis / np.linalg.norm(axis)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


@pytest.mark.parametrize("controlled", ["slave", "master"])
@pytest.mark.parametrize("mu", [0.0, 0.3])
def test_torque_border_is_the_derivative_in_the_rotation(controlled, mu):
    """One body of the point turns by ψ about an axis: its nodes move by a × (x − c) δψ, its
    residual rows are R(ψ)ᵀ r, and the moment about the axis is W p m, m = ±a·((x − c) × d).
    The pressure's parts (W ε ρ β, W ε m γ, W ε m β, as ``rotation_terms``) plus
    :func:`torque_border`'s are the derivatives of these in ψ and in the nodes."""
    from gearfem.contact.tangent import torque_border

    rng = np.random.default_rng(7)
    master = _patch(0.0, 1.0, (-0.003, -0.004), rng)
    slave = _patch(-2e-5, -1.0, (-0.004, -0.003), rng)
    coords = np.concatenate([slave, master])
    ns = len(NODES_REF)
    own = slice(0, ns) if controlled == "slave" else slice(ns, None)
    sign = 1.0 if controlled == "slave" else -1.0
    xi_s = np.array([0.3, 0.3])
    s0 = np.array([0.8, 0.6, 0.0])
    axis = np.array([0.3, 1.0, 0.2])
    axis /= np.linalg.norm(axis)
    centre = np.array([0.02, -0.01, 0.03])

    def turned(psi):
        c = coords.copy()
        c[own] = centre + (c[own] - centre) @ _rotation(axis, psi).T
        return c

    def body_residual(psi):
        r = _state(turned(psi), xi_s, s0, mu)[0].reshape(-1, 3).copy()
        r[own] = r[own] @ _rotation(axis, psi)  # R(ψ)ᵀ r, row vectors
        return r.ravel()

    def moment(c):
        _, geo, p, d = _state(c, xi_s, s0, mu)
        x = geo.Ns[0] @ c[:ns]
        return W * p * sign * axis @ np.cross(x - centre, d)

    _, geo, p, d = _state(coords, xi_s, s0, mu)
    Ns, Nm, n = geo.Ns[0], geo.Nm[0], geo.normal[0]
    x = Ns @ coords[:ns]
    r = _state(coords, xi_s, s0, mu)[0]
    rho, gam = _rho(Ns, Nm, d), _rho(Ns, Nm, n)
    v = np.zeros_like(coords)
    v[own] = np.cross(axis, coords[own] - centre)
    beta = gam @ v.ravel()
    m = sign * axis @ np.cross(x - centre, d)
    k_up, k_pu, k_pp = torque_border(
        geo, np.array([W * p]), d[None], mu, s0[None], r[None], coords[None], x[None], axis,
        centre, controlled,
    )  # fmt: skip
    step = 1e-7
    fd_up = (body_residual(step) - body_residual(-step)) / (2 * step)
    want = W * EPS * rho * beta + k_up[0]
    assert np.linalg.norm(fd_up - want) < 1e-6 * np.linalg.norm(fd_up)
    assert np.linalg.norm(fd_up - W * EPS * rho * beta) > 1e-3 * np.linalg.norm(fd_up)
    fd_pu = np.zeros(coords.size)
    for j in range(coords.size):
        e = np.zeros(coords.size)
        e[j] = step
        fd_pu[j] = -(
            moment(coords + e.reshape(coords.shape)) - moment(coords - e.reshape(coords.shape))
        ) / (2 * step)
    assert np.linalg.norm(fd_pu - (W * EPS * m * gam + k_pu[0])) < 1e-6 * np.linalg.norm(fd_pu)
    fd_pp = -(moment(turned(step)) - moment(turned(-step))) / (2 * step)
    assert fd_pp == pytest.approx(W * EPS * m * beta + k_pp[0], rel=1e-6)


def _assembled(itf, u, motions, matrix):
    """The interface's residual (dense, by dof) and, with ``matrix``, its tangent (sparse) at
    displacement ``u``: the segmentation, the multipliers and the frozen slip directions held."""
    pts = itf.evaluate(u, motions)
    (rd, rv), coo = itf.assemble(pts, motions, matrix)
    r = np.zeros(len(u))
    np.add.at(r, rd, rv)
    if not matrix:
        return r, None
    rows, cols, vals = coo
    return r, sp.csr_matrix((vals, (rows, cols)), shape=(len(u), len(u)))


#: The upper Hertz cylinder's motion: turning about its own axis (as the gear cycle holds the
#: wheel); at the contact it slides along +x, so with friction it freezes slip directions.
TURN = RigidMotion(center=(0.0, 1.0, 0.0), axis=(0.0, 0.0, 1.0), angular_velocity_rad_s=1.0)


@pytest.fixture(scope="module", params=[0.0, 0.3], ids=["mu0", "mu0.3"])
def solved_hertz(request):
    """The Hertz pair of curved P2 cylinders after a solve with the upper one turning (active
    contact, multipliers from the augmented Lagrangian), for each friction coefficient: one solve
    shared by the tangent's and the torque border's checks, which only evaluate the interface at
    (perturbations of) its displacement. Returns (mu, case, displacement)."""
    mu = request.param
    opts = ContactOptions(search_distance_rel=2.0, friction_coefficient=mu, geometric_tangent=True)
    case = hertz_case(MPI.COMM_SELF, opts, contact_size=0.02)
    case.problem.motions["upper"] = TURN
    case.problem.solve("tangent check")
    return mu, case, case.problem.u.x.array.copy()


def test_the_assembled_tangent_is_the_derivative_of_the_assembled_residual(solved_hertz):
    """On the solved Hertz pair, the interface's tangent with the geometric part is the central
    finite difference of its residual in the contact dofs (the bodies' frames, the dofs the
    boundary conditions fix left out); without it, it is off by the normal's and the foot's
    variation (with friction, the sliding upper cylinder freezes its slip directions)."""
    _, case, u0 = solved_hertz
    itf, motions = case.problem.interfaces[0], case.problem.motions
    _, K = _assembled(itf, u0, motions, True)
    itf_frozen = dataclasses.replace(itf.options, geometric_tangent=False)
    itf.options, saved = itf_frozen, itf.options
    _, K0 = _assembled(itf, u0, motions, True)
    itf.options = saved
    contact = np.unique(K.nonzero()[1])
    rng = np.random.default_rng(0)
    h = 1e-7 * np.abs(u0).max()
    err, err0 = [], []
    for j in rng.choice(contact, size=min(24, len(contact)), replace=False):
        e = np.zeros_like(u0)
        e[j] = h
        rp, _ = _assembled(itf, u0 + e, motions, False)
        rm, _ = _assembled(itf, u0 - e, motions, False)
        fd = (rp - rm) / (2 * h)
        scale = np.linalg.norm(fd)
        err.append(np.linalg.norm(K[:, j].toarray().ravel() - fd) / scale)
        err0.append(np.linalg.norm(K0[:, j].toarray().ravel() - fd) / scale)
    assert max(err) < 1e-5, max(err)
    assert max(err0) > 100 * max(err)  # the geometric part is what closes the gap


def _dense(n: int, dofs: np.ndarray, vals: np.ndarray) -> np.ndarray:
    out = np.zeros(n)
    np.add.at(out, dofs, vals)
    return out


def test_the_assembled_torque_border_is_the_derivative_in_the_rotation(solved_hertz):
    """The solved Hertz pair's upper cylinder turned by ψ about its own axis:
    ``rotation_terms``' ∂R_u/∂ψ, ∂(−M)/∂u and ∂(−M)/∂ψ with the geometric parts are the central
    finite differences of the assembled residual and of the contact moment; without them they
    are not."""
    _, case, u0 = solved_hertz
    itf, motions = case.problem.interfaces[0], dict(case.problem.motions)
    n = len(u0)
    psi0, d_psi = 2e-3, 1e-7
    at = lambda psi: {**motions, "upper": TURN.rotated(psi)}

    def terms(u, psi, geometric=True):
        saved = itf.options
        itf.options = dataclasses.replace(saved, geometric_tangent=geometric)
        try:
            return itf.rotation_terms(itf.evaluate(u, at(psi)), at(psi), "upper")
        finally:
            itf.options = saved

    def residual(u, psi):
        return _assembled(itf, u, at(psi), False)[0]

    fd_up = (residual(u0, psi0 + d_psi) - residual(u0, psi0 - d_psi)) / (2 * d_psi)
    fd_pp = -(terms(u0, psi0 + d_psi)[0] - terms(u0, psi0 - d_psi)[0]) / (2 * d_psi)
    rng = np.random.default_rng(1)
    _, kpp, (d1, v1), (d2, v2) = terms(u0, psi0)
    _, _, (e1, w1), (e2, w2) = terms(u0, psi0, geometric=False)
    k_up, k_pu = _dense(n, d1, v1), _dense(n, d2, v2)
    k_up0, k_pu0 = _dense(n, e1, w1), _dense(n, e2, w2)
    # the free dofs of the contact points (the fixed ones carry no entries by design)
    cols = rng.choice(np.unique(e2[w2 != 0.0]), size=24, replace=False)
    h = 1e-5 * np.abs(u0).max()  # the moment's differences: round-off 1e-16 M / h
    fd_pu = np.zeros(len(cols))
    for i, j in enumerate(cols):
        e = np.zeros_like(u0)
        e[j] = h
        fd_pu[i] = -(terms(u0 + e, psi0)[0] - terms(u0 - e, psi0)[0]) / (2 * h)
    rel = lambda a, b: np.linalg.norm(a - b) / np.linalg.norm(b)
    assert rel(k_up, fd_up) < 1e-5 and rel(k_pu[cols], fd_pu) < 1e-5
    assert kpp == pytest.approx(fd_pp, rel=1e-5)
    assert rel(k_up0, fd_up) > 1e-3 and rel(k_pu0[cols], fd_pu) > 1e-3
