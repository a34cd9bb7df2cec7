"""Contact solved on the candidate contact surfaces only (condensed elastic bodies).

Model. The same problem as :class:`~gearfem.contact.problem.ContactProblem` — linear elastic
bodies in their own frames, rigid motions, GPTS contact with penalty or augmented Lagrangian
normal law and Coulomb friction, optionally a body whose rotation is held by a torque — with
loads only through contact and prescribed displacements. Each body's interior is then in
equilibrium with its candidate contact DOFs c (the nodes of its contact surfaces), and the exact
condensed relation f_c = S (u_c − ū_c) holds (:mod:`gearfem.contact.compliance`). The unknown is
the elastic force on c, g = S (u_c − ū_c), and u_c = ū_c + C g with the compliance C = S⁻¹:

    F(g, ψ) = g + R_c(ū_c + C g, ψ) = 0,     R_ψ(u_c, ψ) = −(M_contact + T) = 0,

R_c being the contact residual of the interfaces (the full residual K u − f + R_c restricted to c:
elsewhere it vanishes identically). Newton on F is Newton on the full system — its Jacobian
I + K_c C is the full Jacobian's Schur complement on c times C — so iterates, line search,
tolerances, Uzawa and slip-direction passes are those of the full solver (the outer loop is
inherited). K_c, the contact tangent, lives on the DOFs a of the active contact points only, so a
Newton direction costs one small dense LU:

    δg_r = −F_r,   (I + K_aa C_aa) δg_a = −F_a − K_aa (C δg_r)_a,   δu_c = C δg,

with the bordered torque row as in the full solver (two right-hand sides, one factorisation).

Volume field. After each solve the whole displacement follows by one solve per body with its
stored factor, u_f = ū_f + K_ff⁻¹ E_c g (back-substitution); strain energy and stresses are then
evaluated as for the full solver.

Surface set. Contact is only looked for on the interfaces' surfaces. ``guards`` are interfaces
between the surfaces left out and the other bodies: after each solve they are evaluated with the
back-substituted displacement, and a penetration there raises
:class:`~gearfem.core.errors.UncoveredContactError` naming the surfaces, the depth and the place.

Parallel. Contact points are evaluated by every rank on its own facets as in the full solver; the
dense algebra (C of every body, g, the active-set solve) lives on rank 0, which broadcasts the
direction δu_c. Each body's factor lives on its owner rank (body k on rank k mod size).
"""

from __future__ import annotations

import dataclasses
import logging
import time
from collections.abc import Mapping, Sequence

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
from dolfinx import fem
from mpi4py import MPI
from threadpoolctl import threadpool_limits

from gearfem.contact.compliance import ComplianceStore, Condensation, body_dofs
from gearfem.contact.interface import ContactInterface
from gearfem.contact.options import ContactOptions
from gearfem.contact.problem import ContactProblem, ControlledRotation, SolveReport
from gearfem.contact.rigid import RigidMotion
from gearfem.core.errors import (
    ConvergenceError,
    GearfemError,
    ParameterError,
    UncoveredContactError,
)
from gearfem.core.newton import newton_solve

log = logging.getLogger(__name__)

ROOT = Condensation.root

#: Iterative refinement with the last LU of the active-set system
#: (:meth:`CondensedContactProblem._active_solve`): accepted at this residual relative to the
#: right-hand side (a new LU leaves 1e-15 to 1e-13; Newton's own tolerance is 1e-9 of the forces
#: by default), within this many passes.
REFINE_RTOL = 1e-12
REFINE_PASSES = 6


@dataclasses.dataclass
class _CondensedState:
    """Residual and tangent data at one iterate. Dense arrays only on the root rank."""

    pts: list
    norm: float
    scale: float
    F: np.ndarray | None = None  # condensed residual g + R_c on c (root)
    rows: np.ndarray | None = None  # contact tangent COO in c numbering (root)
    cols: np.ndarray | None = None
    vals: np.ndarray | None = None
    k_up: np.ndarray | None = None  # ∂F/∂ψ (root)
    k_pu: np.ndarray | None = None  # ∂R_ψ/∂u_c (root)
    R_psi: float = 0.0
    moment_Nm: float = 0.0
    k_pp: float = 0.0

    def destroy(self) -> None:
        """Nothing to free (the full solver's state holds PETSc vectors)."""


