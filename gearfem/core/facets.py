"""Reference-facet data for contact on Lagrange (P1/P2) tetrahedral and hexahedral meshes.

A facet of a degree-d Lagrange cell is itself a degree-d Lagrange triangle or quadrilateral: its
nodes are the cell's closure dofs on that facet. :class:`FacetReference` lists, for every local
facet of the reference cell, the cell-local node numbers in the order of the basix facet element
(vertices, then edges, then the face interior), so the facet's curved geometry and the displacement
on it are evaluated with the facet element's shape functions directly.
"""

from __future__ import annotations

import dataclasses
from functools import cached_property

import basix
import numpy as np

from gearfem.core.errors import ParameterError

_FACET_TYPE = {
    basix.CellType.tetrahedron: basix.CellType.triangle,
    basix.CellType.hexahedron: basix.CellType.quadrilateral,
}

# Counter-clockwise vertex cycle of the reference facet (basix numbers quad vertices in tensor
# order).
_VERTEX_CYCLE = {
    basix.CellType.triangle: np.array([0, 1, 2]),
    basix.CellType.quadrilateral: np.array([0, 1, 3, 2]),
}


def _lagrange(cell: basix.CellType, degree: int) -> basix.finite_element.FiniteElement:
    return basix.create_element(
        basix.ElementFamily.P, cell, degree, basix.LagrangeVariant.equispaced
    )


