"""Vectorised facet kinematics: positions, tangents and normals on curved Lagrange facets,
closest-point projection, and segmentation of a slave facet by the master facets over it.

All functions work on batches: ``nodes`` has shape (n, n_nodes, 3) — the current coordinates of the
facet nodes belonging to each of the n evaluations — and ``xi`` has shape (n, 2).
"""

from __future__ import annotations

import numpy as np

from gearfem.core.facets import FacetReference


def evaluate(ref: FacetReference, nodes: np.ndarray, xi: np.ndarray, derivatives: int = 1):
    """Position and tangents ∂x/∂ξ₁, ∂x/∂ξ₂ (and second derivatives) at ``xi``.

    Returns:
        (x, t1, t2, N) with x, t1, t2 of shape (n, 3) and N (n, n_nodes) the shape functions; with
        ``derivatives=2`` also (x11, x12, x22).
    """
    tab = ref.tabulate(xi, derivatives)  # (nd, n, nn)
    out = [np.matmul(tab[i][:, None, :], nodes)[:, 0, :] for i in range(tab.shape[0])]
    if derivatives == 1:
        return out[0], out[1], out[2], tab[0]
    return out[0], out[1], out[2], tab[0], (out[3], out[4], out[5])


def unit_normal(
    t1: np.ndarray, t2: np.ndarray, orientation: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Outward unit normal and area scale |t1 × t2| (orientation ±1 per evaluation)."""
    c = np.cross(t1, t2)
    jac = np.linalg.norm(c, axis=1)
    return c * (orientation / jac)[:, None], jac


def power_coefficients(ref: FacetReference, nodes: np.ndarray) -> np.ndarray:
    """Coefficients (n_monomials, n, 3) of the facet maps ``nodes`` (n, n_nodes, 3) in the
    monomials of ``ref.power_exponents`` (monomial first: each row is a contiguous (n, 3))."""
    return np.tensordot(ref.power_basis, nodes, axes=([1], [1]))


def _power_terms(e: tuple[int, int], a: np.ndarray, b: np.ndarray, da: int, db: int):
    """∂^(da+db)/∂ξ₁^da ∂ξ₂^db of ξ₁^i ξ₂^j at (a, b), or None where it vanishes identically."""
    i, j = e
    if da > i or db > j:
        return None
    f = 1.0
    for k in range(da):
        f *= i - k
    for k in range(db):
        f *= j - k
    pi, pj = i - da, j - db
    out = None
    if pi:
        out = a**pi if pi > 1 else a
    if pj:
        bj = b**pj if pj > 1 else b
        out = bj if out is None else out * bj
    if out is None:
        return f  # a constant
    return out * f if f != 1.0 else out


def evaluate_power(
    ref: FacetReference, coef: np.ndarray, xi: np.ndarray, derivatives: int = 1
) -> tuple[np.ndarray, ...]:
    """Position and derivatives of facet maps given by their power coefficients (m, n, 3) at
    ``xi`` (n, 2): (x,) with ``derivatives=0``, (x, t1, t2) with 1, and with 2 also (x11, x12,
    x22), each (n, 3).

    The same values as :func:`evaluate` on the nodes (to round-off) at a fraction of the cost: a
    sum of a few scaled coefficient rows instead of a tabulation of every shape function and a
    batched product with the nodes (the closest-point iteration evaluates millions of points per
    meshing cycle)."""
    a, b = xi[:, 0:1], xi[:, 1:2]
    orders = [(0, 0)]
    if derivatives >= 1:
        orders += [(1, 0), (0, 1)]
    if derivatives == 2:
        orders += [(2, 0), (1, 1), (0, 2)]
    out = []
    for da, db in orders:
        acc = None
        for m, e in enumerate(ref.power_exponents):
            t = _power_terms((int(e[0]), int(e[1])), a, b, da, db)
            if t is None:
                continue
            term = coef[m] * t
            acc = term if acc is None else acc + term
        out.append(np.zeros((len(xi), 3)) if acc is None else acc)
    return tuple(out)


def project(
    ref: FacetReference,
    nodes: np.ndarray,
    x: np.ndarray,
    xi0: np.ndarray | None = None,
    iterations: int = 8,
    tol: float = 1e-7,
) -> tuple[np.ndarray, np.ndarray]:
    """Closest-point projection of points ``x`` (n, 3) onto the (extended) curved facets ``nodes``.

    Newton's method on the facet's reference coordinates for the stationarity condition
    (x_m(ξ) − x)·∂x_m/∂ξ_a = 0, with the full Hessian (second derivatives of the P2 map). The
    facet polynomial is used beyond the reference facet when the foot lies outside it; callers
    decide what to do with such points (``ref.inside``). The maps are evaluated from their power
    coefficients (:func:`evaluate_power`).

    Each point iterates until its own step is below ``tol`` (or ``iterations`` are done): points
    that have converged are not evaluated again. Newton converges quadratically here, so the step
    that falls below the default 1e-7 leaves an error of order its square, 1e-14 in reference
    coordinates: round-off, without the further steps a tolerance at round-off would spend.

    Returns:
        (xi, distance) with xi (n, 2) and the distance |x − x_m(ξ)|.
    """
    n = x.shape[0]
    if xi0 is None:
        xi = np.tile(ref.reference_polygon.mean(axis=0), (n, 1))
    else:
        xi = np.array(xi0, dtype=np.float64, copy=True)
    coef = power_coefficients(ref, nodes)
    todo = np.arange(n)
    for _ in range(iterations):
        if not len(todo):
            break
        c = coef[:, todo] if len(todo) < n else coef
        xm, t1, t2, x11, x12, x22 = evaluate_power(ref, c, xi[todo], derivatives=2)
        d = xm - x[todo]
        g0 = np.einsum("pd,pd->p", d, t1)
        g1 = np.einsum("pd,pd->p", d, t2)
        h11 = np.einsum("pd,pd->p", t1, t1) + np.einsum("pd,pd->p", d, x11)
        h12 = np.einsum("pd,pd->p", t1, t2) + np.einsum("pd,pd->p", d, x12)
        h22 = np.einsum("pd,pd->p", t2, t2) + np.einsum("pd,pd->p", d, x22)
        det = h11 * h22 - h12 * h12
        bad = np.abs(det) < 1e-30 * (h11 * h22 + 1e-300)
        det = np.where(bad, 1.0, det)
        step = np.empty((len(todo), 2))
        step[:, 0] = -(h22 * g0 - h12 * g1) / det
        step[:, 1] = -(-h12 * g0 + h11 * g1) / det
        step[bad] = 0.0
        np.clip(step, -0.5, 0.5, out=step)  # keep the iteration near the facet
        xi[todo] += step
        todo = todo[np.max(np.abs(step), axis=1) >= tol]
    xm = evaluate_power(ref, coef, xi, derivatives=0)[0]
    return xi, np.linalg.norm(x - xm, axis=1)


# ------------------------------------------------------------------------------------------------
# segmentation
# ------------------------------------------------------------------------------------------------


def _affine_coords(
    origin: np.ndarray, e1: np.ndarray, e2: np.ndarray, pts: np.ndarray
) -> np.ndarray:
    """Least-squares coordinates (a, b) with pts ≈ origin + a e1 + b e2; pts (P, k, 3) -> (P, k,
    2)."""
    g11 = np.einsum("pd,pd->p", e1, e1)
    g12 = np.einsum("pd,pd->p", e1, e2)
    g22 = np.einsum("pd,pd->p", e2, e2)
    det = g11 * g22 - g12 * g12
    r = pts - origin[:, None, :]
    b1 = np.einsum("pkd,pd->pk", r, e1)
    b2 = np.einsum("pkd,pd->pk", r, e2)
    a = (g22[:, None] * b1 - g12[:, None] * b2) / det[:, None]
    b = (-g12[:, None] * b1 + g11[:, None] * b2) / det[:, None]
    return np.stack([a, b], axis=2)


def _signed_area(poly: np.ndarray, count: np.ndarray) -> np.ndarray:
    """Signed area of padded polygons poly (P, m, 2) with ``count`` valid vertices."""
    _P, m, _ = poly.shape
    idx = np.arange(m)
    nxt = (idx[None, :] + 1) % np.maximum(count, 1)[:, None]
    valid = idx[None, :] < count[:, None]
    x, y = poly[..., 0], poly[..., 1]
    xn = np.take_along_axis(x, nxt, axis=1)
    yn = np.take_along_axis(y, nxt, axis=1)
    return 0.5 * np.sum(np.where(valid, x * yn - xn * y, 0.0), axis=1)


def clip_polygons(
    subject: np.ndarray, clip: np.ndarray, max_vertices: int = 16
) -> tuple[np.ndarray, np.ndarray]:
    """Sutherland–Hodgman clipping of one convex subject polygon by P convex polygons.

    Args:
        subject: (s, 2) counter-clockwise polygon (the reference slave facet).
        clip: (P, c, 2) counter-clockwise convex polygons (master facets in slave coordinates).

    Returns:
        (poly, count): the intersections as padded arrays (P, max_vertices, 2) and vertex counts.
    """
    P, c, _ = clip.shape
    poly = np.zeros((P, max_vertices, 2))
    poly[:, : len(subject)] = subject[None]
    count = np.full(P, len(subject), dtype=np.int64)
    rows = np.arange(P)
    for e in range(c):
        a = clip[:, e]
        b = clip[:, (e + 1) % c]
        ab = b - a
        out = np.zeros_like(poly)
        ocount = np.zeros(P, dtype=np.int64)
        side = ab[:, None, 0] * (poly[..., 1] - a[:, None, 1]) - ab[:, None, 1] * (
            poly[..., 0] - a[:, None, 0]
        )
        for i in range(max_vertices):
            active = i < count
            if not active.any():
                break
            j = np.where(count > 0, (i + 1) % np.maximum(count, 1), 0)
            cur, nxt = poly[:, i], poly[rows, j]
            sc, sn = side[:, i], side[rows, j]
            cin, nin = sc >= 0.0, sn >= 0.0
            denom = np.where(sc - sn == 0.0, 1.0, sc - sn)
            inter = cur + (sc / denom)[:, None] * (nxt - cur)
            # entering or leaving: emit the intersection
            emit_i = active & (cin != nin)
            out[rows[emit_i], ocount[emit_i]] = inter[emit_i]
            ocount += emit_i
            emit_n = active & nin
            out[rows[emit_n], np.minimum(ocount[emit_n], max_vertices - 1)] = nxt[emit_n]
            ocount += emit_n
        poly, count = out, np.minimum(ocount, max_vertices)
    return poly, count


def segment(
    ref: FacetReference,
    slave_vertices: np.ndarray,
    master_vertices: np.ndarray,
    points: np.ndarray,
    weights: np.ndarray,
    min_area: float = 1e-12,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Integration points on the parts of slave facets covered by master facets.

    For each (slave facet, master facet) pair, the master facet's vertices are projected into the
    slave facet's reference coordinates (affine map of its vertices), the reference slave facet is
    clipped by that polygon, the intersection is split into a fan of triangles, and the triangle
    rule (``points``, ``weights`` on the reference triangle) is mapped onto each. For flat facets
    the
    integrand of the master shape functions is then polynomial on every piece and is integrated
    exactly (what makes the contact patch test pass with non-matching meshes).

    Args:
        ref: Slave facet reference (triangle or quadrilateral facets).
        slave_vertices: (P, nv, 3) current slave facet vertex coordinates, basix vertex order.
        master_vertices: (P, nv, 3) current master facet vertex coordinates, basix vertex order.
        points, weights: reference-triangle quadrature rule.

    Returns:
        (pair, xi, w): pair index of each integration point, its slave reference coordinates and
        its weight in reference-area measure (multiply by the slave area scale |t1 × t2|).
    """
    P = slave_vertices.shape[0]
    if P == 0:
        return np.zeros(0, dtype=np.int64), np.zeros((0, 2)), np.zeros(0)
    o, e1, e2 = (
        slave_vertices[:, 0],
        slave_vertices[:, 1] - slave_vertices[:, 0],
        slave_vertices[:, 2] - slave_vertices[:, 0],
    )
    mpoly = _affine_coords(o, e1, e2, master_vertices[:, ref.vertex_cycle])
    cnt = np.full(P, mpoly.shape[1], dtype=np.int64)
    flip = _signed_area(mpoly, cnt) < 0.0
    mpoly[flip] = mpoly[flip, ::-1]
    poly, count = clip_polygons(ref.reference_polygon, mpoly)
    area = _signed_area(poly, count)
    keep = (count >= 3) & (area > min_area)
    pair_ids, xis, ws = [], [], []
    nq = len(weights)
    for k in range(1, poly.shape[1] - 1):  # fan triangles (v0, vk, vk+1)
        sel = keep & (k + 1 < count)
        if not sel.any():
            break
        p0, p1, p2 = poly[sel, 0], poly[sel, k], poly[sel, k + 1]
        d1, d2 = p1 - p0, p2 - p0
        det = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
        xi = (
            p0[:, None, :]
            + points[None, :, 0:1] * d1[:, None, :]
            + points[None, :, 1:2] * d2[:, None, :]
        )
        pair_ids.append(np.repeat(np.nonzero(sel)[0], nq))
        xis.append(xi.reshape(-1, 2))
        ws.append((weights[None, :] * np.abs(det)[:, None]).ravel())
    if not pair_ids:
        return np.zeros(0, dtype=np.int64), np.zeros((0, 2)), np.zeros(0)
    return np.concatenate(pair_ids), np.concatenate(xis), np.concatenate(ws)
