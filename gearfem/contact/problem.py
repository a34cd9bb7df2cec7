"""Small-strain elasticity of several bodies in one mesh with contact between them.

The elastic operator is assembled once (it is linear and constant in each body frame); contact
adds a residual and a tangent that change with the configuration. Newton's method with
backtracking line search solves R(u) = K u − f + R_c(u) = 0 with MUMPS LU on K + K_c (non-symmetric
when there is friction). The augmented Lagrangian wraps Newton in Uzawa updates of the contact
multipliers until the largest penetration is below the tolerance.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import time
from collections.abc import Sequence

import numpy as np
from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc
from mpi4py import MPI
from petsc4py import PETSc

from gearfem.contact.elasticity import elastic_stress, stiffness_form
from gearfem.contact.interface import ContactInterface, ContactPoints
from gearfem.contact.options import ContactOptions
from gearfem.contact.rigid import RigidMotion
from gearfem.core.errors import ConvergenceError
from gearfem.core.newton import NewtonSettings, newton_solve
from gearfem.core.petsc import ksp_reason, set_options

log = logging.getLogger(__name__)

__all__ = ["ContactProblem", "ControlledRotation", "SolveReport", "elastic_stress", "fixed_mask"]


@dataclasses.dataclass(frozen=True)
class ControlledRotation:
    """A body whose rotation about its motion axis is unknown, held by an external torque.

    The equation added to the system is: moment of the contact forces on the body about its axis
    + ``torque_Nm`` = 0 (``torque_Nm`` acts on the body about +axis, e.g. the resisting torque of a
    driven gear). ``length_scale_m`` (a typical lever, such as the base radius) converts the moment
    residual to a force for the convergence test.
    """

    body: str
    torque_Nm: float
    length_scale_m: float


@dataclasses.dataclass
class _State:
    """Residual and tangent data at one iterate."""

    R: PETSc.Vec
    pts: list
    coos: list
    R_psi: float = 0.0
    moment_Nm: float = 0.0
    k_up: PETSc.Vec | None = None
    k_pu: PETSc.Vec | None = None
    k_pp: float = 0.0

    def destroy(self) -> None:
        for v in (self.R, self.k_up, self.k_pu):
            if v is not None:
                v.destroy()


@dataclasses.dataclass
class SolveReport:
    """What one contact solve did (all values global)."""

    label: str
    newton_iterations: int
    uzawa_iterations: int
    residual_norm: float
    max_penetration_m: float  # at the integration points, after the last solve
    wall_time_s: float
    linear_solves: int
    constraint_penetration_m: float = (
        0.0  # at the multiplier points, where the AL enforces the limit
    )
    stalled: int = 0  # Newton passes accepted at a stall (ContactOptions.newton_stall_rtol)


class ContactProblem:
    """Elastic bodies + contact interfaces, solved by Newton (+ Uzawa for the augmented Lagrangian).

    Args:
        V: Vector Lagrange space (degree = mesh geometry degree) on the mesh holding all bodies.
        mu, lmbda: Lamé parameters (floats, Constants or DG0 Functions), Pa.
        bcs: Dirichlet conditions in the body frames (their values may be changed between solves).
        interfaces: Contact interfaces.
        motions: Rigid motion of every body by name (changeable between solves, :meth:`set_motion`).
        options: Contact and Newton options.
        controlled: Optional body whose rotation is an unknown held by a torque (bordered Newton).
        traction_form: Optional linear form of external loads (N), assembled once.
        petsc_options_prefix: Prefix of this problem's PETSc options (KSP/PC/MUMPS).
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
        traction_form=None,
        petsc_options_prefix: str = "gearfem_contact_",
        controlled: ControlledRotation | None = None,
    ) -> None:
        self.V, self.options = V, options
        self.controlled = controlled
        self.last_state: _State | None = None
        self.comm: MPI.Comm = V.mesh.comm
        self.bcs = list(bcs)
        self.interfaces = list(interfaces)
        self.motions = dict(motions)
        self.u = fem.Function(V, name="displacement")
        self.a = fem.form(stiffness_form(V, mu, lmbda))
        self.K_full = fem_petsc.assemble_matrix(self.a)  # for residuals (no BC rows)
        self.K_full.assemble()
        self._K_bc: PETSc.Mat | None = None  # Jacobian base (BC rows: identity), when first needed
        self.f_ext = self.K_full.createVecLeft()
        if traction_form is not None:
            fem_petsc.assemble_vector(self.f_ext, fem.form(traction_form))
            self.f_ext.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        self._bc_rows = self._owned_bc_rows()
        # Linear solver: GMRES preconditioned by MUMPS LU factors. When the factors are those of the
        # current Jacobian GMRES converges in one iteration; with factorization reuse they may be
        # those of an earlier Jacobian of the same problem (see ContactOptions.reuse_factorization).
        self.ksp = PETSc.KSP().create(self.comm)
        self.ksp.setOptionsPrefix(petsc_options_prefix)
        defaults = {
            "ksp_type": "gmres",  # Krylov wrapper around the (possibly lagged) direct solve
            "ksp_gmres_restart": 100,
            "ksp_pc_side": "right",  # residual-based stopping on the true residual
            "pc_type": "lu",
            "pc_factor_mat_solver_type": "mumps",
            "mat_mumps_icntl_14": 200,  # workspace increase (%) for contact fill-in
            # detect null pivots: report singular systems instead of garbage
            "mat_mumps_icntl_24": 1,
        }
        # gearfem's defaults under whatever the user set for this prefix (core.petsc)
        self._options = set_options(petsc_options_prefix, defaults)
        self.ksp.setFromOptions()
        self.ksp.setTolerances(rtol=options.krylov_rtol, atol=0.0, max_it=options.max_krylov_its)
        self.ksp.setNormType(PETSc.KSP.NormType.UNPRECONDITIONED)
        self._P: PETSc.Mat | None = None  # matrix whose factors precondition
        self._refactor = False
        self.factorizations = 0
        self.linear_solves = 0
        self.stalled = 0  # Newton solves accepted at a stall (see ContactOptions.newton_stall_rtol)
        self.last_points: list[list[ContactPoints]] = []

    @property
    def K_bc(self) -> PETSc.Mat:
        """The elastic stiffness with identity rows at the Dirichlet DOFs (the Jacobian's base;
        assembled on first use)."""
        if self._K_bc is None:
            self._K_bc = fem_petsc.assemble_matrix(self.a, bcs=self.bcs)
            self._K_bc.assemble()
        return self._K_bc

    # -------------------------------------------------------------------------------------------
    def _owned_bc_rows(self) -> np.ndarray:
        imap, bs = self.V.dofmap.index_map, self.V.dofmap.index_map_bs
        n_owned = imap.size_local * bs
        rows = []
        for bc in self.bcs:
            dofs, n = bc.dof_indices()
            rows.append(dofs[:n])
        loc = np.unique(np.concatenate(rows)) if rows else np.zeros(0, np.int32)
        loc = loc[loc < n_owned]
        return (loc + imap.local_range[0] * bs).astype(PETSc.IntType)

    def fixed_mask(self) -> np.ndarray:
        """Boolean mask of Dirichlet dofs over the local (owned + ghost) dof array."""
        return fixed_mask(self.V, self.bcs)

    def set_motion(self, body: str, motion: RigidMotion) -> None:
        self.motions[body] = motion

    def _apply_bc_values(self) -> None:
        for bc in self.bcs:
            bc.set(self.u.x.array)
        self.u.x.scatter_forward()

    # -------------------------------------------------------------------------------------------
    def residual(self, u_vec: PETSc.Vec, matrix: bool) -> _State:
        """R(u) (and R_ψ), the contact points per interface, and tangent data (collective)."""
        u_loc = self.u.x.array
        st = _State(self.K_full.createVecLeft(), [], [])
        self.K_full.mult(u_vec, st.R)
        st.R.axpy(-1.0, self.f_ext)
        ctl = self.controlled
        if ctl is not None and matrix:
            st.k_up, st.k_pu = st.R.duplicate(), st.R.duplicate()
            st.k_up.set(0.0)
            st.k_pu.set(0.0)
        M = kpp = 0.0
        for itf in self.interfaces:
            pts = itf.evaluate(u_loc, self.motions)
            (rd, rv), coo = itf.assemble(pts, self.motions, matrix)
            st.R.setValues(rd.astype(PETSc.IntType), rv, addv=PETSc.InsertMode.ADD_VALUES)
            st.pts.append(pts)
            st.coos.append(coo)
            if ctl is not None:
                m, k, (d1, v1), (d2, v2) = itf.rotation_terms(pts, self.motions, ctl.body)
                M, kpp = M + m, kpp + k
                if matrix:
                    st.k_up.setValues(
                        d1.astype(PETSc.IntType), v1, addv=PETSc.InsertMode.ADD_VALUES
                    )
                    st.k_pu.setValues(
                        d2.astype(PETSc.IntType), v2, addv=PETSc.InsertMode.ADD_VALUES
                    )
        vecs = [st.R] + ([st.k_up, st.k_pu] if st.k_up is not None else [])
        for v in vecs:
            v.assemblyBegin()
            v.assemblyEnd()
            if len(self._bc_rows):
                v.setValues(
                    self._bc_rows, np.zeros(len(self._bc_rows)), addv=PETSc.InsertMode.INSERT_VALUES
                )
                v.assemblyBegin()
                v.assemblyEnd()
        if ctl is not None:
            M = self.comm.allreduce(M, op=MPI.SUM)
            st.moment_Nm = M
            st.R_psi = -(M + ctl.torque_Nm)
            st.k_pp = self.comm.allreduce(kpp, op=MPI.SUM)
        return st

    def _norm(self, st: _State) -> float:
        if self.controlled is None:
            return st.R.norm()
        return float(np.hypot(st.R.norm(), st.R_psi / self.controlled.length_scale_m))

    def _jacobian(self, coos) -> PETSc.Mat:
        rows = np.concatenate([c[0] for c in coos if c is not None] or [np.zeros(0, np.int64)])
        cols = np.concatenate([c[1] for c in coos if c is not None] or [np.zeros(0, np.int64)])
        vals = np.concatenate([c[2] for c in coos if c is not None] or [np.zeros(0)])
        Kc = PETSc.Mat().create(self.comm)
        Kc.setSizes(self.K_bc.getSizes())
        Kc.setType(PETSc.Mat.Type.AIJ)
        Kc.setPreallocationCOO(rows.astype(PETSc.IntType), cols.astype(PETSc.IntType))
        Kc.setValuesCOO(vals, addv=PETSc.InsertMode.ADD_VALUES)
        Kc.assemble()
        A = self.K_bc.copy()
        A.axpy(1.0, Kc, structure=PETSc.Mat.Structure.DIFFERENT_NONZERO_PATTERN)
        Kc.destroy()
        return A

    def _linear_solve(self, A: PETSc.Mat, b: PETSc.Vec, x: PETSc.Vec, label: str, it: int) -> None:
        """Solve A x = b with GMRES + LU factors (reused from an earlier A while they work)."""
        reuse = self.options.reuse_factorization and self._P is not None and not self._refactor
        for _attempt in range(2):
            if not reuse:
                if self._P is not None:
                    self._P.destroy()
                self._P = A.copy()
                self.factorizations += 1
            self.ksp.setOperators(A, self._P)
            x.set(0.0)
            self.ksp.solve(b, x)
            self.linear_solves += 1
            reason = self.ksp.getConvergedReason()
            if reason > 0:
                its = self.ksp.getIterationNumber()
                log.debug(
                    "%s Newton %d: linear solve %d GMRES its (%s factors)",
                    label,
                    it,
                    its,
                    "reused" if reuse else "new",
                )
                # factors that needed many iterations are replaced at the next solve
                self._refactor = its > self.options.refactor_krylov_its
                return
            if not reuse:
                break
            reuse = False  # the old factors no longer precondition well enough: refactor
        raise ConvergenceError(
            "contact linear solve (GMRES + MUMPS LU)",
            ksp_reason(reason),
            step=label,
            iteration=it,
        )

    def _force_scale(self, u_vec: PETSc.Vec) -> float:
        """Norm of the internal forces K u (reactions included), or the applied torque over the
        lever: the scale of the residual."""
        f = self.K_full.createVecLeft()
        self.K_full.mult(u_vec, f)
        s = f.norm()
        f.destroy()
        s = max(s, self.f_ext.norm())
        if self.controlled is not None:
            s = max(s, abs(self.controlled.torque_Nm) / self.controlled.length_scale_m)
        return s

    @property
    def controlled_angle(self) -> float:
        """Current rotation angle (rad) of the torque-controlled body."""
        return self.motions[self.controlled.body].angle_rad

    def _set_controlled_angle(self, angle: float) -> None:
        body = self.controlled.body
        self.motions[body] = dataclasses.replace(self.motions[body], angle_rad=float(angle))

    def newton_settings(self) -> NewtonSettings:
        """How the contact Newton iterates (backtracking on the residual norm, a stall accepted
        below ``newton_stall_rtol``)."""
        o = self.options
        return NewtonSettings(
            max_it=o.newton_max_it,
            line_search="backtracking",
            max_halvings=11 if o.line_search else 0,
            armijo=1e-4,
            accept_below_tolerance=True,
            on_line_search_failure="keep_last",
            min_iterations=1,
        )

    def newton(self, label: str = "", rtol: float | None = None) -> tuple[int, float]:
        """Solve for fixed multipliers; returns (iterations, final residual norm).

        ``rtol`` overrides ``options.newton_rtol`` (looser solves inside the Uzawa loop).

        With a torque-controlled body the unknowns are (u, ψ) and each iteration solves the
        bordered system [[J, k_uψ], [k_ψuᵀ, k_ψψ]] by two solves with the same factors:
        J a = −R_u, J b = −k_uψ, δψ = −(R_ψ + k_ψu·a) / (k_ψψ + k_ψu·b), δu = a + δψ b.
        """
        o = self.options
        rtol = o.newton_rtol if rtol is None else rtol
        self._apply_bc_values()
        for itf in self.interfaces:
            itf.update_segmentation(self.u.x.array, self.motions)
        system = _ContactSystem(self, rtol, label)
        try:
            report = newton_solve(system, self.newton_settings(), "contact Newton", label)
        except ConvergenceError:
            system.free()
            raise
        if report.stalled:
            self.stalled += 1
        self.last_points, self.last_state = system.state.pts, system.state
        system.free(keep_state=True)
        return report.iterations, report.residual_norm

    def solve(self, label: str = "") -> SolveReport:
        """Solve the contact problem at the current BC values and rigid motions (collective)."""
        t0 = time.perf_counter()
        ls0, st0 = self.linear_solves, self.stalled
        total_it, uz, pen, rnorm, constraint_pen = 0, 0, 0.0, 0.0, 0.0
        o = self.options
        al = o.method == "augmented_lagrangian"
        friction = o.friction_coefficient > 0.0
        tol = (
            min(itf.penetration_tolerance() for itf in self.interfaces)
            if (al and self.interfaces)
            else np.inf
        )
        # Outer loop: Newton with frozen multipliers and slip directions, then update both
        # (Uzawa for the multipliers; a fixed point for the slip directions) until the penetration
        # and the change of the slip directions are within tolerance. Intermediate Newton solves
        # may be loose; the last one is tightened.
        # After max_uzawa passes whose penetration is within tolerance but whose slip directions
        # still change, the multipliers are held for up to max_uzawa more passes while the
        # directions settle: near the pitch point (|v_T| ~ v_ε, a few µm from it) a multiplier
        # update that moves the surfaces by a fraction of the penetration tolerance turns the
        # directions by a few 1e-2, and the coupled iteration can cycle there with period 2.
        # Runs that converge within max_uzawa passes are solved exactly as without this.
        loose = max(o.uzawa_newton_rtol, o.newton_rtol) if (al or friction) else o.newton_rtol
        for uz in range(1, 2 * o.max_uzawa + 1):
            its, rnorm = self.newton(f"{label} (outer {uz})", rtol=loose)
            total_it += its
            # penetration where the multipliers live (the fixed points; measured before updating
            # them)
            hold = tol if uz > o.max_uzawa else None
            pen = (
                max(
                    (
                        itf.update_multipliers(self.u.x.array, self.motions, hold)
                        for itf in self.interfaces
                    ),
                    default=0.0,
                )
                if al
                else 0.0
            )
            dslip = (
                max(
                    (itf.update_slip(self.u.x.array, self.motions) for itf in self.interfaces),
                    default=0.0,
                )
                if friction
                else 0.0
            )
            log.debug(
                "%s outer %d: max penetration at the multiplier points %.3e m (tol %.3e m), slip "
                "direction "
                "change %.2e (tol %.2e)",
                label,
                uz,
                pen,
                tol,
                dslip,
                o.slip_tolerance,
            )
            if pen <= tol and dslip <= o.slip_tolerance:
                constraint_pen = pen
                break
            if uz >= o.max_uzawa and not (al and friction and pen <= tol):
                break  # nothing to hold the multipliers for: not converged
        if not (pen <= tol and dslip <= o.slip_tolerance):
            raise ConvergenceError(
                "contact outer iteration (Uzawa / slip directions)",
                f"max penetration {pen:.3e} m (tolerance {tol:.3e} m), slip direction change "
                f"{dslip:.2e} (tolerance {o.slip_tolerance:.2e}) after {uz} passes",
                step=label,
                iteration=uz,
            )
        if loose > o.newton_rtol or al:  # the last pass: final multipliers, final tolerance
            its, rnorm = self.newton(f"{label} (final)")
            total_it += its
        pen = self.max_penetration() if self.interfaces else 0.0  # at the integration points
        rep = SolveReport(
            label,
            total_it,
            uz,
            rnorm,
            pen,
            time.perf_counter() - t0,
            self.linear_solves - ls0,
            constraint_pen,
            self.stalled - st0,
        )
        log.info(
            "%s: %d Newton iterations, %d Uzawa, max penetration %.3e m, %.2f s",
            label,
            total_it,
            uz,
            pen,
            rep.wall_time_s,
        )
        return rep

    # -------------------------------------------------------------------------------------------
    def max_penetration(self) -> float:
        worst = 0.0
        for pts_list in self.last_points:
            for p in pts_list:
                if p.num_points:
                    worst = max(worst, float(np.max(np.where(p.pressure > 0.0, -p.gap, 0.0))))
        return self.comm.allreduce(worst, op=MPI.MAX)

    def contact_force(self, interface: int = 0) -> tuple[np.ndarray, np.ndarray]:
        """Total (normal, tangential) force on the first surface of an interface, N (global).

        The two passes are combined with their weights; in each pass the traction on the slave acts
        on the slave body, its reaction on the master.
        """
        itf = self.interfaces[interface]
        fn, ft = np.zeros(3), np.zeros(3)
        for ps, pts in zip(itf.passes, self.last_points[interface]):
            sign = 1.0 if ps.slave is itf.a else -1.0
            fn += sign * np.einsum("p,pd->d", pts.dA * pts.pressure, pts.normal)
            ft += sign * np.einsum(
                "p,pd->d", pts.dA, pts.traction - pts.pressure[:, None] * pts.normal
            )
        return self.comm.allreduce(fn, op=MPI.SUM), self.comm.allreduce(ft, op=MPI.SUM)

    def contact_moment(self, center: np.ndarray, axis: np.ndarray, interface: int = 0) -> float:
        """Moment (N m) about ``axis`` through ``center`` of the contact forces on surface ``a``."""
        itf = self.interfaces[interface]
        a = np.asarray(axis, float) / np.linalg.norm(axis)
        m = 0.0
        for ps, pts in zip(itf.passes, self.last_points[interface]):
            sign = 1.0 if ps.slave is itf.a else -1.0
            f = pts.dA[:, None] * pts.traction * sign
            m += float(np.einsum("pd,d->", np.cross(pts.x - np.asarray(center), f), a))
        return self.comm.allreduce(m, op=MPI.SUM)


