"""Extrusion of a 2D section mesh over the face width into a 3D body mesh (tetrahedra or
hexahedra, second-order nodes on the curved section boundary, straight across the width)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gearfem.geometry.placement import BodyPlacement


@dataclass
class Section2D:
    """Curved 2D mesh of one body's section at z = 0 (metres).

    Attributes:
        nodes: ``(n, 2)`` node coordinates (vertices and high-order nodes).
        cell_type: gmsh type of the 2D cells (2/9 triangles, 3/10 quadrilaterals).
        cells: ``(m, k)`` node indices of the cells (gmsh local order, counter-clockwise).
        edges: facet-group name -> ``(e, 2 or 3)`` boundary line elements (gmsh order: ends, mid).
    """

    body: str
    nodes: np.ndarray
    cell_type: int
    cells: np.ndarray
    edges: dict[str, np.ndarray]
    placement: BodyPlacement


@dataclass
class SweptBody:
    """3D mesh of one body (metres): nodes, cells and facet groups, gmsh types and local order."""

    body: str
    nodes: np.ndarray
    cell_type: int
    cells: np.ndarray
    facet_type: dict[str, int]
    facets: dict[str, np.ndarray]


# Reference node coordinates of the gmsh element types used here (MSH format, fixed by gmsh; the
# test suite checks them against gmsh.model.mesh.getElementProperties) and their vertex counts.
_H = (-1.0, 1.0, 0.0)
GMSH_REF: dict[int, tuple[int, tuple[tuple[float, ...], ...]]] = {
    1: (2, ((-1.0,), (1.0,))),
    8: (2, ((-1.0,), (1.0,), (0.0,))),
    2: (3, ((0, 0), (1, 0), (0, 1))),
    9: (3, ((0, 0), (1, 0), (0, 1), (0.5, 0), (0.5, 0.5), (0, 0.5))),
    3: (4, ((-1, -1), (1, -1), (1, 1), (-1, 1))),
    10: (4, ((-1, -1), (1, -1), (1, 1), (-1, 1), (0, -1), (1, 0), (0, 1), (-1, 0), (0, 0))),
    4: (4, ((0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1))),
    11: (
        4,
        (
            (0, 0, 0),
            (1, 0, 0),
            (0, 1, 0),
            (0, 0, 1),
            (0.5, 0, 0),
            (0.5, 0.5, 0),
            (0, 0.5, 0),
            (0, 0, 0.5),
            (0, 0.5, 0.5),
            (0.5, 0, 0.5),
        ),
    ),
    5: (
        8,
        (
            (-1, -1, -1),
            (1, -1, -1),
            (1, 1, -1),
            (-1, 1, -1),
            (-1, -1, 1),
            (1, -1, 1),
            (1, 1, 1),
            (-1, 1, 1),
        ),
    ),
    12: (
        8,
        (
            (-1, -1, -1),
            (1, -1, -1),
            (1, 1, -1),
            (-1, 1, -1),
            (-1, -1, 1),
            (1, -1, 1),
            (1, 1, 1),
            (-1, 1, 1),
            (0, -1, -1),
            (-1, 0, -1),
            (-1, -1, 0),
            (1, 0, -1),
            (1, -1, 0),
            (0, 1, -1),
            (1, 1, 0),
            (-1, 1, 0),
            (0, -1, 1),
            (-1, 0, 1),
            (1, 0, 1),
            (0, 1, 1),
            (0, 0, -1),
            (0, -1, 0),
            (-1, 0, 0),
            (1, 0, 0),
            (0, 1, 0),
            (0, 0, 1),
            (0, 0, 0),
        ),
    ),
}
del _H


def _ref_coords(gmsh_type: int) -> np.ndarray:
    return np.asarray(GMSH_REF[gmsh_type][1], dtype=float)


def _edge_mid_table(cell_type: int) -> list[tuple[int, int, int]]:
    """(vertex a, vertex b, local node) for the edge nodes of a simplex type."""
    ref = _ref_coords(cell_type)
    nv = GMSH_REF[cell_type][0]
    out = []
    for loc in range(nv, len(ref)):
        for a in range(nv):
            for b in range(a + 1, nv):
                if np.allclose(0.5 * (ref[a] + ref[b]), ref[loc]):
                    out.append((a, b, loc))
    if len(out) != len(ref) - nv:  # pragma: no cover - table error
        raise RuntimeError(f"gmsh type {cell_type}: high-order nodes that are not edge midpoints")
    return out


def layer_planes(
    face_width_m: float, layers: int, order: int, grading: float | None = None
) -> np.ndarray:
    """z of the node planes (``order * layers + 1``, metres): the layers' bounding planes and, for
    order 2, each layer's middle plane. Equal layers without ``grading``; with a ratio G > 1 the
    bounding planes are ``b s(i / layers)``, ``s(xi) = (G^(2 xi) - 1) / (2 (G - 1))`` for xi <=
    1/2 and ``1 - s(1 - xi)`` beyond (:class:`~gearfem.geometry.options.MeshOptions`)."""
    if grading is None or grading == 1.0:
        return np.linspace(0.0, face_width_m, order * layers + 1)
    xi = np.arange(layers + 1) / layers
    half = np.minimum(xi, 1.0 - xi)
    s = (grading ** (2.0 * half) - 1.0) / (2.0 * (grading - 1.0))
    s = np.where(xi <= 0.5, s, 1.0 - s)
    bounds = face_width_m * s
    bounds[0], bounds[-1] = 0.0, face_width_m
    if order == 1:
        return bounds
    z = np.empty(order * layers + 1)
    z[::order] = bounds
    for k in range(1, order):  # interior planes of each layer, equally spaced within it
        z[k::order] = bounds[:-1] + (bounds[1:] - bounds[:-1]) * (k / order)
    return z


class _Extruder:
    """Node numbering of the swept mesh: node (i, j) = 2D node i on plane j -> j * n2 + i."""

    def __init__(
        self,
        sec: Section2D,
        face_width_m: float,
        layers: int,
        order: int,
        grading: float | None = None,
    ) -> None:
        self.sec = sec
        self.n2 = len(sec.nodes)
        self.q = order
        self.layers = layers
        self.planes = order * layers + 1
        z = layer_planes(face_width_m, layers, order, grading)
        self.nodes = np.column_stack([np.tile(sec.nodes, (self.planes, 1)), np.repeat(z, self.n2)])
        self._mid = None
        if order == 2:
            # 2D edge -> mid node, from the 2D cells (simplex or quadrilateral)
            ct = sec.cell_type
            if ct == 9:
                table = _edge_mid_table(9)
            else:  # quad9: edge nodes 4..7 between corners (0,1), (1,2), (2,3), (3,0)
                table = [(0, 1, 4), (1, 2, 5), (2, 3, 6), (3, 0, 7)]
            a = np.concatenate([sec.cells[:, t[0]] for t in table])
            b = np.concatenate([sec.cells[:, t[1]] for t in table])
            m = np.concatenate([sec.cells[:, t[2]] for t in table])
            key = np.minimum(a, b) * self.n2 + np.maximum(a, b)
            key, first = np.unique(key, return_index=True)
            self._keys, self._mids = key, m[first]

    def idx(self, i2: np.ndarray, plane: np.ndarray | int) -> np.ndarray:
        return np.asarray(plane) * self.n2 + np.asarray(i2)

    def mid2d(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        key = np.minimum(a, b) * self.n2 + np.maximum(a, b)
        pos = np.searchsorted(self._keys, key)
        if np.any(pos >= len(self._keys)) or np.any(
            self._keys[np.minimum(pos, len(self._keys) - 1)] != key
        ):
            raise RuntimeError("extrude: an edge without a 2D mid node")  # pragma: no cover
        return self._mids[pos]

    def mid3d(
        self, a: tuple[np.ndarray, np.ndarray], b: tuple[np.ndarray, np.ndarray]
    ) -> np.ndarray:
        """Mid node of the straight-in-z edge between swept vertices a = (i2, plane), b."""
        (ia, pa), (ib, pb) = a, b
        i_mid = ia.copy()  # vertical edge: the same 2D node on the middle plane
        diff = ia != ib  # in-plane or diagonal edge: the 2D edge's mid node (on the middle plane)
        if np.any(diff):
            i_mid[diff] = self.mid2d(ia[diff], ib[diff])
        return self.idx(i_mid, (pa + pb) // 2)


def extrude(
    sec: Section2D,
    face_width_m: float,
    layers: int,
    order: int,
    grading: float | None = None,
) -> SweptBody:
    """Extrude a 2D section mesh over ``z in [0, face_width_m]`` with ``layers`` element layers
    (equal, or graded towards both side faces by ``grading``: :func:`layer_planes`):
    quadrilaterals -> hexahedra, triangles -> prisms split into three tetrahedra each (diagonals
    of the side faces from the lower- to the higher-numbered vertex, consistent between
    neighbours). High-order nodes come from the 2D mesh (curved boundary) and straight in z."""
    sw = _Extruder(sec, face_width_m, layers, order, grading)
    q = order
    quad = sec.cell_type in (3, 10)
    facets: dict[str, np.ndarray] = {}
    facet_type: dict[str, int] = {}
    nplane = sw.planes
    if quad:
        cell_type = {1: 5, 2: 12}[q]
        face_type = {1: 3, 2: 10}[q]
        href = _ref_coords(cell_type)
        qref = _ref_coords(sec.cell_type)
        lmap = []  # hex local node -> (quad local node, plane offset)
        for x in href:
            k = int(np.flatnonzero(np.all(np.isclose(qref, x[:2]), axis=1))[0])
            lmap.append((k, round((x[2] + 1.0) * 0.5 * q)))
        cells = np.vstack(
            [
                np.column_stack([sw.idx(sec.cells[:, k], lay * q + off) for k, off in lmap])
                for lay in range(layers)
            ]
        )
        # lateral facets: quad (xi along the edge, eta along z)
        lref = _ref_coords({1: 1, 2: 8}[q])[:, 0]
        fmap = []
        for x in _ref_coords(face_type):
            k = int(np.flatnonzero(np.isclose(lref, x[0]))[0])
            fmap.append((k, round((x[1] + 1.0) * 0.5 * q)))
        for name, e in sec.edges.items():
            facets[name] = np.vstack(
                [
                    np.column_stack([sw.idx(e[:, k], lay * q + off) for k, off in fmap])
                    for lay in range(layers)
                ]
            )
            facet_type[name] = face_type
    else:
        cell_type = {1: 4, 2: 11}[q]
        face_type = {1: 2, 2: 9}[q]
        tri = np.sort(sec.cells[:, :3], axis=1)
        a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
        chunks = []
        for lay in range(layers):
            p0 = np.full(len(tri), lay * q)
            p1 = p0 + q
            for verts in (
                ((a, p0), (b, p0), (c, p0), (c, p1)),
                ((a, p0), (b, p0), (b, p1), (c, p1)),
                ((a, p0), (a, p1), (b, p1), (c, p1)),
            ):
                chunks.append(verts)
        cells = _simplices(sw, chunks, cell_type, orient=True)
        for name, e in sec.edges.items():
            lo, hi = np.minimum(e[:, 0], e[:, 1]), np.maximum(e[:, 0], e[:, 1])
            tris = []
            for lay in range(layers):
                p0 = np.full(len(e), lay * q)
                p1 = p0 + q
                tris.append(((lo, p0), (hi, p0), (hi, p1)))
                tris.append(((lo, p0), (hi, p1), (lo, p1)))
            facets[name] = _simplices(sw, tris, face_type, orient=False)
            facet_type[name] = face_type
    body = sec.body
    front_back = {f"{body}_side_front": 0, f"{body}_side_back": nplane - 1}
    for name, plane in front_back.items():
        facets[name] = sw.idx(sec.cells, plane)
        facet_type[name] = sec.cell_type
    return SweptBody(body, sw.nodes, cell_type, cells, facet_type, facets)


def _simplices(sw: _Extruder, chunks, gmsh_type: int, orient: bool) -> np.ndarray:
    """Assemble simplices from vertex lists ``((i2, plane), ...)`` with their edge mid nodes."""
    table = _edge_mid_table(gmsh_type) if sw.q == 2 else []
    out = []
    for verts in chunks:
        verts = [(np.asarray(i, dtype=np.int64), np.asarray(p, dtype=np.int64)) for i, p in verts]
        if orient:  # positive volume: swap vertices 1 and 2 where negative
            X = [sw.nodes[sw.idx(i, p)] for i, p in verts]
            vol = np.einsum("ij,ij->i", X[1] - X[0], np.cross(X[2] - X[0], X[3] - X[0]))
            neg = vol < 0
            v1 = (np.where(neg, verts[2][0], verts[1][0]), np.where(neg, verts[2][1], verts[1][1]))
            v2 = (np.where(neg, verts[1][0], verts[2][0]), np.where(neg, verts[1][1], verts[2][1]))
            verts = [verts[0], v1, v2, verts[3]]
        cols = [sw.idx(i, p) for i, p in verts]
        cols += [sw.mid3d(verts[a], verts[b]) for a, b, _ in sorted(table, key=lambda t: t[2])]
        out.append(np.column_stack(cols))
    return np.vstack(out)
