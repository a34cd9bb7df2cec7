"""Gather a thermal model's temperature field to one rank, in an order independent of the
partition (collective; DOLFINx).

:class:`FieldRecorder` is built once per thermal problem: it gathers the mesh of the temperature
on rank 0 (nodes sorted by their coordinates, the cells, the tagged boundary faces oriented
outwards) and, each time :meth:`FieldRecorder.record` is called, the nodal temperatures. The
nodes are the dofs of the Lagrange space whose degree is the larger of the temperature's and the
geometry's (the temperature is interpolated into it exactly), so a quadratic mesh keeps its
curved faces. :meth:`FieldRecorder.body_field` returns the rank-0
:class:`~gearfem.instruments.snapshot.BodyField`. The result is the same on any number of ranks:
the node order comes from the coordinates, not from the partition.
"""

from __future__ import annotations

import numpy as np
from dolfinx import fem

from gearfem.geometry.mesh import parse_group_name
from gearfem.instruments.snapshot import KINDS, BodyField


def _gather(comm, arr: np.ndarray) -> np.ndarray | None:
    parts = comm.gather(np.ascontiguousarray(arr), root=0)
    return np.concatenate(parts) if comm.rank == 0 else None


def dof_coordinates(V) -> np.ndarray:
    """Coordinates of the dofs of a scalar Lagrange space (local, ghosts included). When the
    space is the mesh's coordinate element (same degree), these are the mesh's own node
    coordinates, exactly as read (so the same on every partition); otherwise the tabulated ones
    (computed per cell, equal across partitions to rounding)."""
    mesh = V.mesh
    tab = V.tabulate_dof_coordinates()
    if V.element.basix_element.degree != mesh.geometry.cmaps[0].degree:
        return tab
    node = np.empty(tab.shape[0], dtype=np.int64)
    node[V.dofmap.list.ravel()] = mesh.geometry.dofmaps[0].ravel()
    x = mesh.geometry.x[node]
    scale = float(np.max(np.abs(x))) if len(x) else 1.0
    if len(x) and np.max(np.abs(x - tab)) > 1e-9 * scale:
        raise RuntimeError("the Lagrange dof layout differs from the coordinate element's")
    return x