@dataclasses.dataclass(frozen=True)
class FacetReference:
    """Facet element of a Lagrange cell type and degree (1 or 2).

    Attributes:
        cell_type: basix cell type of the volume cells.
        degree: Lagrange degree of the geometry and of the displacement (equal here).
        facet_nodes: (n_facets_per_cell, n_facet_nodes) cell-local node numbers per local facet.
    """

    cell_type: basix.CellType
    degree: int
    facet_nodes: np.ndarray

    @classmethod
    def create(cls, cell_type: basix.CellType, degree: int) -> FacetReference:
        if cell_type not in _FACET_TYPE:
            raise ParameterError("mesh cell type", str(cell_type), "tetrahedron or hexahedron")
        if degree not in (1, 2):
            raise ParameterError(
                "contact element degree", degree, "1 or 2 (one node per sub-entity)"
            )
        ftype = _FACET_TYPE[cell_type]
        cell_el, facet_el = _lagrange(cell_type, degree), _lagrange(ftype, degree)
        ctopo, ftopo = basix.topology(cell_type), basix.topology(ftype)
        lookup = {(d, frozenset(vs)): e for d in range(3) for e, vs in enumerate(ctopo[d])}
        rows = []
        for fverts in ctopo[2]:
            nodes = np.full(facet_el.dim, -1, dtype=np.int64)
            for d in range(3):
                for e, local_vs in enumerate(ftopo[d]):
                    key = (d, frozenset(fverts[i] for i in local_vs))
                    cdofs = cell_el.entity_dofs[d][lookup[key]]
                    fdofs = facet_el.entity_dofs[d][e]
                    nodes[fdofs] = cdofs
            assert (nodes >= 0).all()
            rows.append(nodes)
        return cls(cell_type, degree, np.array(rows, dtype=np.int64))

    # -------------------------------------------------------------------------------------------
    @property
    def facet_type(self) -> basix.CellType:
        return _FACET_TYPE[self.cell_type]

    @cached_property
    def element(self) -> basix.finite_element.FiniteElement:
        return _lagrange(self.facet_type, self.degree)

    @property
    def num_nodes(self) -> int:
        return self.facet_nodes.shape[1]

    @property
    def num_vertices(self) -> int:
        return 3 if self.facet_type == basix.CellType.triangle else 4

    @property
    def vertex_cycle(self) -> np.ndarray:
        """Facet-local vertex numbers in counter-clockwise order around the reference facet."""
        return _VERTEX_CYCLE[self.facet_type]

    @cached_property
    def reference_polygon(self) -> np.ndarray:
        """Reference facet as a counter-clockwise polygon (n_vertices, 2)."""
        return np.asarray(basix.geometry(self.facet_type))[self.vertex_cycle]

    @cached_property
    def power_exponents(self) -> np.ndarray:
        """Exponents (i, j) of the monomials ξ₁^i ξ₂^j spanning the facet element (P_d: i + j ≤ d,
        Q_d: i, j ≤ d), in the order of :attr:`power_basis`'s rows."""
        d = self.degree
        if self.facet_type == basix.CellType.triangle:
            pairs = [(i, k - i) for k in range(d + 1) for i in range(k, -1, -1)]
        else:
            pairs = [(i, j) for j in range(d + 1) for i in range(d + 1)]
        return np.array(pairs, dtype=np.int64)

    @cached_property
    def power_basis(self) -> np.ndarray:
        """Matrix P (n_monomials, n_nodes): P @ nodal values are the coefficients of the same
        polynomial in the monomials of :attr:`power_exponents` (the inverse of their Vandermonde
        matrix at the facet element's nodes). Evaluating a facet map from these coefficients costs
        a few vector operations per point instead of a tabulation of every shape function."""
        pts = np.asarray(self.element.points, dtype=np.float64)
        e = self.power_exponents
        V = pts[:, None, 0] ** e[None, :, 0] * pts[:, None, 1] ** e[None, :, 1]
        return np.linalg.inv(V)

    def tabulate(self, xi: np.ndarray, derivatives: int = 1) -> np.ndarray:
        """Shape functions at reference points ``xi`` (n, 2): array (n_deriv, n, n_nodes).

        Index 0 is the value, 1 and 2 the derivatives in xi_1 and xi_2, (with ``derivatives=2``)
        3, 4, 5 the second derivatives 11, 12, 22. Closed forms in basix's node order (the contact
        search evaluates hundreds of thousands of points; a test checks them against basix).
        """
        xi = np.asarray(xi, dtype=np.float64)
        if derivatives > 2:
            return self.element.tabulate(derivatives, np.ascontiguousarray(xi))[..., 0]
        x, y = xi[:, 0], xi[:, 1]
        if self.facet_type == basix.CellType.triangle:
            out = triangle_shape(x, y, self.degree)
        else:
            out = _quad_shape(x, y, self.degree)
        return out[: 3 if derivatives == 1 else 6] if derivatives else out[:1]

    def quadrature(self, degree: int) -> tuple[np.ndarray, np.ndarray]:
        """Gauss points and weights on the reference facet (weights sum to its area)."""
        pts, wts = basix.make_quadrature(self.facet_type, degree)
        return np.asarray(pts), np.asarray(wts)

    def linear_fit(self, points: np.ndarray) -> np.ndarray:
        """Matrix F (3, n) such that c = F @ values are the coefficients of the least-squares linear
        function a0 + a1 xi1 + a2 xi2 through ``values`` at ``points`` (exact for linear data)."""
        phi = np.column_stack([np.ones(len(points)), points])
        return np.linalg.solve(phi.T @ phi, phi.T)

    def nodal_fit(self, points: np.ndarray) -> np.ndarray:
        """Matrix F (n_nodes, n) such that F @ values are the nodal values of the least-squares
        facet-element function (P_d triangle, Q_d quadrilateral) through ``values`` at ``points``:
        interpolation when there are as many points as nodes (exact for data in that space)."""
        phi = self.tabulate(np.asarray(points, dtype=np.float64), 0)[0]  # (n, n_nodes)
        if phi.shape[0] < phi.shape[1]:
            raise ParameterError(
                "multiplier points per facet", phi.shape[0], f">= {phi.shape[1]} facet nodes"
            )
        return np.linalg.solve(phi.T @ phi, phi.T)

    def inside(self, xi: np.ndarray, tol: float = 0.0) -> np.ndarray:
        """True where the reference point lies in the facet (within ``tol``)."""
        if self.facet_type == basix.CellType.triangle:
            return (
                (xi[..., 0] >= -tol) & (xi[..., 1] >= -tol) & (xi[..., 0] + xi[..., 1] <= 1.0 + tol)
            )
        return np.all((xi >= -tol) & (xi <= 1.0 + tol), axis=-1)

    def clamp(self, xi: np.ndarray) -> np.ndarray:
        """Nearest point of the reference facet (in reference coordinates)."""
        out = np.array(xi, dtype=np.float64, copy=True)
        if self.facet_type == basix.CellType.quadrilateral:
            return np.clip(out, 0.0, 1.0)
        out = np.maximum(out, 0.0)
        s = out.sum(axis=-1)
        over = s > 1.0
        if np.any(over):  # project onto the hypotenuse xi1 + xi2 = 1, then clip to its ends
            a = np.clip(0.5 * (1.0 + xi[over, 0] - xi[over, 1]), 0.0, 1.0)
            out[over, 0], out[over, 1] = a, 1.0 - a
        return out