@dataclasses.dataclass(frozen=True)
class Guard:
    """Contact surfaces left out of a condensed problem, checked after every solve.

    Attributes:
        interface: Between the surface left out (``a``) and what it could touch (``b``).
        labels: A name for each facet of ``a`` in its gathered order (e.g. ``"pinion tooth 6"``),
            used in the error.
    """

    interface: ContactInterface
    labels: np.ndarray


class CondensedContactProblem(ContactProblem):
    """:class:`ContactProblem` solved on the candidate contact DOFs of each body.

    Same arguments as :class:`ContactProblem` (no ``traction_form``: loads only through contact
    and prescribed displacements), plus:

    Args:
        bodies: Local cells of each body by name (the names the contact surfaces use); bodies
            are separate volumes of the mesh.
        store: Where compliances are kept between runs (None: computed every time).
        guards: Surfaces left out of ``interfaces`` and what they could touch (:class:`Guard`); a
            penetration there after a solve raises UncoveredContactError naming the facets' label.
        guard_hint: Added to that error (how to widen the surface set).
        share: With a problem on one rank (``V`` on a one-rank mesh): the communicator of the
            ranks that each hold their own copy of this problem; the compliances missing from the
            store are computed once among them (:class:`~gearfem.contact.compliance.Condensation`).
    """

    def __init__(
        self,
        V: fem.FunctionSpace,
        mu,
        lmbda,
        bcs: Sequence[fem.DirichletBC],
        interfaces: Sequence[ContactInterface],
        motions: dict[str, RigidMotion],
        options: ContactOptions,
        bodies: Mapping[str, np.ndarray],
        traction_form=None,
        petsc_options_prefix: str = "gearfem_condensed_",
        controlled: ControlledRotation | None = None,
        store: ComplianceStore | None = None,
        guards: Sequence[Guard] = (),
        guard_hint: str = "",
        share: MPI.Comm | None = None,
    ) -> None:
        if traction_form is not None:
            raise ParameterError(
                "traction_form",
                "a load form",
                "None with the condensed solver",
                "it condenses bodies loaded only through contact and prescribed displacements",
            )
        t0 = time.perf_counter()
        super().__init__(
            V,
            mu,
            lmbda,
            bcs,
            interfaces,
            motions,
            options,
            petsc_options_prefix=petsc_options_prefix,
            controlled=controlled,
        )
        # the full solver's KSP is not used: its options would be reported as unused
        self._options.clear()
        self.ksp.destroy()
        self.guards, self.guard_hint = list(guards), guard_hint
        mask = self.fixed_mask()
        contact: dict[str, list[np.ndarray]] = {b: [] for b in bodies}
        for itf in self.interfaces:
            for s in (itf.a, itf.b):
                if s.body not in contact:
                    raise ParameterError(
                        "bodies", sorted(bodies), f"a body named {s.body!r} (surface {s.name!r})"
                    )
                g = s.gathered()
                d = 3 * g.blocks[:, :, None] + np.arange(3)
                contact[s.body].append(d[~g.fixed].ravel())
        dofs = body_dofs(
            V,
            bodies,
            mask,
            {b: np.concatenate(v) if v else np.zeros(0, np.int64) for b, v in contact.items()},
        )
        self.condensation = Condensation(
            self.K_full, dofs, self.comm, store=store, prefix=petsc_options_prefix, share=share
        )
        self.body_dofs = dofs
        # the condensed unknowns: c of every body, body after body, canonical order within
        self.slices: dict[str, slice] = {}
        k = 0
        for name, b in dofs.items():
            self.slices[name] = slice(k, k + b.num_contact)
            k += b.num_contact
        self.num_condensed = k
        self.cdofs = np.concatenate([b.contact for b in dofs.values()])
        # global DOF -> index in c (-1: not a condensed unknown)
        n_global = V.dofmap.index_map.size_global * V.dofmap.index_map_bs
        self._c_of = np.full(n_global, -1, dtype=np.int64)
        self._c_of[self.cdofs] = np.arange(len(self.cdofs))
        # local DOFs (owned and ghost) that are condensed unknowns, and their index in c
        imap, bs = V.dofmap.index_map, V.dofmap.index_map_bs
        nloc = imap.size_local + imap.num_ghosts
        gl = imap.local_to_global(np.arange(nloc, dtype=np.int32)).astype(np.int64)
        self._global_local = (bs * gl[:, None] + np.arange(bs)).ravel()
        idx, found = self._index(self._global_local)
        self._uc_pos, self._uc_idx = np.nonzero(found)[0], idx[found]
        # local DOFs of each body's free set (for the back-substitution)
        self._free_local = {}
        for name, b in dofs.items():
            pos = np.searchsorted(b.free, self._global_local)
            pos = np.minimum(pos, len(b.free) - 1)
            hit = b.free[pos] == self._global_local if len(b.free) else np.zeros(nloc * bs, bool)
            self._free_local[name] = (np.nonzero(hit)[0], pos[hit])
        self.uc = np.zeros(self.num_condensed)  # every rank
        self.g = np.zeros(self.num_condensed) if self.comm.rank == ROOT else None
        self.ubar = np.zeros(self.num_condensed)  # every rank: response to u_D at c
        self._ubar_free: dict[str, np.ndarray] = {}  # owner: response to u_D on the free DOFs
        self._bc_signature: np.ndarray | None = None
        self.dense_factorizations = 0
        self.dense_solve_s = 0.0  # on the root: forming and solving the active-set systems
        self.direction_s = 0.0  # on the root: the whole Newton direction (incl. the above)
        self.state_s = 0.0  # this rank: contact residuals and tangents (:meth:`state`)
        self.active_sizes: list[int] = []  # active DOFs per Newton direction
        self.zone_sizes: list[int] = []  # condensed DOFs the segmentation reaches, per Newton solve
        self._zone: dict[str, tuple] = {}
        self._cg: tuple[np.ndarray, np.ndarray] | None = None  # root: the last (g, C g)
        self._lu: tuple[np.ndarray, tuple] | None = None  # root: the last (a, LU of I + K_aa C_aa)
        self.back_substitution_error = 0.0  # max |u_f(c) − u_c| / max |u_c| at the last solve
        self.setup_time_s = time.perf_counter() - t0

    # -------------------------------------------------------------------------------------------
    def _index(self, gdofs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Index in c of global DOFs, and whether each is in c."""
        idx = self._c_of[np.asarray(gdofs, dtype=np.int64)]
        return idx, idx >= 0

    def _to_c(self, gdofs: np.ndarray, vals: np.ndarray, what: str) -> tuple[np.ndarray, ...]:
        """Entries on global DOFs to c numbering; entries off c must be zero (Dirichlet)."""
        idx, found = self._index(gdofs)
        if not found.all():
            off = np.abs(vals[~found]).max(initial=0.0)
            if off > 0.0:
                raise GearfemError(
                    f"condensed contact: {what} has non-zero entries ({off:.3e}) on DOFs outside "
                    "the condensed set (a contact surface node the condensation does not hold)"
                )
        return idx[found], vals[found], found

    def write_uc(self) -> None:
        """Put u_c into the displacement array (the contact surfaces read only c nodes)."""
        self.u.x.array[self._uc_pos] = self.uc[self._uc_idx]

    # -------------------------------------------------------------------------------------------
    def _update_lift(self) -> None:
        """ū: the bodies' response to the Dirichlet values with no contact force (recomputed when
        the values change; zero for homogeneous supports)."""
        ua = self.u.x.array
        mask = self.fixed_mask()
        sig = ua[mask].copy()
        changed = self._bc_signature is None or not np.array_equal(sig, self._bc_signature)
        if not self.comm.allreduce(bool(changed), op=MPI.LOR):
            return
        self._bc_signature = sig
        if self.comm.allreduce(float(np.abs(sig).max(initial=0.0)), op=MPI.MAX) == 0.0:
            self.ubar[:] = 0.0
            self._ubar_free = {}
            return
        # f = −K_fD u_D: K times the vector of the Dirichlet values
        x = self.K_full.createVecRight()
        n_owned = len(x.array)
        x.array[:] = np.where(mask[:n_owned], ua[:n_owned], 0.0)
        y = self.K_full.createVecLeft()
        self.K_full.mult(x, y)
        for name, b in self.body_dofs.items():
            pos, idx = self._free_local[name]
            sel = pos < n_owned
            parts = self.comm.gather((idx[sel], -y.array[pos[sel]]), root=b.owner)
            ub = None
            if self.comm.rank == b.owner:
                rhs = np.zeros(len(b.free))
                for i, v in parts:
                    rhs[i] = v
                ub = self.condensation.solve(name, rhs)
                self._ubar_free[name] = ub
                ub = ub[b.contact_in_free]
            self.ubar[self.slices[name]] = self.comm.bcast(ub, root=b.owner)
        x.destroy()
        y.destroy()

    def back_substitute(self) -> None:
        """The whole displacement from g: u_f = ū_f + K_ff⁻¹ E_c g per body (collective)."""
        g = self.comm.bcast(self.g, root=ROOT)
        worst, scale = 0.0, float(np.abs(self.uc).max(initial=0.0))
        for name, b in self.body_dofs.items():
            uf = None
            if self.comm.rank == b.owner:
                rhs = np.zeros(len(b.free))
                rhs[b.contact_in_free] = g[self.slices[name]]
                uf = self.condensation.solve(name, rhs)
                if name in self._ubar_free:
                    uf += self._ubar_free[name]
                d = np.abs(uf[b.contact_in_free] - self.uc[self.slices[name]]).max(initial=0.0)
                worst = max(worst, float(d))
            uf = self.comm.bcast(uf, root=b.owner)
            pos, idx = self._free_local[name]
            self.u.x.array[pos] = uf[idx]
        self._apply_bc_values()
        self.back_substitution_error = self.comm.allreduce(worst, op=MPI.MAX) / max(scale, 1e-300)

    # -------------------------------------------------------------------------------------------
    def state(self, matrix: bool = True) -> _CondensedState:
        """Contact residual and tangent at the current u_c and motions (collective)."""
        t_start = time.perf_counter()
        self.write_uc()
        u_loc = self.u.x.array
        n = self.num_condensed
        ctl = self.controlled
        vec = np.zeros((3, n))  # residual, k_up, k_pu (local contributions)
        rows, cols, vals, pts_all = [], [], [], []
        M = kpp = 0.0
        for itf in self.interfaces:
            pts = itf.evaluate(u_loc, self.motions)
            (rd, rv), coo = itf.assemble(pts, self.motions, matrix)
            i, v, _ = self._to_c(rd, rv, "the contact residual")
            vec[0] += np.bincount(i, weights=v, minlength=n)
            if matrix:
                ri, rv2, found = self._to_c(coo[0], coo[2], "the contact tangent")
                ci, _, found_c = self._to_c(coo[1], coo[2], "the contact tangent")
                if not np.array_equal(found, found_c):
                    raise GearfemError("condensed contact: tangent entries off the condensed set")
                rows.append(ri)
                cols.append(ci)
                vals.append(rv2)
            pts_all.append(pts)
            if ctl is not None:
                m, k, (d1, v1), (d2, v2) = itf.rotation_terms(pts, self.motions, ctl.body)
                M, kpp = M + m, kpp + k
                if matrix:
                    i1, w1, _ = self._to_c(d1, v1, "the torque coupling")
                    i2, w2, _ = self._to_c(d2, v2, "the torque coupling")
                    vec[1] += np.bincount(i1, weights=w1, minlength=n)
                    vec[2] += np.bincount(i2, weights=w2, minlength=n)
        total = np.zeros_like(vec) if self.comm.rank == ROOT else None
        self.comm.Reduce(vec, total, op=MPI.SUM, root=ROOT)
        cat = lambda a, dt: np.concatenate(a).astype(dt) if a else np.zeros(0, dt)
        coo = (cat(rows, np.int64), cat(cols, np.int64), cat(vals, np.float64))
        gathered = self.comm.gather(coo, root=ROOT) if matrix else None
        st = _CondensedState(pts_all, 0.0, 0.0)
        if ctl is not None:
            st.moment_Nm = self.comm.allreduce(M, op=MPI.SUM)
            st.R_psi = -(st.moment_Nm + ctl.torque_Nm)
            st.k_pp = self.comm.allreduce(kpp, op=MPI.SUM)
        norm = scale = 0.0
        if self.comm.rank == ROOT:
            st.F = self.g + total[0]
            if matrix:
                st.rows = np.concatenate([c[0] for c in gathered])
                st.cols = np.concatenate([c[1] for c in gathered])
                st.vals = np.concatenate([c[2] for c in gathered])
                st.k_up, st.k_pu = total[1], total[2]
            norm = float(np.linalg.norm(st.F))
            if ctl is not None:
                norm = float(np.hypot(norm, st.R_psi / ctl.length_scale_m))
            # the force scale: the elastic forces on c (the full solver's ‖K u‖ also holds the
            # support reactions), or the applied torque over its lever
            scale = float(np.linalg.norm(self.g))
            if ctl is not None:
                scale = max(scale, abs(ctl.torque_Nm) / ctl.length_scale_m)
        st.norm, st.scale = self.comm.bcast((norm, scale), root=ROOT)
        self.state_s += time.perf_counter() - t_start
        return st

    def direction(self, st: _CondensedState, label: str, iteration: int):
        """Newton direction (δu_c, δψ) on every rank, δg on the root."""
        ctl = self.controlled
        du = dpsi = dg = stats = None
        failure = None
        if self.comm.rank == ROOT:
            try:
                du, dpsi, dg, stats = self._direction_root(st, label, iteration)
            except ConvergenceError as err:
                failure = (err.solver, err.reason, err.step, err.iteration)
        failure = self.comm.bcast(failure, root=ROOT)
        if failure is not None:  # raised on every rank
            raise ConvergenceError(*failure)
        du, dpsi, stats = self.comm.bcast((du, dpsi, stats), root=ROOT)
        self.dense_solve_s += stats[0]
        self.direction_s += stats[1]
        self.active_sizes.append(stats[2])
        self.linear_solves += 2 if ctl is not None else 1
        self.dense_factorizations += int(stats[3])
        self.factorizations += int(stats[3])
        return du, dpsi, dg

    def _direction_root(self, st: _CondensedState, label: str, iteration: int):
        """(δu_c, δψ, δg, (dense solve s, direction s, active DOFs, whether A was factorised))
        on the root; δu_c only on the zone Z (the nodes the frozen segmentation can reach:
        nothing else is read before :meth:`newton` refreshes u_c = ū + C g)."""
        t_start = time.perf_counter()
        ctl = self.controlled
        n = self.num_condensed
        on = np.zeros(n, dtype=bool)  # the active DOFs, sorted (a mask: no sort of the COO)
        on[st.rows] = True
        on[st.cols] = True
        a = np.nonzero(on)[0]
        pos = np.full(n, -1, dtype=np.int64)
        pos[a] = np.arange(len(a))
        Kaa = sp.csr_matrix((st.vals, (pos[st.rows], pos[st.cols])), shape=(len(a), len(a)))
        Y = -st.F[:, None] if ctl is None else -np.column_stack([st.F, st.k_up])
        X = Y.copy()
        X[a] = 0.0  # δg off the active DOFs: −F there
        Caa = np.zeros((len(a), len(a)))
        CXa = np.zeros((len(a), X.shape[1]))
        for name, sl in self.slices.items():
            zb, zpos, CZZ = self._zone[name]
            sel = (a >= sl.start) & (a < sl.stop)
            pa = zpos[a[sel] - sl.start]
            if (pa < 0).any():
                raise GearfemError("condensed contact: an active DOF outside the segmentation zone")
            Caa[np.ix_(sel, sel)] = CZZ[np.ix_(pa, pa)]
            CXa[sel] = self._c_times(name, X[sl], rows=pa)
        log.debug("%s Newton %d: %d active DOFs of %d", label, iteration, len(a), n)
        t_dense = time.perf_counter()
        rhs = Y[a] - Kaa @ CXa
        X[a], factored = self._active_solve(a, Kaa, Caa, rhs, label, iteration)
        if not np.isfinite(X).all():
            raise ConvergenceError(
                "condensed contact linear solve (dense LU)",
                "singular active-set system",
                step=label,
                iteration=iteration,
            )
        t_dense = time.perf_counter() - t_dense
        U = np.zeros_like(X)
        for name, sl in self.slices.items():
            zb = self._zone[name][0]
            U[sl][zb] = self._c_times(name, X[sl])
        # seconds, seconds, DOFs, whether a new factorisation was made
        stats = (t_dense, time.perf_counter() - t_start, len(a), factored)
        if ctl is None:
            return U[:, 0], 0.0, X[:, 0], stats
        D = st.k_pp + float(st.k_pu @ U[:, 1])
        if not (D > 0.0 and np.isfinite(D)):
            raise ConvergenceError(
                "contact Newton (torque control)",
                f"no rotational contact stiffness of {ctl.body!r} (k = {D:.3e} N m/rad): the body "
                "is not in contact; close the gap first (prescribe its angle)",
                step=label,
                iteration=iteration,
            )
        dpsi = -(st.R_psi + float(st.k_pu @ U[:, 0])) / D
        return U[:, 0] + dpsi * U[:, 1], dpsi, X[:, 0] + dpsi * X[:, 1], stats

    def _active_solve(
        self, a: np.ndarray, Kaa, Caa: np.ndarray, rhs: np.ndarray, label: str, iteration: int
    ) -> tuple[np.ndarray, bool]:
        """Solve (I + K_aa C_aa) x = rhs; returns x and whether A was factorised anew.

        While the active set a is the one of the last factorisation, that LU (of the tangent of
        an earlier iterate) preconditions iterative refinement on the current A, applied as
        x + K_aa (C_aa x) without forming it: each pass costs a few n² products instead of the
        n³ of a new LU and the sparse-times-dense product that forms A. The refinement is kept
        only when it converges to :data:`REFINE_RTOL` of the right-hand side, shrinking the
        residual at least twofold per pass, within :data:`REFINE_PASSES` passes; otherwise (and
        when a changed) A is formed and factorised, and the new LU kept for the next directions."""
        if self._lu is not None and np.array_equal(self._lu[0], a):
            x = self._refine(self._lu[1], Kaa, Caa, rhs)
            if x is not None:
                return x, False
        A = np.eye(len(a)) + Kaa @ Caa
        try:
            lu = sla.lu_factor(A, check_finite=True)
            x = sla.lu_solve(lu, rhs)
        except (ValueError, sla.LinAlgError) as err:
            raise ConvergenceError(
                "condensed contact linear solve (dense LU)",
                str(err),
                step=label,
                iteration=iteration,
            ) from err
        self._lu = (a.copy(), lu)
        return x, True

    @staticmethod
    def _refine(lu, Kaa, Caa: np.ndarray, rhs: np.ndarray) -> np.ndarray | None:
        """Iterative refinement of (I + K_aa C_aa) x = rhs preconditioned by ``lu``; None when it
        does not converge as :meth:`_active_solve` requires."""
        size = float(np.linalg.norm(rhs))
        if not np.isfinite(size):
            return None
        x = sla.lu_solve(lu, rhs)
        last = np.inf
        for _ in range(REFINE_PASSES):
            r = rhs - (x + Kaa @ (Caa @ x))
            norm = float(np.linalg.norm(r))
            if not np.isfinite(norm) or norm > 0.5 * last:
                return None
            if norm <= REFINE_RTOL * size:
                return x
            x = x + sla.lu_solve(lu, r)
            last = norm
        return None

    def _c_times(self, name: str, Xb: np.ndarray, rows: np.ndarray | None = None) -> np.ndarray:
        """(C_b X_b) on the zone rows of body ``name`` (or on the zone positions ``rows``).

        X_b vanishes off the DOFs contact has touched (g starts at 0; F_r is exactly 0 where no
        contact point acts), which lie in the zone but for forces left from earlier positions:
        the zone block C_ZZ does the bulk, the columns off the zone (few, if any) come from C."""
        zb, _, CZZ = self._zone[name]
        Zrows = CZZ if rows is None else CZZ[rows]
        out = Zrows @ Xb[zb]
        off = np.ones(len(Xb), bool)
        off[zb] = False
        t = np.nonzero(off & np.any(Xb != 0.0, axis=1))[0]
        if len(t):
            r = zb if rows is None else zb[rows]
            out += self.condensation.compliance[name][np.ix_(r, t)] @ Xb[t]
        return out

    def _set_zone(self) -> None:
        """The zone of the current segmentation: per body its c DOFs that the contact points can
        reach, and (root) the compliance block C_ZZ on them (collective)."""
        blocks = np.concatenate([itf.segmentation_blocks() for itf in self.interfaces])
        blocks = np.unique(np.concatenate(self.comm.allgather(blocks)))
        idx, found = self._index((3 * blocks[:, None] + np.arange(3)).ravel())
        zone = np.unique(idx[found])
        self._zone = {}
        for name, sl in self.slices.items():
            zb = zone[(zone >= sl.start) & (zone < sl.stop)] - sl.start
            zpos = np.full(sl.stop - sl.start, -1, dtype=np.int64)
            zpos[zb] = np.arange(len(zb))
            CZZ = None
            if self.comm.rank == ROOT:
                CZZ = self.condensation.compliance[name][np.ix_(zb, zb)]
            self._zone[name] = (zb, zpos, CZZ)
        self.zone_sizes.append(len(zone))

    # -------------------------------------------------------------------------------------------
    def newton(self, label: str = "", rtol: float | None = None) -> tuple[int, float]:
        """Solve for fixed multipliers and slip directions on the condensed unknowns; returns
        (iterations, final residual norm)."""
        o = self.options
        rtol = o.newton_rtol if rtol is None else rtol
        self._apply_bc_values()
        self._update_lift()
        if self.comm.rank == ROOT:
            self.uc = self.ubar + self._compliance_times(self.g)
        self.uc = self.comm.bcast(self.uc, root=ROOT)
        self.write_uc()
        for itf in self.interfaces:
            itf.update_segmentation(self.u.x.array, self.motions)
        self._set_zone()
        system = _CondensedSystem(self, rtol, label)
        report = newton_solve(system, self.newton_settings(), "contact Newton (condensed)", label)
        if report.stalled:
            self.stalled += 1
        self.last_points, self.last_state = system.state.pts, system.state
        # the directions updated u_c on the zone only: the whole of it from g
        if self.comm.rank == ROOT:
            self.uc = self.ubar + self._compliance_times(self.g)
        self.uc = self.comm.bcast(self.uc, root=ROOT)
        self.write_uc()
        return report.iterations, report.residual_norm

    def _compliance_times(self, g: np.ndarray) -> np.ndarray:
        """C g per body. g vanishes off the DOFs contact has touched: C is symmetric, so C g is
        the combination of C's rows at g's non-zeros (contiguous rows, not a full pass over C).
        The last product is kept: a Newton solve starts from the g the last one ended with (the
        Uzawa and slip-direction passes change the multipliers, not g), and each product reads a
        few hundred MB of C."""
        if self._cg is not None and np.array_equal(self._cg[0], g):
            return self._cg[1].copy()
        out = self._compliance_times_of(g)
        self._cg = (g.copy(), out.copy())
        return out

    def _compliance_times_of(self, g: np.ndarray) -> np.ndarray:
        out = np.empty_like(g)
        for name, sl in self.slices.items():
            C, gb = self.condensation.compliance[name], g[sl]
            nz = np.nonzero(gb)[0]
            out[sl] = gb[nz] @ C[nz] if 2 * len(nz) < len(gb) else C @ gb
        return out

    def solve(self, label: str = "") -> SolveReport:
        """Solve on the condensed unknowns (the full solver's outer loop), then recover the whole
        displacement and check the surfaces left out (collective)."""
        # small dense matrices: one BLAS thread (threads of several OpenBLAS pools in one process
        # spin against each other and against the other MPI ranks)
        with threadpool_limits(limits=1, user_api="blas"):
            rep = super().solve(label)
            t0 = time.perf_counter()
            self.back_substitute()
            self.check_guards(label)
        rep.wall_time_s += time.perf_counter() - t0
        return rep

    def check_guards(self, label: str) -> None:
        """Raise UncoveredContactError if a surface left out penetrates another body (checked with
        the whole displacement, after :meth:`back_substitute`; collective)."""
        u = self.u.x.array
        found: dict[str, list] = {}  # label -> [depth, x, points]
        for guard in self.guards:
            itf = guard.interface
            itf.update_segmentation(u, self.motions)
            offset = int(np.sum(self.comm.allgather(itf.a.local.num_facets)[: self.comm.rank]))
            for ps, pts in zip(itf.passes, itf.evaluate(u, self.motions)):
                bad = np.nonzero(np.isfinite(pts.gap) & (pts.gap < 0.0))[0]
                left_out = offset + pts.facet[bad] if ps.slave is itf.a else pts.mfacet[bad]
                for name in np.unique(guard.labels[left_out]):
                    sel = bad[guard.labels[left_out] == name]
                    k = sel[np.argmin(pts.gap[sel])]
                    depth, x = float(-pts.gap[k]), pts.x[k]
                    entry = found.setdefault(str(name), [0.0, x, 0, itf.b.name])
                    if depth > entry[0]:
                        entry[0], entry[1] = depth, x
                    entry[2] += len(sel)
        merged: dict[str, list] = {}
        for part in self.comm.allgather(found):
            for name, (depth, x, n, other) in part.items():
                e = merged.setdefault(name, [0.0, x, 0, other])
                if depth > e[0]:
                    e[0], e[1] = depth, x
                e[2] += n
        if merged:
            lines = [
                f"{name} penetrates {other} by {depth:.3e} m at x = ({x[0]:.5g}, {x[1]:.5g}, "
                f"{x[2]:.5g}) m ({n} integration points)"
                for name, (depth, x, n, other) in sorted(merged.items())
            ]
            raise UncoveredContactError(label, lines, self.guard_hint)

    @property
    def info(self) -> dict:
        """Sizes, timings and memory of the condensation (global values)."""
        ci = self.condensation.info
        return {
            "solver": "condensed",
            "condensed_dofs": dict(ci.contact_dofs),
            "body_free_dofs": dict(ci.free_dofs),
            "compliance_from_store": dict(ci.from_store),
            "compliance_MB_root": ci.compliance_MB,
            "factorization_s": ci.factor_s,
            "condensation_s": ci.condense_s,
            "condensed_setup_s": self.setup_time_s,
            "peak_rss_MB_after_condensation": ci.peak_rss_MB,
            "dense_factorizations": self.dense_factorizations,
            "zone_dofs_mean": float(np.mean(self.zone_sizes)) if self.zone_sizes else 0.0,
            "newton_directions": len(self.active_sizes),
            "active_dofs_mean": float(np.mean(self.active_sizes)) if self.active_sizes else 0.0,
            "dense_solve_s": self.dense_solve_s,
            "direction_s": self.direction_s,
            "state_s": self.state_s,
            "back_substitution_error": self.back_substitution_error,
        }


class _CondensedSystem:
    """One condensed contact Newton solve as a :class:`gearfem.core.newton.NewtonSystem` (the
    counterpart of the full solver's ``_ContactSystem``: same tolerance rule, stall rule and
    bordered torque row)."""

    def __init__(self, problem: CondensedContactProblem, rtol: float, label: str) -> None:
        self.p, self.rtol, self.label = problem, rtol, label
        self.state = problem.state(matrix=True)
        self.trial: _CondensedState | None = None
        self.du = None
        self.dg = None
        self.dpsi = 0.0
        self.uc0 = problem.uc.copy()
        self.g0 = problem.g.copy() if problem.g is not None else None
        self.psi0 = problem.controlled_angle if problem.controlled is not None else 0.0

    def residual_norm(self) -> float:
        return self.state.norm

    def tolerance(self) -> float:
        return max(self.rtol * self.state.scale, self.p.options.newton_atol_N)

    def compute_direction(self, iteration: int) -> None:
        p = self.p
        self.du, self.dpsi, self.dg = p.direction(self.state, self.label, iteration)
        self.uc0 = p.uc.copy()
        self.g0 = p.g.copy() if p.g is not None else None
        self.psi0 = p.controlled_angle if p.controlled is not None else 0.0

    def _set(self, alpha: float) -> None:
        p = self.p
        p.uc = self.uc0 + alpha * self.du
        if p.g is not None:
            p.g = self.g0 + alpha * self.dg
        if p.controlled is not None:
            p._set_controlled_angle(self.psi0 + alpha * self.dpsi)

    def try_step(self, alpha: float) -> float:
        self._set(alpha)
        self.trial = self.p.state(matrix=True)
        return self.trial.norm

    def accept(self) -> None:
        self.state, self.trial = self.trial, None

    def revert(self) -> None:
        self._set(0.0)
        self.p.write_uc()
        self.trial = None

    def accepts_stall(self, norm: float) -> bool:
        return norm <= self.p.options.newton_stall_rtol * self.state.scale

    def step_negligible(self, alpha: float) -> bool:
        return False
