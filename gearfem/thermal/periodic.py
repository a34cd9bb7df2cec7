"""Rotationally periodic cut faces: the temperature on a sector's end face tied to its start face.

A sector of n of the gear's z teeth heated alike on every tooth has a rotationally periodic
temperature field: T(R x) = T(x) for x on the start cut face and R the rotation by the sector's
angle 2 pi n / z. Adiabatic cut faces (the thesis's choice) are exact only when the field is
also mirror-symmetric about them, which drive-flank heating breaks (the teeth next to the cuts
of the thesis's 8-tooth sector are 2-4 K off the whole gear). With a mesh whose two cut faces
correspond node for node (``periodic_cuts``), the tie is exact in the discrete space of the
whole gear's periodic fields:

    T = P y,    P_ij = 1 when DOF i is DOF j or DOF i is on the end face and j its image's
                master on the start face, 0 otherwise,

with y the reduced unknowns (every DOF but the end face's). The discrete problem is the
Galerkin one on the periodic space: P^T F(P y) = 0, Newton with the Jacobian P^T J P. Summing
P^T F adds each end-face DOF's row to its master's: the flux leaving the sector through one cut
face enters through the other, and the heat balance (F tested with v = 1 = P 1) is unchanged.

Built once per problem from arrays (the cut faces' DOF coordinates gathered over the ranks,
their matching by a k-d tree). Parallel: P's rows follow the temperature space's ownership, its
columns number each rank's owned reduced DOFs consecutively.
"""

from __future__ import annotations

import numpy as np
from dolfinx import fem
from mpi4py import MPI
from petsc4py import PETSc
from scipy.spatial import cKDTree

from gearfem.core.errors import ParameterError

#: Largest distance between an end-face DOF and the image of its master, relative to the
#: sector's size: the meshes of the two faces must correspond (``periodic_cuts``), not nearly.
MATCH_TOLERANCE = 1e-9


