"""The contact tangent at one contact point against finite differences: what gearfem's tangent
leaves out, and the terms that make it consistent (gearfem.contact.tangent, not yet assembled by
the interface).

One slave point on a curved P2 slave facet and its closest-point foot ζ on a curved P2 master facet
(two sphere patches with randomly perturbed nodes; a gap of 0.1 mm with a multiplier that keeps
the point active), the point residual of gearfem.contact.interface (augmented-Lagrangian
pressure p = <λ − ε g>, frozen slip direction re-projected onto the current tangent plane,
Coulomb friction)

    r = −W p [N_s ⊗ d ; −N_m(ζ) ⊗ d],   d = n − μ ŝ(n),

is differentiated over the 36 nodal coordinates by central differences and compared with

* gearfem's tangent  W ε s_p ρ γᵀ  (ρ = [N_s ⊗ d; −N_m ⊗ d], γ = [N_s ⊗ n; −N_m ⊗ n]): the normal,
  the foot ζ and ŝ frozen;
* that tangent plus the geometric terms of the closest-point linearisation (Wriggers,
  *Computational Contact Mechanics*, ch. 4): the foot's motion from the stationarity condition
  (x − x_m(ζ))·τ_α = 0, with A = m − g b (m the facet metric, b its curvature along n),

      A Δζ = τ_α·(N_s Δx_s − N_m Δx_m) + g n·N_m,α Δx_m,
      Δn   = −τ_β m^{βα} (n·N_m,α Δx_m + b_αγ Δζ^γ),
      Δd   = (I − μ ∂ŝ/∂n) Δn,

  entering the residual as −W p [N_s ⊗ Δd; −N_m ⊗ Δd − N_m,α ⊗ d Δζ^α].

The gap's own derivative needs no geometric term (at a closest point Δg = n·(Δx_s − N_m Δx_m)), and
the weight W is the reference area. The P2 shape functions and the projection are gearfem's own
(:class:`gearfem.core.facets.FacetReference`, :func:`gearfem.contact.kinematics.project`).

Purpose: verification (why the contact Newton converges linearly, and the size of what is left
out: of order 3 p / E per iteration on the gears). Runs in a second:

    python benchmarks/verification/contact_tangent_check.py

Writes: no documentation block (prints; docs/contact.md "Tangent" quotes it).
"""

from __future__ import annotations

import basix
import numpy as np

import gearfem  # noqa: F401  (must precede dolfinx/petsc4py)

# isort: split

from gearfem.contact import tangent
from gearfem.contact.kinematics import project
from gearfem.contact.tangent import PointGeometry
from gearfem.core.facets import FacetReference

REF = FacetReference.create(basix.CellType.tetrahedron, 2)
#: P2 triangle nodes in the reference facet (basix order: vertices, then edges).
REF_NODES = np.asarray(REF.element.points, dtype=np.float64)
#: The point's data: weight (m²), penalty (Pa/m), multiplier (Pa), friction coefficient, the
#: frozen slip direction, the slave point's reference coordinates.
W, EPS, LAM, MU = 0.7, 1.0e3, 0.5, 0.3
S0 = np.array([0.8, 0.6, 0.0])
XI_S = np.array([[0.3, 0.25]])
ORIENT = -1.0  # the master normal points towards the slave (−z)


def sphere_patch(center_z: float, sign: float, shift, size=0.01, radius=0.05) -> np.ndarray:
    """A P2 facet's nodes on a sphere of ``radius`` (a bowl for sign +1, a cap for −1)."""
    p = REF_NODES * size + shift
    z = center_z + sign * (radius - np.sqrt(radius**2 - (p**2).sum(axis=1)))
    return np.column_stack([p, z])