def triangle_shape(x: np.ndarray, y: np.ndarray, degree: int) -> np.ndarray:
    """P1/P2 triangle shape functions and derivatives (value, d1, d2, d11, d12, d22) x (n, nn) at
    reference points (x, y); nodes: the vertices (0,0), (1,0), (0,1), then the edges (1,2),
    (0,2), (0,1)."""
    n = len(x)
    z, o = np.zeros(n), np.ones(n)
    l0, l1, l2 = 1.0 - x - y, x, y
    if degree == 1:
        N = np.stack([l0, l1, l2], axis=1)
        dx = np.stack([-o, o, z], axis=1)
        dy = np.stack([-o, z, o], axis=1)
        zz = np.zeros((n, 3))
        return np.stack([N, dx, dy, zz, zz, zz])
    # vertices l(2l-1); edges 3: (1,2), 4: (0,2), 5: (0,1): 4 la lb
    N = np.stack(
        [
            l0 * (2 * l0 - 1),
            l1 * (2 * l1 - 1),
            l2 * (2 * l2 - 1),
            4 * l1 * l2,
            4 * l0 * l2,
            4 * l0 * l1,
        ],
        axis=1,
    )
    # d/dx: dl0 = -1, dl1 = 1, dl2 = 0 ; d/dy: dl0 = -1, dl1 = 0, dl2 = 1
    dx = np.stack([-(4 * l0 - 1), 4 * l1 - 1, z, 4 * l2, -4 * l2, 4 * (l0 - l1)], axis=1)
    dy = np.stack([-(4 * l0 - 1), z, 4 * l2 - 1, 4 * l1, 4 * (l0 - l2), -4 * l1], axis=1)
    c = lambda *v: np.tile(np.array(v, dtype=np.float64), (n, 1))
    dxx = c(4, 4, 0, 0, 0, -8)
    dxy = c(4, 0, 0, 4, -4, -4)
    dyy = c(4, 0, 4, 0, -8, 0)
    return np.stack([N, dx, dy, dxx, dxy, dyy])


def _lagrange_1d(t: np.ndarray, degree: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """1D Lagrange basis on [0, 1] with nodes (0, 1[, 0.5]): values, first, second derivatives (n,
    k)."""
    o = np.ones_like(t)
    if degree == 1:
        return np.stack([1 - t, t], axis=1), np.stack([-o, o], axis=1), np.zeros((len(t), 2))
    v = np.stack([(1 - t) * (1 - 2 * t), t * (2 * t - 1), 4 * t * (1 - t)], axis=1)
    d = np.stack([4 * t - 3, 4 * t - 1, 4 - 8 * t], axis=1)
    dd = np.stack([4 * o, 4 * o, -8 * o], axis=1)
    return v, d, dd


def _quad_shape(x: np.ndarray, y: np.ndarray, degree: int) -> np.ndarray:
    """Q1/Q2 quadrilateral shape functions in basix order, with derivatives up to second order."""
    # basix order: vertices (0,0) (1,0) (0,1) (1,1); edges (0,1) (0,2) (1,3) (2,3); interior
    pairs = [(0, 0), (1, 0), (0, 1), (1, 1)]
    if degree == 2:
        pairs += [(2, 0), (0, 2), (1, 2), (2, 1), (2, 2)]
    vx, dx, ddx = _lagrange_1d(x, degree)
    vy, dy, ddy = _lagrange_1d(y, degree)
    cols = lambda a, b: np.stack([a[:, i] * b[:, j] for i, j in pairs], axis=1)
    return np.stack(
        [cols(vx, vy), cols(dx, vy), cols(vx, dy), cols(ddx, vy), cols(dx, dy), cols(vx, ddy)]
    )