def fixed_mask(V: fem.FunctionSpace, bcs: Sequence[fem.DirichletBC]) -> np.ndarray:
    """Boolean mask over the local (owned + ghost) dofs of V marking Dirichlet dofs."""
    imap, bs = V.dofmap.index_map, V.dofmap.index_map_bs
    mask = np.zeros((imap.size_local + imap.num_ghosts) * bs, dtype=bool)
    for bc in bcs:
        dofs, _ = bc.dof_indices()
        mask[dofs] = True
    return mask


class _ContactSystem:
    """One contact Newton solve as a :class:`gearfem.core.newton.NewtonSystem`.

    Unknowns (u, ψ) with a torque-controlled body: each direction solves the bordered system
    [[J, k_uψ], [k_ψuᵀ, k_ψψ]] by two solves with the same factors. Tolerance max(rtol · force
    scale, atol) at every iterate; a residual the line search cannot decrease is accepted as a
    stall below ``newton_stall_rtol`` · force scale.
    """

    def __init__(self, problem: ContactProblem, rtol: float, label: str) -> None:
        self.p, self.rtol, self.label = problem, rtol, label
        self.u_vec = problem.u.x.petsc_vec
        self.state = problem.residual(self.u_vec, matrix=True)
        self.norm = problem._norm(self.state)
        self.trial: _State | None = None
        self.trial_norm = math.nan
        self.du = self.u_vec.duplicate()
        self.db = self.u_vec.duplicate() if problem.controlled is not None else None
        self.u0: PETSc.Vec | None = None
        self.psi0 = 0.0
        self.dpsi = 0.0
        self.scale = 0.0

    def residual_norm(self) -> float:
        return self.norm

    def tolerance(self) -> float:
        self.scale = self.p._force_scale(self.u_vec)
        return max(self.rtol * self.scale, self.p.options.newton_atol_N)

    def compute_direction(self, iteration: int) -> None:
        p, st, ctl = self.p, self.state, self.p.controlled
        A = p._jacobian(st.coos)
        st.R.scale(-1.0)
        try:
            p._linear_solve(A, st.R, self.du, self.label, iteration)
            self.dpsi = 0.0
            if ctl is not None:
                st.k_up.scale(-1.0)
                p._linear_solve(A, st.k_up, self.db, self.label, iteration)
                D = st.k_pp + st.k_pu.dot(self.db)
                if not (D > 0.0 and np.isfinite(D)):
                    raise ConvergenceError(
                        "contact Newton (torque control)",
                        f"no rotational contact stiffness of {ctl.body!r} (k = {D:.3e} N "
                        "m/rad): the body is not in contact; close the gap first (prescribe its "
                        "angle)",
                        step=self.label,
                        iteration=iteration,
                    )
                self.dpsi = -(st.R_psi + st.k_pu.dot(self.du)) / D
                self.du.axpy(self.dpsi, self.db)
        finally:
            A.destroy()
        if self.u0 is not None:
            self.u0.destroy()
        self.u0 = self.u_vec.copy()
        self.psi0 = p.controlled_angle if ctl is not None else 0.0

    def try_step(self, alpha: float) -> float:
        p = self.p
        if self.trial is not None:
            self.trial.destroy()
        self.u_vec.waxpy(alpha, self.du, self.u0)
        p.u.x.scatter_forward()
        if p.controlled is not None:
            p._set_controlled_angle(self.psi0 + alpha * self.dpsi)
        self.trial = p.residual(self.u_vec, matrix=True)
        self.trial_norm = p._norm(self.trial)
        return self.trial_norm

    def accept(self) -> None:
        self.state.destroy()
        self.state, self.trial = self.trial, None
        self.norm = self.trial_norm

    def revert(self) -> None:
        p = self.p
        self.u0.copy(self.u_vec)
        p.u.x.scatter_forward()
        if p.controlled is not None:
            p._set_controlled_angle(self.psi0)
        if self.trial is not None:
            self.trial.destroy()
            self.trial = None

    def accepts_stall(self, norm: float) -> bool:
        return norm <= self.p.options.newton_stall_rtol * self.scale

    def step_negligible(self, alpha: float) -> bool:
        return False

    def free(self, keep_state: bool = False) -> None:
        """Free the work vectors (and the states unless ``keep_state``: the problem keeps the
        converged one as ``last_state``)."""
        for v in (self.du, self.db, self.u0):
            if v is not None:
                v.destroy()
        if self.trial is not None:
            self.trial.destroy()
        if not keep_state:
            self.state.destroy()
