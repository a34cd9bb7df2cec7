"""Contact surfaces: the boundary facets of one body that may touch another body.

Each rank holds its owned facets (:attr:`ContactSurface.local`); a surface acting as master is also
gathered to every rank (:meth:`ContactSurface.gathered`), because a slave point may meet any part
of the opposing body. Only node coordinates, global dof numbers and (per iteration) displacements
travel: the master surface is small next to the volume.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from mpi4py import MPI

from gearfem.contact.kinematics import evaluate
from gearfem.core.errors import ParameterError
from gearfem.core.facets import FacetReference


@dataclasses.dataclass(frozen=True)
class SurfaceData:
    """Arrays describing a set of facets of one body.

    Attributes:
        X: (nf, nn, 3) reference coordinates of the facet nodes (body frame), m.
        blocks: (nf, nn) global block (node) numbers of the displacement dofs.
        fixed: (nf, nn, 3) True where the displacement component is prescribed (Dirichlet).
        orientation: (nf,) ±1 making sign·(t1 × t2) the outward normal.
        local_blocks: (nf, nn) local block numbers on the owning rank (owned facets only).
        size: (nf,) facet size: its shortest vertex-to-vertex edge, m (for the long, thin facets of
            swept meshes this is the element size across the surface, which sets the penalty and
            the search margin).
    """

    X: np.ndarray
    blocks: np.ndarray
    fixed: np.ndarray
    orientation: np.ndarray
    local_blocks: np.ndarray
    size: np.ndarray

    @property
    def num_facets(self) -> int:
        return self.X.shape[0]


class ContactSurface:
    """Owned facets of a named boundary of one body, ready for contact computations.

    Args:
        V: The vector P1/P2 displacement space (same degree as the mesh geometry).
        facets: Local indices of the boundary facets (ghost facets are ignored).
        body: Name of the body the facets belong to (rigid motions are looked up by it).
        fixed_mask: Boolean array over the local dofs (owned + ghost, blocked layout) marking
            Dirichlet-constrained dofs.
        name: Name used in messages and outputs.
    """

    def __init__(
        self, V, facets: np.ndarray, body: str, fixed_mask: np.ndarray, name: str = ""
    ) -> None:
        from dolfinx import fem

        mesh = V.mesh
        self.V, self.mesh, self.body, self.name = V, mesh, body, name or body
        tdim = mesh.topology.dim
        if mesh.geometry.cmaps[0].degree != V.element.basix_element.degree:
            raise ParameterError(
                "displacement degree",
                V.element.basix_element.degree,
                f"equal to the mesh geometry degree {mesh.geometry.cmaps[0].degree}",
            )
        import basix

        cell_type = {
            "tetrahedron": basix.CellType.tetrahedron,
            "hexahedron": basix.CellType.hexahedron,
        }[mesh.topology.cell_name()]
        self.ref = FacetReference.create(cell_type, mesh.geometry.cmaps[0].degree)
        mesh.topology.create_connectivity(tdim - 1, tdim)
        n_owned = mesh.topology.index_map(tdim - 1).size_local
        facets = np.unique(np.asarray(facets, dtype=np.int32))
        facets = facets[facets < n_owned]
        cf = fem.compute_integration_domains(fem.IntegralType.exterior_facet, mesh.topology, facets)
        cf = np.asarray(cf).reshape(-1, 2)
        if len(cf) != len(facets):
            raise ParameterError(
                f"contact surface {self.name!r}", len(facets), "exterior facets only"
            )
        cells, lf = cf[:, 0], cf[:, 1]
        nodes_local = self.ref.facet_nodes[lf]  # (nf, nn)
        gdofs = mesh.geometry.dofmaps[0][cells]
        X = mesh.geometry.x[np.take_along_axis(gdofs, nodes_local, axis=1)]
        vdofs = V.dofmap.list[cells]
        lblocks = np.take_along_axis(vdofs, nodes_local, axis=1).astype(np.int64)
        imap = V.dofmap.index_map
        gblocks = imap.local_to_global(lblocks.ravel().astype(np.int32)).reshape(lblocks.shape)
        bs = V.dofmap.index_map_bs
        fixed = fixed_mask.reshape(-1, bs)[lblocks]
        # outward orientation: compare t1 x t2 at the facet centre with (facet centre - cell centre)
        centre = np.tile(self.ref.reference_polygon.mean(axis=0), (len(cells), 1))
        xc, t1, t2, _ = evaluate(self.ref, X, centre)
        cell_centre = mesh.geometry.x[gdofs].mean(axis=1)
        s = np.einsum("pd,pd->p", np.cross(t1, t2), xc - cell_centre)
        orientation = np.where(s >= 0.0, 1.0, -1.0)
        cyc = self.ref.vertex_cycle
        V0 = X[:, cyc]
        edges = np.linalg.norm(V0 - np.roll(V0, -1, axis=1), axis=2)
        self.facets = facets
        self.local = SurfaceData(
            X,
            gblocks,
            fixed,
            orientation,
            lblocks,
            edges.min(axis=1) if len(cells) else np.zeros(0),
        )
        self._gathered: SurfaceData | None = None
        self._counts = None

    # -------------------------------------------------------------------------------------------
    @property
    def comm(self) -> MPI.Comm:
        return self.mesh.comm

    def num_facets_global(self) -> int:
        return self.comm.allreduce(self.local.num_facets, op=MPI.SUM)

    def gathered(self) -> SurfaceData:
        """All ranks' facets of this surface, in rank order (collective on first call)."""
        if self._gathered is None:
            loc = self.local
            comm = self.comm
            self._counts = np.array(comm.allgather(loc.num_facets))
            nn = self.ref.num_nodes

            def cat(a, shape, dtype):
                parts = comm.allgather(np.ascontiguousarray(a))
                return (
                    np.concatenate(parts).reshape(shape).astype(dtype)
                    if parts
                    else np.zeros(shape, dtype)
                )

            n = int(self._counts.sum())
            self._gathered = SurfaceData(
                X=cat(loc.X, (n, nn, 3), np.float64),
                blocks=cat(loc.blocks, (n, nn), np.int64),
                fixed=cat(loc.fixed, (n, nn, 3), bool),
                orientation=cat(loc.orientation, (n,), np.float64),
                local_blocks=np.full((n, nn), -1, dtype=np.int64),
                size=cat(loc.size, (n,), np.float64),
            )
        return self._gathered

    def local_displacement(self, u_array: np.ndarray) -> np.ndarray:
        """Displacement at the owned facets' nodes, (nf, nn, 3), from a ghosted local array."""
        return u_array.reshape(-1, 3)[self.local.local_blocks]

    def gathered_displacement(self, u_array: np.ndarray) -> np.ndarray:
        """Displacement at all facets' nodes in the order of :meth:`gathered` (collective)."""
        g = self.gathered()
        mine = np.ascontiguousarray(self.local_displacement(u_array))
        parts = self.comm.allgather(mine)
        return np.concatenate(parts).reshape(g.X.shape)