class FieldRecorder:
    """Snapshots of ``T`` (a Function on ``domain.mesh``) gathered on rank 0 (collective).

    Args:
        T: The temperature Function (kelvin).
        domain: Its :class:`gearfem.thermal.domain.ThermalDomain` (facet tags and group names).
    """

    def __init__(self, T, domain) -> None:
        mesh = T.function_space.mesh
        self.comm = mesh.comm
        tdim, fdim = mesh.topology.dim, mesh.topology.dim - 1
        degree = max(T.function_space.element.basix_element.degree, mesh.geometry.cmaps[0].degree)
        V = T.function_space
        if V.element.basix_element.degree != degree:
            V = fem.functionspace(mesh, ("Lagrange", degree))
        self._T = T
        self._V = V
        self._Ts = fem.Function(V) if V is not T.function_space else None
        im = V.dofmap.index_map
        n_owned = im.size_local
        self._n_owned = n_owned
        coords = dof_coordinates(V)[:n_owned]
        gdofs = im.local_to_global(np.arange(n_owned, dtype=np.int32))
        # cells (owned) as global dofs
        n_cells = mesh.topology.index_map(tdim).size_local
        cells = im.local_to_global(V.dofmap.list[:n_cells].ravel()).reshape(n_cells, -1)
        # tagged boundary facets (owned) with their closure dofs and the cell they bound
        mesh.topology.create_connectivity(fdim, tdim)
        mesh.topology.create_connectivity(tdim, fdim)
        f2c = mesh.topology.connectivity(fdim, tdim)
        c2f = mesh.topology.connectivity(tdim, fdim)
        ft = domain.facet_tags
        n_facets = mesh.topology.index_map(fdim).size_local
        sel = ft.indices < n_facets
        facets, values = ft.indices[sel], ft.values[sel]
        kind_of_tag = {}
        for name, tags in domain.groups.items():
            kind = parse_group_name(name)[2]
            if kind in KINDS:
                for t in tags:
                    kind_of_tag[int(t)] = KINDS.index(kind)
        keep = np.array([int(v) in kind_of_tag for v in values], dtype=bool)
        facets, values = facets[keep], values[keep]
        layout = V.dofmap.dof_layout
        closure = [layout.entity_closure_dofs(fdim, i) for i in range(4 if tdim == 3 else 3)]
        fdofs = np.empty((len(facets), len(closure[0])), dtype=np.int64)
        centroid = np.empty((len(facets), 3))
        x = mesh.geometry.x
        xdofs = mesh.geometry.dofmaps[0]
        for i, f in enumerate(facets):
            c = f2c.links(f)[0]
            local = int(np.flatnonzero(c2f.links(c) == f)[0])
            fdofs[i] = V.dofmap.cell_dofs(c)[closure[local]]
            centroid[i] = x[xdofs[c]].mean(axis=0)
        fdofs_g = im.local_to_global(fdofs.ravel().astype(np.int32)).reshape(fdofs.shape)
        kinds = np.array([kind_of_tag[int(v)] for v in values], dtype=np.int8)

        g_coords = _gather(self.comm, coords)
        g_ids = _gather(self.comm, gdofs.astype(np.int64))
        g_cells = _gather(self.comm, cells.astype(np.int64))
        g_fdofs = _gather(self.comm, fdofs_g.astype(np.int64))
        g_centroid = _gather(self.comm, centroid)
        g_kinds = _gather(self.comm, kinds)
        self._values: list[np.ndarray] = []
        self.labels: list[str] = []
        self.times_s: list[float | None] = []
        self.temperatures_C: dict[str, dict[str, float]] = {}
        self.heat_W: dict[str, dict[str, float]] = {}
        if self.comm.rank != 0:
            return
        order = np.lexsort((g_coords[:, 2], g_coords[:, 1], g_coords[:, 0]))
        self._order = order
        self.nodes_m = np.ascontiguousarray(g_coords[order])
        position = np.empty(int(g_ids.max()) + 1, dtype=np.int64)
        position[g_ids[order]] = np.arange(len(order))
        cells_s = position[g_cells]
        self.cells = cells_s[np.lexsort(np.sort(cells_s, axis=1).T[::-1])]
        faces = position[g_fdofs]
        # outward: counter-clockwise seen from outside, i.e. the normal points away from the cell
        p = self.nodes_m[faces[:, :3]]
        nrm = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
        flip = np.einsum("ij,ij->i", nrm, p.mean(axis=1) - g_centroid) < 0.0
        swap = [0, 2, 1] if faces.shape[1] == 3 else [0, 2, 1, 3, 5, 4]
        faces[flip] = faces[flip][:, swap]
        order_f = np.lexsort(np.sort(faces[:, :3], axis=1).T[::-1])
        self.faces = faces[order_f]
        self.face_kind = g_kinds[order_f]

    def record(
        self,
        label: str,
        time_s: float | None,
        temperatures_C: dict[str, float],
        heat_W: dict[str, float] | None = None,
    ) -> None:
        """Gather the current temperature as ``label`` (collective), with the thermal model's
        reported temperatures and, when given, the whole gear's heat sources at that time
        (``friction_W``, ``hysteresis_W``: what the torque meters read from)."""
        if self._Ts is not None:
            self._Ts.interpolate(self._T)
            arr = self._Ts.x.array
        else:
            arr = self._T.x.array
        vals = _gather(self.comm, arr[: self._n_owned].copy())
        if self.comm.rank == 0:
            if label in self.labels:  # a time recorded twice (the end is also an output time)
                i = self.labels.index(label)
                self._values[i] = vals[self._order]
            else:
                self._values.append(vals[self._order])
                self.labels.append(label)
                self.times_s.append(time_s)
            self.temperatures_C[label] = dict(temperatures_C)
            if heat_W is not None:
                self.heat_W[label] = dict(heat_W)

    def body_field(
        self,
        body: str,
        center_m,
        tooth_angles_rad,
        teeth: int,
        rotation_sense: int,
        speed_rpm: float,
        emissivity: float,
    ) -> BodyField | None:
        """The rank-0 snapshot of the body (None on the other ranks)."""
        if self.comm.rank != 0:
            return None
        return BodyField(
            body=body,
            nodes_m=self.nodes_m,
            cells=self.cells,
            faces=self.faces,
            face_kind=self.face_kind,
            temperature_K=np.stack(self._values)
            if self._values
            else np.zeros((0, len(self.nodes_m))),
            center_m=np.asarray(center_m, dtype=float),
            tooth_angles_rad=np.asarray(tooth_angles_rad, dtype=float),
            teeth=int(teeth),
            rotation_sense=int(rotation_sense),
            speed_rpm=float(speed_rpm),
            emissivity=float(emissivity),
            temperatures_C=dict(self.temperatures_C),
            heat_W=dict(self.heat_W),
        )


__all__ = ["FieldRecorder", "dof_coordinates"]
