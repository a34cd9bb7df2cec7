"""Static condensation of an elastic body onto its candidate contact DOFs: the compliance.

Model. One body of small-strain linear elasticity, K u = f, held by Dirichlet conditions u_D.
Split its free DOFs into c, the nodes of the surfaces that may touch another body, and i, the
rest. Loads reach the body only through contact (on c) and through u_D, so the interior is in
equilibrium, K_ii u_i + K_ic u_c + K_iD u_D = 0, and eliminating it is exact (static
condensation):

    f_c = S (u_c − ū_c),    S = K_cc − K_ci K_ii⁻¹ K_ic   (Schur complement),

with ū the body's response to u_D when f_c = 0. The compliance C = S⁻¹ = [K_ff⁻¹]_cc holds the
influence coefficients: C_jk is the displacement of DOF j under a unit force on DOF k. C depends
on the mesh, the material and the supports of the body, never on the contact state, so it is
computed once per mesh and material and stored (:class:`ComplianceStore`).

Computation, one rank per body (:class:`Condensation`): the body's stiffness on its free DOFs is
extracted from the assembled distributed matrix onto its owner rank; MUMPS computes S during a
partial Cholesky factorisation (:func:`gearfem.core.petsc.schur_complement`) and C = S⁻¹ follows
by a dense Cholesky inverse (LAPACK potrf/potri). The owner also keeps a plain Cholesky factor of
the body for the volume field (back-substitution, u_f = K_ff⁻¹ f_f), which is not stored.

Names. A DOF is named by (mesh input node index, component) — 3·node + component — which does not
depend on the number of ranks or the partition, so a compliance computed on 2 ranks serves 1. The
c DOFs of a body are kept in the order of their names ("canonical order") everywhere, and a stored
compliance carries the names of its DOFs and a hash of the names of the body's fixed DOFs.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import logging
import os
import resource
import shutil
import tempfile
import time
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import scipy.linalg as sla
from mpi4py import MPI
from petsc4py import PETSc
from threadpoolctl import threadpool_limits

from gearfem.core.errors import ConvergenceError, ParameterError
from gearfem.core.petsc import cholesky_factor, schur_complement

log = logging.getLogger(__name__)

#: Columns per block of the compliance-by-solves route (a dense RHS block of n x 256 doubles).
SOLVE_BLOCK = 256


@dataclasses.dataclass(frozen=True)
class BodyDofs:
    """The DOFs of one body: this run's global (PETSc) numbers and their partition-free names.

    Attributes:
        name: Body name (as the contact surfaces call it).
        owner: Rank that holds the body's factorisation.
        free: Sorted global numbers of the body's free (not Dirichlet) DOFs.
        contact: Global numbers of its candidate contact DOFs c, in canonical order.
        contact_names: Names (3·input node + component) of c, ascending (canonical order).
        fixed_hash: Hash of the names of the body's Dirichlet DOFs (the supports).
    """

    name: str
    owner: int
    free: np.ndarray
    contact: np.ndarray
    contact_names: np.ndarray
    fixed_hash: str

    @property
    def num_contact(self) -> int:
        return len(self.contact)

    @property
    def contact_in_free(self) -> np.ndarray:
        """Positions of c in :attr:`free` (canonical order)."""
        return np.searchsorted(self.free, self.contact)

    def identity(self) -> str:
        """Hash of what the body's compliance depends on besides mesh and material: its c DOFs
        and its supports."""
        h = hashlib.sha256(self.name.encode())
        h.update(np.ascontiguousarray(self.contact_names, dtype=np.int64).tobytes())
        h.update(self.fixed_hash.encode())
        return h.hexdigest()[:16]


def dof_names(V) -> np.ndarray:
    """Name (3·mesh input node index + component) of every local DOF (owned and ghost) of the
    vector space V, whose nodes are the mesh geometry nodes (same degree as the geometry)."""
    mesh = V.mesh
    bs = V.dofmap.index_map_bs
    imap = V.dofmap.index_map
    nblocks = imap.size_local + imap.num_ghosts
    geo = np.full(nblocks, -1, dtype=np.int64)
    geo[np.asarray(V.dofmap.list).ravel()] = np.asarray(mesh.geometry.dofmaps[0]).ravel()
    if (geo < 0).any():
        raise ParameterError("displacement space", "nodes", "one DOF block per geometry node")
    xd = V.tabulate_dof_coordinates()[:nblocks]
    if not np.allclose(xd, mesh.geometry.x[geo], rtol=0.0, atol=1e-12 * np.ptp(mesh.geometry.x)):
        raise ParameterError(
            "displacement space", "nodes", "the mesh geometry nodes (same degree as the mesh)"
        )
    node = np.asarray(mesh.geometry.input_global_indices, dtype=np.int64)[geo]
    return (bs * node[:, None] + np.arange(bs)).ravel()


def body_dofs(
    V,
    cells: Mapping[str, np.ndarray],
    fixed: np.ndarray,
    contact_dofs: Mapping[str, np.ndarray],
) -> dict[str, BodyDofs]:
    """The :class:`BodyDofs` of every body (collective).

    Args:
        V: The vector displacement space of the mesh holding all bodies.
        cells: Local cells of each body (bodies are separate volumes: no shared nodes).
        fixed: Dirichlet mask over the local DOFs (:func:`gearfem.contact.problem.fixed_mask`).
        contact_dofs: Global numbers of each body's candidate contact DOFs (any order; fixed ones
            are dropped).
    """
    comm = V.mesh.comm
    imap, bs = V.dofmap.index_map, V.dofmap.index_map_bs
    names = dof_names(V)
    out = {}
    for k, (body, cl) in enumerate(cells.items()):
        blocks = np.unique(np.asarray(V.dofmap.list)[np.asarray(cl, dtype=np.int32)].ravel())
        local = (bs * blocks[:, None] + np.arange(bs)).ravel()
        gblocks = imap.local_to_global(blocks.astype(np.int32)).astype(np.int64)
        glob = (bs * gblocks[:, None] + np.arange(bs)).ravel()
        is_fixed = fixed[local]
        free = np.unique(np.concatenate(comm.allgather(glob[~is_fixed])))
        # names of every DOF of the body (global number -> name), gathered
        g_all = np.concatenate(comm.allgather(glob))
        n_all = np.concatenate(comm.allgather(names[local]))
        g_all, first = np.unique(g_all, return_index=True)
        n_all = n_all[first]
        fixed_names = np.unique(np.concatenate(comm.allgather(names[local][is_fixed])))
        c = np.unique(np.asarray(contact_dofs.get(body, np.zeros(0)), dtype=np.int64))
        c = c[np.isin(c, free)]  # Dirichlet components carry no unknown
        cn = n_all[np.searchsorted(g_all, c)]
        order = np.argsort(cn)
        out[body] = BodyDofs(
            name=body,
            owner=k % comm.size,
            free=free,
            contact=c[order],
            contact_names=cn[order],
            fixed_hash=hashlib.sha256(fixed_names.tobytes()).hexdigest()[:16],
        )
    return out


def spd_inverse(S: np.ndarray, what: str = "Schur complement", block: int = 512) -> np.ndarray:
    """Inverse of a symmetric positive definite matrix, computed in the storage of ``S`` (LAPACK
    potrf + potri on its lower triangle, then the upper triangle filled by blocks: no n²
    temporaries); raises ConvergenceError when it is not positive definite. ``S`` is consumed."""
    S = S.T if S.flags.c_contiguous else np.asfortranarray(S)  # symmetric: Sᵀ is S, in F order
    c, info = sla.lapack.dpotrf(S, lower=1, clean=0, overwrite_a=1)
    if info != 0:
        raise ConvergenceError(f"Cholesky factorisation of the {what}", f"LAPACK info {info}")
    inv, info = sla.lapack.dpotri(c, lower=1, overwrite_c=1)
    if info != 0:
        raise ConvergenceError(f"inverse of the {what}", f"LAPACK info {info}")
    n = inv.shape[0]
    for j0 in range(0, n, block):  # the lower triangle is the inverse's: mirror it
        j1 = min(n, j0 + block)
        inv[:j0, j0:j1] = inv[j0:j1, :j0].T
        tile = inv[j0:j1, j0:j1]
        inv[j0:j1, j0:j1] = np.tril(tile) + np.tril(tile, -1).T
    return inv.T  # C order (the inverse is symmetric)


def compliance_by_solves(factor: PETSc.PC, n: int, rows: np.ndarray) -> np.ndarray:
    """[K⁻¹]_rows,rows by one solve per column with the factor of K (blocks of
    :data:`SOLVE_BLOCK` right-hand sides): the reference the Schur route is checked against."""
    F = factor.getFactorMatrix()
    m = len(rows)
    C = np.empty((m, m))
    for j0 in range(0, m, SOLVE_BLOCK):
        cols = np.arange(j0, min(m, j0 + SOLVE_BLOCK))
        B = PETSc.Mat().createDense((n, len(cols)), comm=PETSc.COMM_SELF)
        B.setUp()
        b = B.getDenseArray()
        b[:] = 0.0
        b[rows[cols], np.arange(len(cols))] = 1.0
        B.assemble()
        X = PETSc.Mat().createDense((n, len(cols)), comm=PETSc.COMM_SELF)
        X.setUp()
        F.matSolve(B, X)
        C[:, cols] = X.getDenseArray()[rows, :]
        B.destroy()
        X.destroy()
    return 0.5 * (C + C.T)


# ------------------------------------------------------------------------------------------------
# storage
# ------------------------------------------------------------------------------------------------


class ComplianceStore:
    """Compliances on disk: ``<directory>/<key>/compliance.npy``, ``names.npy`` and ``meta.json``,
    written in a temporary directory renamed into place (a killed run never leaves a half entry;
    of two runs storing the same key at once, the first rename wins).

    ``key`` hashes ``context`` (what the caller knows the compliance depends on: the mesh key, the
    materials, the code) with the body's :meth:`BodyDofs.identity`.
    """

    def __init__(self, directory: str | Path, context: str) -> None:
        self.directory = Path(directory)
        self.context = str(context)

    def key(self, body: BodyDofs) -> str:
        h = hashlib.sha256(self.context.encode())
        h.update(body.identity().encode())
        return h.hexdigest()[:16]

    def path(self, body: BodyDofs) -> Path:
        return self.directory / self.key(body)

    def load(self, body: BodyDofs) -> np.ndarray | None:
        d = self.path(body)
        if not (d / "meta.json").is_file():
            return None
        names = np.load(d / "names.npy")
        if not np.array_equal(names, body.contact_names):
            log.warning("compliance %s: stored DOF names differ; recomputing", d)
            return None
        C = np.load(d / "compliance.npy", mmap_mode=None)
        log.info("compliance of %s from the store (%s, %d DOFs)", body.name, d, len(names))
        return C

    def save(self, body: BodyDofs, C: np.ndarray, info: Mapping[str, float]) -> Path:
        final = self.path(body)
        final.parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=".tmp-compliance-", dir=final.parent))
        np.save(tmp / "names.npy", body.contact_names)
        np.save(tmp / "compliance.npy", C)
        meta = {"body": body.name, "dofs": int(body.num_contact), "context": self.context}
        meta.update({k: float(v) for k, v in info.items()})
        (tmp / "meta.json").write_text(json.dumps(meta, indent=2))
        try:
            os.replace(tmp, final)
        except OSError:
            # another run (a study's other torque) stored the same key meanwhile: keep theirs
            shutil.rmtree(tmp, ignore_errors=True)
            if not (final / "meta.json").is_file():
                raise
        return final


# ------------------------------------------------------------------------------------------------
# the condensation of all bodies of a problem
# ------------------------------------------------------------------------------------------------


@dataclasses.dataclass
class CondensationInfo:
    """What the condensation cost and holds (global values)."""

    contact_dofs: dict[str, int]
    free_dofs: dict[str, int]
    from_store: dict[str, bool]
    factor_s: float  # plain Cholesky factorisations (max over ranks)
    condense_s: float  # Schur complements and inverses, or the store (max over ranks)
    compliance_MB: float  # dense compliance blocks held on the root rank
    peak_rss_MB: float  # peak resident memory after the condensation, max over ranks


class Condensation:
    """Per body: the factor of its stiffness (on its owner rank) and its compliance C (on the root
    rank, 0), from ``store`` when it holds them (collective).

    Args:
        K: Assembled elastic stiffness of all bodies (no Dirichlet rows; distributed).
        bodies: :func:`body_dofs` of each body.
        store: Optional :class:`ComplianceStore`.
        prefix: PETSc options prefix of the MUMPS factorisations.
        share: With ``comm`` of one rank: the communicator of the processes that each hold the
            same problem (every rank its own copy of the mesh, e.g. to solve different positions
            of a cycle). Each body's compliance missing from the store is then computed once, by
            rank k mod size of ``share`` for the k-th body, all at the same time, and broadcast;
            every rank factors every body for its own back-substitutions.
    """

    root = 0

    def __init__(
        self,
        K: PETSc.Mat,
        bodies: Mapping[str, BodyDofs],
        comm: MPI.Comm,
        store: ComplianceStore | None = None,
        prefix: str = "gearfem_condensed_",
        share: MPI.Comm | None = None,
    ) -> None:
        self.bodies, self.comm, self.store = dict(bodies), comm, store
        self.factors: dict[str, PETSc.PC] = {}
        self.matrices: dict[str, PETSc.Mat] = {}
        self.compliance: dict[str, np.ndarray] = {}
        self._scopes = []
        if share is not None and share.size > 1:
            if comm.size != 1:
                raise ParameterError(
                    "share",
                    f"a communicator of {share.size} ranks with a problem on {comm.size}",
                    "a problem on one rank (each rank of share holds its own copy)",
                )
            self._init_shared(K, share, prefix)
            return
        from_store, t_fact, t_cond = {}, 0.0, 0.0
        for b in self.bodies.values():
            mine = comm.rank == b.owner
            rows = b.free if mine else np.zeros(0, dtype=np.int64)
            isr = PETSc.IS().createGeneral(rows.astype(PETSc.IntType), comm=PETSc.COMM_SELF)
            (Kb,) = K.createSubMatrices(isr)  # collective; the owner gets the body's matrix
            isr.destroy()
            C = None
            if comm.rank == self.root and store is not None:
                C = store.load(b)
            have = comm.bcast(C is not None, root=self.root)
            from_store[b.name] = have
            if mine:
                t0 = time.perf_counter()
                pc, scope = cholesky_factor(Kb, prefix + f"{b.name}_")
                self.factors[b.name], self.matrices[b.name] = pc, Kb
                self._scopes.append(scope)
                t_fact += time.perf_counter() - t0
                if not have:
                    t0 = time.perf_counter()
                    with threadpool_limits(1, "blas"):
                        C, info = self._compute(Kb, b, prefix)
                    t_cond += time.perf_counter() - t0
                    if store is not None:
                        store.save(b, C, info)
            else:
                Kb.destroy()
            if not have and b.owner != self.root:  # move the computed block to the root
                if mine:
                    comm.Send(np.ascontiguousarray(C), dest=self.root, tag=77)
                    C = None
                elif comm.rank == self.root:
                    C = np.empty((b.num_contact, b.num_contact))
                    comm.Recv(C, source=b.owner, tag=77)
            if comm.rank == self.root:
                self.compliance[b.name] = C
        self._finish_info(comm, from_store, t_fact, t_cond)

    def _init_shared(self, K: PETSc.Mat, share: MPI.Comm, prefix: str) -> None:
        """Every rank of ``share`` holds the whole problem: compliances computed once (body k by
        rank k mod size, concurrently) and broadcast; every body factored on every rank."""
        store = self.store
        matrices, loaded = {}, {}
        for b in self.bodies.values():
            isr = PETSc.IS().createGeneral(b.free.astype(PETSc.IntType), comm=PETSc.COMM_SELF)
            (matrices[b.name],) = K.createSubMatrices(isr)
            isr.destroy()
            loaded[b.name] = store.load(b) if store is not None else None
        # the same store on every rank: computed only when no rank found it
        have = {n: share.allreduce(C is not None, op=MPI.LAND) for n, C in loaded.items()}
        t_fact = t_cond = 0.0
        for k, b in enumerate(self.bodies.values()):
            if not have[b.name] and share.rank == k % share.size:
                t0 = time.perf_counter()
                with threadpool_limits(1, "blas"):
                    C, info = self._compute(matrices[b.name], b, prefix)
                t_cond += time.perf_counter() - t0
                if store is not None:
                    store.save(b, C, info)
                loaded[b.name] = C
        for b in self.bodies.values():
            t0 = time.perf_counter()
            pc, scope = cholesky_factor(matrices[b.name], prefix + f"{b.name}_")
            self.factors[b.name], self.matrices[b.name] = pc, matrices[b.name]
            self._scopes.append(scope)
            t_fact += time.perf_counter() - t0
        for k, b in enumerate(self.bodies.values()):
            if not have[b.name]:
                C = loaded[b.name] if share.rank == k % share.size else None
                if C is None:
                    C = np.empty((b.num_contact, b.num_contact))
                share.Bcast(C, root=k % share.size)
                loaded[b.name] = C
            self.compliance[b.name] = loaded[b.name]
        self._finish_info(share, have, t_fact, t_cond)

    def _finish_info(self, comm: MPI.Comm, from_store, t_fact: float, t_cond: float) -> None:
        rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
        self.info = CondensationInfo(
            contact_dofs={n: b.num_contact for n, b in self.bodies.items()},
            free_dofs={n: len(b.free) for n, b in self.bodies.items()},
            from_store=dict(from_store),
            factor_s=comm.allreduce(t_fact, op=MPI.MAX),
            condense_s=comm.allreduce(t_cond, op=MPI.MAX),
            compliance_MB=comm.bcast(
                sum(C.nbytes for C in self.compliance.values()) / 2**20, root=self.root
            ),
            peak_rss_MB=comm.allreduce(rss, op=MPI.MAX),
        )

    @staticmethod
    def _compute(Kb: PETSc.Mat, b: BodyDofs, prefix: str) -> tuple[np.ndarray, dict[str, float]]:
        t0 = time.perf_counter()
        S = schur_complement(Kb, b.contact_in_free, prefix + f"{b.name}_schur_")
        t1 = time.perf_counter()
        C = spd_inverse(S, f"Schur complement of {b.name}")
        t2 = time.perf_counter()
        log.info(
            "compliance of %s: %d contact DOFs of %d, Schur complement %.1f s, inverse %.1f s",
            b.name,
            b.num_contact,
            len(b.free),
            t1 - t0,
            t2 - t1,
        )
        return C, {"schur_s": t1 - t0, "inverse_s": t2 - t1}

    def solve(self, body: str, rhs: np.ndarray) -> np.ndarray:
        """K_ff⁻¹ rhs for ``body`` (on its owner rank; rhs over its free DOFs)."""
        pc = self.factors[body]
        b = self.matrices[body].createVecLeft()
        x = b.duplicate()
        b.array[:] = rhs
        pc.apply(b, x)
        out = x.array.copy()
        b.destroy()
        x.destroy()
        return out

    def destroy(self) -> None:
        for pc in self.factors.values():
            pc.destroy()
        for m in self.matrices.values():
            m.destroy()
        for s in self._scopes:
            s.clear()
        self.factors, self.matrices, self._scopes = {}, {}, []