class PeriodicTie:
    """The prolongation P from the reduced unknowns onto a sector's temperature DOFs (module
    docstring) and the products a Newton solve on the reduced system needs.

    Args:
        V: The scalar temperature space.
        domain: A :class:`~gearfem.thermal.domain.ThermalDomain` with ``periodic`` set; its
            ``cuts`` are (start, end), the end face the start face's image.

    Raises ParameterError when the faces' DOFs do not correspond one to one.
    """

    def __init__(self, V, domain) -> None:
        rot = domain.periodic
        if rot is None:
            raise ParameterError("domain.periodic", None, "a rotation for a periodic tie")
        comm = V.mesh.comm
        im = V.dofmap.index_map
        n_owned = im.size_local
        start_g = im.local_range[0]
        fdim = V.mesh.topology.dim - 1
        X = V.tabulate_dof_coordinates()

        def owned_dofs(name):
            facets = domain.facets((name,))
            dofs = fem.locate_dofs_topological(V, fdim, facets)
            return np.unique(dofs[dofs < n_owned])

        first, second = domain.cuts
        masters, slaves = owned_dofs(first), owned_dofs(second)
        if np.intersect1d(masters, slaves).size:
            raise ParameterError(
                "domain.cuts", domain.cuts, "two cut faces without common DOFs (a bore radius > 0)"
            )

        # reduced numbering: the owned DOFs that are not slaves, consecutively per rank
        is_slave = np.zeros(n_owned, dtype=bool)
        is_slave[slaves] = True
        n_red = int(n_owned - is_slave.sum())
        offset = comm.exscan(n_red) or 0
        red = np.full(n_owned, -1, dtype=np.int64)
        red[~is_slave] = offset + np.arange(n_red, dtype=np.int64)

        # every rank's masters (coordinates and reduced index) to every rank: the cut faces only
        all_x = np.concatenate(comm.allgather(X[masters]), axis=0).reshape(-1, 3)
        all_red = np.concatenate(comm.allgather(red[masters]))
        n_slaves = comm.allreduce(int(slaves.size), op=MPI.SUM)
        if n_slaves != all_red.size:
            raise ParameterError(
                "thermal mesh cut faces",
                f"{all_red.size} DOFs on {first}, {n_slaves} on {second}",
                "as many on each (mesh the sector with periodic_cuts = true)",
            )
        col = red.copy()
        mismatch = 0.0
        if slaves.size:
            # an end-face DOF's master: the start-face DOF whose image it is
            dist, idx = cKDTree(all_x).query(rot.preimage(X[slaves]))
            mismatch = float(dist.max())
            col[slaves] = all_red[idx]
            used = np.bincount(idx, minlength=all_red.size)
        else:
            used = np.zeros(all_red.size, dtype=np.int64)
        size = float(np.ptp(X[:n_owned], axis=0).max()) if n_owned else 0.0
        size = comm.allreduce(size, op=MPI.MAX)
        mismatch = comm.allreduce(mismatch, op=MPI.MAX)
        used = comm.allreduce(used, op=MPI.SUM)
        if mismatch > MATCH_TOLERANCE * size or (used.size and used.max() > 1):
            raise ParameterError(
                "thermal mesh cut faces",
                f"end-face DOFs {mismatch:.3g} m from the start face's turned DOFs",
                "faces meshed alike (`periodic_cuts = true` in the mesh table)",
            )

        # P: rows = owned DOFs in the space's global numbering, one entry 1 per row
        indptr = np.arange(n_owned + 1, dtype=PETSc.IntType)
        cols = col.astype(PETSc.IntType)
        vals = np.ones(n_owned, dtype=PETSc.ScalarType)
        N_red = comm.allreduce(n_red, op=MPI.SUM)
        self.P = PETSc.Mat().createAIJ(
            ((n_owned, im.size_global), (n_red, N_red)), csr=(indptr, cols, vals), comm=comm
        )
        self.P.assemble()
        # the injection: reduced value = the value of its own DOF (row j of R picks DOF j)
        rows_own = np.flatnonzero(~is_slave)
        self.R = PETSc.Mat().createAIJ(
            ((n_red, N_red), (n_owned, im.size_global)),
            csr=(
                np.arange(n_red + 1, dtype=PETSc.IntType),
                (start_g + rows_own).astype(PETSc.IntType),
                np.ones(n_red, dtype=PETSc.ScalarType),
            ),
            comm=comm,
        )
        self.R.assemble()
        self.num_reduced = N_red

    def create_vector(self) -> PETSc.Vec:
        """A vector of the reduced unknowns."""
        return self.P.createVecRight()

    def restrict(self, b: PETSc.Vec, out: PETSc.Vec) -> None:
        """out = P^T b (a residual onto the reduced unknowns: end-face rows added to their
        masters')."""
        self.P.multTranspose(b, out)

    def prolong(self, y: PETSc.Vec, out: PETSc.Vec) -> None:
        """out = P y (owned entries; the caller updates ghosts)."""
        self.P.mult(y, out)

    def inject(self, x: PETSc.Vec, out: PETSc.Vec) -> None:
        """out = R x: the reduced unknowns' own values of a sector field."""
        self.R.mult(x, out)

    def reduce_matrix(self, A: PETSc.Mat, out: PETSc.Mat | None = None) -> PETSc.Mat:
        """P^T A P: a new Mat (``out`` None; the caller destroys it), or into ``out``, a Mat
        this method returned for a matrix of A's pattern (the product's pattern is reused)."""
        if out is None:
            return A.PtAP(self.P)
        A.PtAP(self.P, out)
        return out

    def make_periodic(self, T) -> None:
        """Set the end face of the Function ``T`` from its start face (T <- P R T; collective)."""
        x = T.x.petsc_vec
        y = self.create_vector()
        self.inject(x, y)
        self.prolong(y, x)
        y.destroy()
        T.x.scatter_forward()

    def destroy(self) -> None:
        for m in (self.P, self.R):
            m.destroy()
