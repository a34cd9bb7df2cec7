"""Carrying a flux of the cycle's reference tooth onto the flank facets of the thermal mesh.

The cycle gives a flux per facet of one reference tooth sector (body frame, as built). Each flank
facet of the thermal mesh (drive flanks, tips, roots) takes the reference facet nearest to its
congruent place (its centroid rotated by whole pitches into the reference sector); every tooth's
total is then scaled to the reference tooth's heat (a purely geometric correction for meshes that
are not rotated copies of each other), so the heat put in is conserved to round-off. Cells next to
the facets carry their facets' area-weighted mean (DG0).
"""

from __future__ import annotations

import numpy as np
from mpi4py import MPI
from scipy.spatial import cKDTree

from gearfem.contact.kinematics import evaluate
from gearfem.core.errors import ParameterError
from gearfem.core.facets import FacetReference
from gearfem.geometry.mesh import parse_group_name

# Facet areas for the per-tooth normalisation: exact enough on curved P2 facets (tip rounds) that
# the heat assembled with this rule equals the target to round-off (degree 2 left 2e-6).
AREA_QUADRATURE_DEGREE = 6
FLANK_KINDS = ("drive_flank", "tip", "root")


def tooth_local(
    points: np.ndarray, center: np.ndarray, tooth_angles: np.ndarray, pitch: float, ref_angle: float
) -> tuple[np.ndarray, np.ndarray]:
    """Rotate points into the reference tooth's sector: (rotated points, index of their tooth)."""
    p = np.asarray(points) - center
    theta = np.arctan2(p[:, 1], p[:, 0])
    d = np.angle(np.exp(1j * (theta[:, None] - np.asarray(tooth_angles)[None, :])))
    k = np.argmin(np.abs(d), axis=1)
    rot = ref_angle - np.asarray(tooth_angles)[k]
    c, s = np.cos(rot), np.sin(rot)
    out = np.column_stack([c * p[:, 0] - s * p[:, 1], s * p[:, 0] + c * p[:, 1], p[:, 2]])
    return out, k


class FlankTransfer:
    """The owned flank facets of one gear's thermal mesh and their reference facets (see the
    module docstring). Collective-free to build.

    Attributes: ``names`` (facet groups), ``cells``/``local_facet`` (cell and local facet of every
    owned flank facet), ``area`` (m²), ``centroid`` (m), ``ref`` (reference facet index),
    ``tooth`` (thermal tooth index), ``num_teeth``, ``Q`` (the DG0 space), ``num_cells`` (local,
    owned and ghost), ``cell_area`` (flank area of each facet's cell).
    """

    def __init__(self, domain, gear_mesh, body: str, fields, kinds=FLANK_KINDS) -> None:
        from dolfinx import fem

        mesh = domain.mesh
        tdim = mesh.topology.dim
        self.comm = mesh.comm
        self.fields = fields
        names = tuple(
            n
            for n in domain.groups
            if parse_group_name(n)[0] == body
            and parse_group_name(n)[2] in kinds
            and parse_group_name(n)[1] is not None
        )
        if not names:
            raise ParameterError(
                "sources.friction surfaces", kinds, f"facet groups of {body!r} in the thermal mesh"
            )
        self.names = names
        facets = domain.facets(names)
        n_owned_f = mesh.topology.index_map(tdim - 1).size_local
        facets = facets[facets < n_owned_f]
        mesh.topology.create_connectivity(tdim - 1, tdim)
        cf = np.asarray(
            fem.compute_integration_domains(fem.IntegralType.exterior_facet, mesh.topology, facets)
        ).reshape(-1, 2)
        import basix

        cell_type = {
            "tetrahedron": basix.CellType.tetrahedron,
            "hexahedron": basix.CellType.hexahedron,
        }[mesh.topology.cell_name()]
        ref = FacetReference.create(cell_type, mesh.geometry.cmaps[0].degree)
        X = mesh.geometry.x[
            np.take_along_axis(
                mesh.geometry.dofmaps[0][cf[:, 0]], ref.facet_nodes[cf[:, 1]], axis=1
            )
        ]
        xc = X[:, : ref.num_vertices].mean(axis=1)
        qp, qw = ref.quadrature(AREA_QUADRATURE_DEGREE)
        area = np.zeros(len(facets))
        for p_, w_ in zip(qp, qw):
            _, a1, a2, _ = evaluate(ref, X, np.tile(p_, (len(facets), 1)))
            area += w_ * np.linalg.norm(np.cross(a1, a2), axis=1)
        angles = gear_mesh.tooth_angles(body)
        center = np.asarray(gear_mesh.center(body))
        xl, tooth = tooth_local(xc, center, angles, fields.pitch_angle_rad, fields.tooth_angle_rad)
        _, j = cKDTree(fields.facet_points_m - fields.center_m).query(xl)
        self.cells, self.local_facet = cf[:, 0], cf[:, 1]
        self.area, self.centroid, self.ref, self.tooth = area, xc, j, tooth
        self.num_teeth = len(angles)
        self.Q = fem.functionspace(mesh, ("DG", 0))
        imap = mesh.topology.index_map(tdim)
        self.num_cells = imap.size_local + imap.num_ghosts
        den = np.bincount(self.cells, weights=area, minlength=self.num_cells)
        self.cell_area = den[self.cells]
        self.dofs = self.Q.dofmap.list[: self.num_cells, 0]

    def tooth_scale(self, q_ref: np.ndarray) -> np.ndarray:
        """Per thermal tooth: the factor that makes its heat, with the facet flux ``q_ref[ref]``,
        equal the reference tooth's Σ q_ref A_ref (collective)."""
        q = q_ref[self.ref]
        tooth_heat = self.comm.allreduce(
            np.bincount(self.tooth, weights=q * self.area, minlength=self.num_teeth), op=MPI.SUM
        )
        target = float(np.sum(q_ref * self.fields.facet_area_m2))
        return np.where(tooth_heat > 0, target / np.where(tooth_heat > 0, tooth_heat, 1.0), 0.0)

    def cell_values(self, q_facet: np.ndarray) -> np.ndarray:
        """Area-weighted mean of a facet quantity per local cell (0 off the flanks)."""
        num = np.bincount(self.cells, weights=q_facet * self.area, minlength=self.num_cells)
        den = np.bincount(self.cells, weights=self.area, minlength=self.num_cells)
        return np.where(den > 0, num / np.where(den > 0, den, 1.0), 0.0)

    def function(self, q_facet: np.ndarray, name: str):
        """DG0 Function of :meth:`cell_values`."""
        from dolfinx import fem

        fn = fem.Function(self.Q, name=name)
        fn.x.array[self.dofs] = self.cell_values(q_facet)
        fn.x.scatter_forward()
        return fn


__all__ = ["AREA_QUADRATURE_DEGREE", "FLANK_KINDS", "FlankTransfer", "tooth_local"]
