"""The geometric part of the contact tangent: how the closest point, the normal and the frozen slip
direction move with the facets' nodes.

At a contact point of the two-pass GPTS contact (:mod:`gearfem.contact.interface`) the residual of
the slave facet's nodes I and the master facet's nodes J is

    r = −W p [N_s^I d ; −N_m^J(ζ) d],   d = n − μ ŝ(n),   p = ⟨λ − ε g⟩,   g = (x − x_m(ζ))·n,

with x = N_s x_s at fixed slave coordinates, ζ the closest point of x on the curved master facet
((x − x_m(ζ))·τ_α = 0, τ_α = ∂x_m/∂ζ_α), n its unit normal and ŝ = |s₀| s_t/|s_t|,
s_t = s₀ − (s₀·n) n, the frozen slip direction kept in the current tangent plane. The interface
assembles W ε s_p ρ γᵀ, the part through the gap (exact: at the foot Δg = n·(Δx − N_m Δx_m)).
The rest of the exact linearisation is

    Δr_geo = −W p [N_s ⊗ Δd ; −N_m ⊗ Δd] + W p [0 ; N_m,α ⊗ d] Δζ^α,

with, from the foot condition and n·n = 1 (m_αβ = τ_α·τ_β, b_αβ = n·∂²x_m/∂ζ_α∂ζ_β,
A = m − g b):

    A Δζ = τ·(N_s Δx_s − N_m Δx_m) + g n·N_m,α Δx_m,      Δn = −τ_β m^βα (n·N_m,α Δx_m + b_αγ Δζ^γ),
    Δd = (I − μ ∂ŝ/∂n) Δn,   ∂ŝ/∂n = (|s₀|/|s_t|)(I − ŝŝᵀ/|s₀|²)(−(s₀·n) I − n s₀ᵀ).

Per point this is a matrix of rank at most 4, returned as factors U Vᵀ over the point's
coordinates [slave nodes; master nodes] (3 per node, node-major): U's columns
−W p ρ(e_β) (β = 1, 2, e_β = (I − μ ∂ŝ/∂n) τ_β, ρ(v) = [N_s ⊗ v ; −N_m ⊗ v]) and
W p [0 ; N_m,α ⊗ d] (α = 1, 2); V's columns the rows of Δn's and Δζ's Jacobians. For μ = 0 and
fixed λ the residual is the gradient of Σ W ⟨λ − εg⟩²/(2ε), and the full tangent is symmetric.
The standard closest-point linearisation (Wriggers, Computational Contact Mechanics, ch. 4).

In the body frames of the interface (x = R u + ...): rows of U are taken times R_bᵀ and columns
of V times R_b, blockwise per body, and both are masked where the interface masks ρ and γ.

Numpy only; verified against central finite differences of the residual built from
:mod:`gearfem.contact.kinematics` (tests/test_contact_tangent.py).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from gearfem.core.errors import ParameterError


@dataclasses.dataclass(frozen=True)
class PointGeometry:
    """What the geometric tangent needs at n contact points (one slave facet of ``ns`` nodes and
    one master facet of ``nm`` nodes each).

    Attributes:
        Ns: (n, ns) slave shape functions at the point.
        Nm: (n, nm) master shape functions at the foot ζ.
        dNm: (n, 2, nm) their derivatives ∂N_m/∂ζ_α.
        tau: (n, 2, 3) the master tangents τ_α = ∂x_m/∂ζ_α at ζ.
        curvature: (n, 2, 2) b_αβ = n·∂²x_m/∂ζ_α∂ζ_β.
        normal: (n, 3) the master's unit normal at ζ.
        gap: (n,) g = (x − x_m)·n.
    """

    Ns: np.ndarray
    Nm: np.ndarray
    dNm: np.ndarray
    tau: np.ndarray
    curvature: np.ndarray
    normal: np.ndarray
    gap: np.ndarray


def projection_jacobians(geo: PointGeometry) -> tuple[np.ndarray, np.ndarray]:
    """(J_ζ, G), each (n, 2, 3 (ns + nm)): Δζ^α = J_ζ^α Δx and Δn = τ_β G^β Δx for the point's
    coordinates Δx = [Δx_s; Δx_m] (node-major, 3 per node)."""
    n = len(geo.gap)
    ns = geo.Ns.shape[1]
    tau, nrm, g = geo.tau, geo.normal, geo.gap
    metric = np.einsum("pad,pbd->pab", tau, tau)
    A = metric - g[:, None, None] * geo.curvature
    # ∂F_α/∂x of the foot condition F_α = (x − x_m(ζ))·τ_α(ζ) at fixed ζ
    dF = np.zeros((n, 2, ns + geo.Nm.shape[1], 3))
    dF[:, :, :ns] = geo.Ns[:, None, :, None] * tau[:, :, None, :]
    dF[:, :, ns:] = (
        -geo.Nm[:, None, :, None] * tau[:, :, None, :]
        + g[:, None, None, None] * geo.dNm[:, :, :, None] * nrm[:, None, None, :]
    )
    Jz = np.linalg.solve(A, dF.reshape(n, 2, -1))
    # n·∂τ_α/∂x at fixed ζ (master nodes only)
    ndtau = np.zeros_like(dF)
    ndtau[:, :, ns:] = geo.dNm[:, :, :, None] * nrm[:, None, None, :]
    G = -np.linalg.solve(metric, ndtau.reshape(n, 2, -1) + geo.curvature @ Jz)
    return Jz, G


def frozen_slip_jacobian(frozen: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """∂ŝ/∂n (n, 3, 3) of the frozen slip direction ŝ = |s₀| s_t/|s_t|, s_t = s₀ − (s₀·n) n
    (zero where s_t vanishes, as ŝ does)."""
    mag = np.linalg.norm(frozen, axis=1)
    sn = np.einsum("pd,pd->p", frozen, normal)
    st = frozen - sn[:, None] * normal
    nst = np.linalg.norm(st, axis=1)
    ok = (nst > 0.0) & (mag > 0.0)
    safe_nst = np.where(ok, nst, 1.0)
    safe_mag = np.where(ok, mag, 1.0)
    s_hat = st * (mag / safe_nst)[:, None]
    eye = np.eye(3)[None]
    dsh_dst = (mag / safe_nst)[:, None, None] * (
        eye - np.einsum("pi,pj->pij", s_hat, s_hat) / (safe_mag**2)[:, None, None]
    )
    dst_dn = -sn[:, None, None] * eye - np.einsum("pi,pj->pij", normal, frozen)
    return np.where(ok[:, None, None], dsh_dst @ dst_dn, 0.0)


def _direction_tangents(geo: PointGeometry, mu: float | np.ndarray, frozen_slip: np.ndarray | None):
    """e_β = (I − μ ∂ŝ/∂n) τ_β (n, 2, 3): Δd = e_β G^β Δx (μ one value or one per point)."""
    proj = np.broadcast_to(np.eye(3), (len(geo.gap), 3, 3))
    mu = np.asarray(mu, dtype=float)
    if frozen_slip is not None and np.any(mu != 0.0):
        proj = proj - np.reshape(mu, (-1, 1, 1)) * frozen_slip_jacobian(frozen_slip, geo.normal)
    return np.einsum("pij,paj->pai", proj, geo.tau)


def geometric_tangent(
    geo: PointGeometry,
    weight_pressure: np.ndarray,
    direction: np.ndarray,
    mu: float | np.ndarray,
    frozen_slip: np.ndarray | None,
) -> tuple[np.ndarray, np.ndarray]:
    """Factors (U, V), each (n, 3 (ns + nm), 4), of the points' geometric tangents K_geo = U Vᵀ
    (module docstring): the derivative of the residual r = −W p ρ(d) through ζ, n and ŝ(n). V's
    first two columns are Δn's rows G^β, the last two Δζ's.

    Args:
        geo: The points' geometry.
        weight_pressure: (n,) W p (zero off contact: no term).
        direction: (n, 3) d = n − μ ŝ.
        mu: Friction coefficient (one value, or one per point).
        frozen_slip: (n, 3) the frozen s₀ (None: frictionless, or ŝ not a function of n).
    """
    U, V, _ = geometric_factors(geo, weight_pressure, direction, mu, frozen_slip)
    return U, V


def geometric_factors(geo, weight_pressure, direction, mu, frozen_slip):
    """(U, V) of :func:`geometric_tangent` and the e_β (n, 2, 3) they were made with."""
    n = len(geo.gap)
    ns, nm = geo.Ns.shape[1], geo.Nm.shape[1]
    Jz, G = projection_jacobians(geo)
    e = _direction_tangents(geo, mu, frozen_slip)
    wp = weight_pressure[:, None, None]
    U = np.zeros((n, ns + nm, 3, 4))
    # −W p ρ(e_β): slave rows N_s e_β, master rows −N_m e_β
    U[:, :ns, :, :2] = -wp[..., None] * geo.Ns[:, :, None, None] * np.moveaxis(e, 1, 2)[:, None]
    U[:, ns:, :, :2] = wp[..., None] * geo.Nm[:, :, None, None] * np.moveaxis(e, 1, 2)[:, None]
    # W p [0 ; N_m,α ⊗ d]
    U[:, ns:, :, 2:] = (
        wp[..., None] * np.moveaxis(geo.dNm, 1, 2)[:, :, None, :] * direction[:, None, :, None]
    )
    V = np.concatenate([G, Jz], axis=1)  # (n, 4, 3 (ns + nm))
    return U.reshape(n, -1, 4), np.moveaxis(V, 1, 2), e


def torque_border(
    geo: PointGeometry,
    weight_pressure: np.ndarray,
    direction: np.ndarray,
    mu: float | np.ndarray,
    frozen_slip: np.ndarray | None,
    residual: np.ndarray,
    nodes: np.ndarray,
    point: np.ndarray,
    axis: np.ndarray,
    centre: np.ndarray,
    controlled: str,
    factors: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The geometric parts of the torque border of a body turning by ψ about ``axis`` through
    ``centre`` (the interface's ``rotation_terms``), per point, in the global frame.

    The body's nodes move by v = a × (x − c) δψ (``controlled``: "slave" or "master", the pass's
    role of the body), its residual rows are R_cᵀ r, and the moment about its axis is
    M = Σ W p m, m = ±a·((x − c) × d) (+ for the slave; x the slave point). Beside the parts
    through the pressure (W ε ρ β, W ε m γ, W ε m β) the derivatives hold

        ∂R_u/∂ψ:   U (Vᵀ v) − a × r   (the latter on the body's own nodes: its frame turns),
        ∂(−M)/∂x:  −W p (±)[(d × a)·N_s Δx_s + (a × (x − c))·Δd],
        ∂(−M)/∂ψ:  the same applied to v.

    Args:
        geo, weight_pressure, direction, mu, frozen_slip: as :func:`geometric_tangent`.
        residual: (n, 3 (ns + nm)) the point's residual r = −W p ρ(d) in the global frame.
        nodes: (n, ns + nm, 3) the current positions of the point's nodes (slave, then master).
        point: (n, 3) the slave point x.
        axis: (3,) the unit rotation axis a; centre: (3,) a point c on it.
        factors: (U, V, e) of these points as :func:`geometric_factors` returns them, when the
            caller has them already (the interface assembles the displacement block first).

    Returns:
        (k_up, k_pu) each (n, 3 (ns + nm)), and k_pp (n,).
    """
    if controlled not in ("slave", "master"):
        raise ParameterError("controlled", controlled, "'slave' or 'master'")
    n = len(geo.gap)
    ns, nm = geo.Ns.shape[1], geo.Nm.shape[1]
    a = np.asarray(axis, dtype=np.float64)
    sign = 1.0 if controlled == "slave" else -1.0
    own = slice(0, ns) if controlled == "slave" else slice(ns, ns + nm)
    v = np.zeros((n, ns + nm, 3))
    v[:, own] = np.cross(a, nodes[:, own] - centre)
    v = v.reshape(n, -1)
    U, V, e = factors or geometric_factors(geo, weight_pressure, direction, mu, frozen_slip)
    k_up = np.einsum("pmc,pc->pm", U, np.einsum("pmc,pm->pc", V, v))
    frame = np.zeros((n, ns + nm, 3))
    frame[:, own] = -np.cross(a, residual.reshape(n, ns + nm, 3)[:, own])
    k_up = k_up + frame.reshape(n, -1)
    # ∂m/∂x: the lever arm (the slave point) and the direction d (through ζ, n and ŝ):
    # Δd = e_β G^β Δx, G^β the first two columns of V
    lever = np.cross(a, point - centre)  # a × (x − c): (a × (x − c))·Δd = Δd·lever
    dm = np.einsum("pa,pma->pm", np.einsum("pd,pad->pa", lever, e), V[:, :, :2])
    dm_lever = np.zeros((n, ns + nm, 3))
    dm_lever[:, :ns] = geo.Ns[:, :, None] * np.cross(direction, a)[:, None, :]
    dm = sign * (dm + dm_lever.reshape(n, -1))
    k_pu = -weight_pressure[:, None] * dm
    k_pp = np.einsum("pm,pm->p", k_pu, v)
    return k_up, k_pu, k_pp


__all__ = [
    "PointGeometry",
    "frozen_slip_jacobian",
    "geometric_factors",
    "geometric_tangent",
    "projection_jacobians",
    "torque_border",
]