def point_state(x: np.ndarray) -> dict:
    """The point's residual and kinematics at nodal coordinates ``x`` (12, 3): slave, master."""
    xs_nodes, xm_nodes = x[:6], x[6:]
    ns = REF.tabulate(XI_S, 0)[0, 0]
    xs = ns @ xs_nodes
    zeta, _ = project(REF, xm_nodes[None], xs[None], np.array([[0.3, 0.3]]), 40, 1e-15)
    tab = REF.tabulate(zeta, 2)[:, 0]  # value, d1, d2, d11, d12, d22 (6, 6)
    nm, dn, d2n = tab[0], tab[1:3], tab[3:6]
    xm, tau = nm @ xm_nodes, dn @ xm_nodes
    c = np.cross(tau[0], tau[1])
    n = ORIENT * c / np.linalg.norm(c)
    g = (xs - xm) @ n
    st = S0 - (S0 @ n) * n
    s_hat = np.linalg.norm(S0) * st / np.linalg.norm(st)
    d = n - MU * s_hat
    p = max(LAM - EPS * g, 0.0)
    r = np.concatenate([-W * p * ns[:, None] * d, W * p * nm[:, None] * d]).ravel()
    return dict(r=r, ns=ns, nm=nm, dn=dn, d2n=d2n, tau=tau, n=n, g=g, p=p, d=d, st=st,
                s_hat=s_hat, xm_nodes=xm_nodes, zeta=zeta[0])  # fmt: skip


def frozen_tangent(s: dict) -> np.ndarray:
    """gearfem's tangent W ε ρ γᵀ (active point, s_p = 1)."""
    rho = np.concatenate([s["ns"][:, None] * s["d"], -s["nm"][:, None] * s["d"]]).ravel()
    gam = np.concatenate([s["ns"][:, None] * s["n"], -s["nm"][:, None] * s["n"]]).ravel()
    return W * EPS * np.outer(rho, gam)


def geometric_tangent(s: dict) -> np.ndarray:
    """The terms the frozen tangent leaves out (module docstring), (36, 36): gearfem's
    :func:`gearfem.contact.tangent.geometric_tangent` at this point."""
    x_ab = s["d2n"] @ s["xm_nodes"]  # x_m,11 x_m,12 x_m,22
    n = s["n"]
    b = np.array([[x_ab[0] @ n, x_ab[1] @ n], [x_ab[1] @ n, x_ab[2] @ n]])
    geo = PointGeometry(
        Ns=s["ns"][None],
        Nm=s["nm"][None],
        dNm=s["dn"][None],
        tau=s["tau"][None],
        curvature=b[None],
        normal=n[None],
        gap=np.array([s["g"]]),
    )
    u, v = tangent.geometric_tangent(geo, np.array([W * s["p"]]), s["d"][None], MU, S0[None])
    return u[0] @ v[0].T


def main() -> None:
    rng = np.random.default_rng(1)
    xm = sphere_patch(0.0, 1.0, np.array([-0.003, -0.004]))
    xs = sphere_patch(-2e-5, -1.0, np.array([-0.004, -0.003]))
    x0 = np.concatenate([xs, xm]) + 2e-4 * rng.standard_normal((12, 3))
    s = point_state(x0)
    h = 1e-7
    k_fd = np.zeros((36, 36))
    for j in range(36):
        e = np.zeros(36)
        e[j] = h
        e = e.reshape(12, 3)
        k_fd[:, j] = (point_state(x0 + e)["r"] - point_state(x0 - e)["r"]) / (2 * h)
    k0, kg = frozen_tangent(s), geometric_tangent(s)
    norm = np.linalg.norm(k_fd)
    print(f"gap {s['g']:.3e} m, pressure {s['p']:.3e} Pa, foot ζ = {np.round(s['zeta'], 3)}")
    err0, err1 = (np.linalg.norm(k_fd - k) / norm for k in (k0, k0 + kg))
    print(f"relative error of the frozen tangent           {err0:.2e}")
    print(f"relative error with the geometric terms added  {err1:.2e}")
    rank = np.linalg.matrix_rank(kg, tol=1e-10 * np.linalg.norm(kg))
    print(
        f"|K_geo| / |K_frozen| {np.linalg.norm(kg) / np.linalg.norm(k0):.2e}, rank of K_geo {rank}"
    )


if __name__ == "__main__":
    main()
