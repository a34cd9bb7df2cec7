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


@dataclasses.dataclass(frozen=True)
class PointTable:
    """The integration points of one interface from all ranks, in a partition-independent order.

    Rows are sorted by pass, then by reference position (rounded to 1e-9 of the interface's
    extent), so the table of a run on N ranks matches the serial one row by row (up to solver
    round-off).

    Attributes:
        slaves: Name of the slave surface of each pass (index with ``pass_index``).
        pass_index: (n,) pass of each point (0, 1).
        x: (n, 3) current position of the slave point, m.
        x_reference: (n, 3) the slave point without elastic displacement (its undeformed position,
            rigidly placed by the body's motion), m.
        normal: (n, 3) outward unit normal of the master surface at the projected point.
        gap: (n,) normal gap, m (negative: penetration).
        pressure: (n,) contact pressure, Pa.
        traction: (n, 3) traction on the slave surface, Pa (t = p n + shear; :attr:`shear`).
        weight: (n,) integration weight including the pass weight, m² (Σ weight·traction is the
            force on the slave surfaces, both passes combined).
    """

    slaves: tuple[str, ...]
    pass_index: np.ndarray
    x: np.ndarray
    x_reference: np.ndarray
    normal: np.ndarray
    gap: np.ndarray
    pressure: np.ndarray
    traction: np.ndarray
    weight: np.ndarray

    @property
    def num_points(self) -> int:
        return len(self.weight)

    @property
    def shear(self) -> np.ndarray:
        """(n, 3) tangential part of the traction on the slave, t − p n, Pa."""
        return self.traction - self.pressure[:, None] * self.normal


def gather_points(problem: ContactProblem, interface: int = 0) -> PointTable:
    """All ranks' integration points of the last solve on every rank (collective; for plots and
    tables of a few thousand points — the arrays are replicated)."""
    comm = problem.comm
    passes = problem.interfaces[interface].passes
    local = []
    for k, (ps, pts) in enumerate(zip(passes, problem.last_points[interface])):
        X = np.einsum("pk,pkd->pd", pts.Ns, ps.slave.local.X[pts.facet])
        X = problem.motions[ps.slave.body].place(X)
        local.append(
            np.column_stack(
                [
                    np.full(pts.num_points, float(k)),
                    X,
                    pts.x,
                    pts.normal,
                    pts.gap,
                    pts.pressure,
                    pts.traction,
                    pts.dA,
                ]
            )
        )
    mine = np.concatenate(local) if local else np.zeros((0, 16))
    rows = np.concatenate(comm.allgather(mine)) if comm.size > 1 else mine
    if len(rows):
        X = rows[:, 1:4]
        scale = max(float(np.ptp(X, axis=0).max()), 1e-300)
        key = np.round(X / (1e-9 * scale))
        rows = rows[np.lexsort((key[:, 2], key[:, 1], key[:, 0], rows[:, 0]))]
    return PointTable(
        slaves=tuple(ps.slave.name for ps in passes),
        pass_index=rows[:, 0].astype(np.int64),
        x_reference=rows[:, 1:4],
        x=rows[:, 4:7],
        normal=rows[:, 7:10],
        gap=rows[:, 10],
        pressure=rows[:, 11],
        traction=rows[:, 12:15],
        weight=rows[:, 15],
    )


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
        tuple(float(v) for v in fn),
        tuple(float(v) for v in ft),
        area,
        comm.allreduce(pmax, op=MPI.MAX),
        comm.allreduce(pen_max, op=MPI.MAX),
        pen_int / area if area > 0 else 0.0,
        comm.allreduce(n, op=MPI.SUM),
    )


def facet_fields(problem: ContactProblem, interface: int = 0):
    """DG0 facet fields ``contact_pressure`` (Pa) and ``contact_traction`` (Pa, vector)
    (collective).

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


def write_vtx(
    problem: ContactProblem, path: str | Path, interface: int = 0, time: float = 0.0
) -> Path:
    """Write the facet fields of :func:`facet_fields` to a VTX (.bp) folder for ParaView
    (collective)."""
    from dolfinx.io import VTXWriter

    sub, p, t = facet_fields(problem, interface)
    path = Path(path)
    with VTXWriter(sub.comm, path, [p, t], engine="BP4") as w:
        w.write(time)
    return path
