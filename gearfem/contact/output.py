"""Contact results: totals, penetration statistics and facet fields for ParaView.

Point values (pressure, traction) live at the contact integration points. For visualisation they
are averaged per facet (area-weighted over the points on it, both passes combined) into DG0
functions on a submesh made of the contact facets, written with ``dolfinx.io.VTXWriter``.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
from mpi4py import MPI

from gearfem.contact.problem import ContactProblem


@dataclasses.dataclass(frozen=True)
class ContactSummary:
    """Global contact results of one interface (same on every rank). Forces act on surface ``a``."""

    normal_force_N: tuple[float, float, float]
    tangential_force_N: tuple[float, float, float]
    contact_area_m2: float
    max_pressure_Pa: float
    max_penetration_m: float
    mean_penetration_m: float  # area-weighted over the points in contact
    num_points_in_contact: int


def summary(problem: ContactProblem, interface: int = 0) -> ContactSummary:
    """Totals and penetration statistics of the last solve (collective)."""
    comm = problem.comm
    fn, ft = problem.contact_force(interface)
    area = pmax = pen_max = pen_int = 0.0
    n = 0
    for pts in problem.last_points[interface]:
        on = pts.pressure > 0.0
        area += float(np.sum(pts.dA[on]))
        pmax = max(pmax, float(pts.pressure.max(initial=0.0)))
        pen = np.where(on, np.maximum(-pts.gap, 0.0), 0.0)
        pen_max = max(pen_max, float(pen.max(initial=0.0)))
        pen_int += float(np.sum(pts.dA * pen))
        n += int(on.sum())
    area = comm.allreduce(area, op=MPI.SUM)
    pen_int = comm.allreduce(pen_int, op=MPI.SUM)
    return ContactSummary(
        tuple(float(v) for v in fn), tuple(float(v) for v in ft), area,
        comm.allreduce(pmax, op=MPI.MAX), comm.allreduce(pen_max, op=MPI.MAX),
        pen_int / area if area > 0 else 0.0, comm.allreduce(n, op=MPI.SUM),
    )


def facet_fields(problem: ContactProblem, interface: int = 0):
    """DG0 facet fields ``contact_pressure`` (Pa) and ``contact_traction`` (Pa, vector) (collective).

    Returns:
        (submesh, pressure, traction): the submesh of both surfaces' facets and the two Functions.
    """
    import dolfinx
    from dolfinx import fem

    itf = problem.interfaces[interface]
    mesh = problem.V.mesh
    tdim = mesh.topology.dim
    surfaces = [itf.a, itf.b]
    facets = np.unique(np.concatenate([s.facets for s in surfaces]))
    sub, emap, _, _ = dolfinx.mesh.create_submesh(mesh, tdim - 1, facets)
    Q = fem.functionspace(sub, ("DG", 0))
    W = fem.functionspace(sub, ("DG", 0, (3,)))
    p, t = fem.Function(Q, name="contact_pressure"), fem.Function(W, name="contact_traction")
    n_sub = sub.topology.index_map(tdim - 1).size_local
    acc_w = np.zeros(n_sub)
    acc_p = np.zeros(n_sub)
    acc_t = np.zeros((n_sub, 3))
    for ps, pts in zip(itf.passes, problem.last_points[interface]):
        if pts.num_points == 0:
            continue
        parent = ps.slave.facets[pts.facet].astype(np.int32)
        cells = emap.sub_topology_to_topology(parent, inverse=True)
        ok = (cells >= 0) & (cells < n_sub)
        np.add.at(acc_w, cells[ok], pts.dA[ok])
        np.add.at(acc_p, cells[ok], (pts.dA * pts.pressure)[ok])
        np.add.at(acc_t, cells[ok], (pts.dA[:, None] * pts.traction)[ok])
    nz = acc_w > 0
    p.x.array[:n_sub][nz] = acc_p[nz] / acc_w[nz]
    t.x.array.reshape(-1, 3)[:n_sub][nz] = acc_t[nz] / acc_w[nz, None]
    p.x.scatter_forward()
    t.x.scatter_forward()
    return sub, p, t


def write_vtx(problem: ContactProblem, path: str | Path, interface: int = 0, time: float = 0.0) -> Path:
    """Write the facet fields of :func:`facet_fields` to a VTX (.bp) folder for ParaView (collective)."""
    from dolfinx.io import VTXWriter

    sub, p, t = facet_fields(problem, interface)
    path = Path(path)
    with VTXWriter(sub.comm, path, [p, t], engine="BP4") as w:
        w.write(time)
    return path
