"""Transient and steady heat conduction in one gear body (thesis 5.1.5, 5.2).

Strong form, temperature T in kelvin::

    de(T)/dt = div(k(T) grad T) + q_h(T) + q_v              in the body,
    -k(T) dT/dn = h(T)(T - T_f) + eps sigma (T^4 - T_r^4)    on teeth (h_t) and sides (h_s),
    -k(T) dT/dn = -q_f(T)                                    additionally on the flux surfaces,
    -k(T) dT/dn = 0   on cut faces and on the bore (or a Robin heat path there),

with e(T) = rho int c_p dT (see :mod:`gearfem.thermal.properties`). Lagrange elements of degree
1 or 2, explicit quadrature degrees (volume 2p+1, boundary 2p+3; exact for radiation with p = 1)
shared by residual and heat balance. Time: variable-step BDF2 with a backward-Euler first step
and local error control (:mod:`gearfem.thermal.timestepping`). Each step is solved by Newton's
method around a PETSc KSP (:mod:`gearfem.thermal.newton`); the Jacobian is UFL's exact derivative
(radiation, H(T), k(T), c_p(T), film-temperature h(T)), its constant part assembled once.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Callable
from typing import Any

import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem.petsc import assemble_matrix, assemble_vector
from mpi4py import MPI
from petsc4py import PETSc

from gearfem.core.errors import ConvergenceError
from gearfem.core.forms import kept_derivative_form, kept_form
from gearfem.core.materials import ZERO_CELSIUS_K, Material, STEFAN_BOLTZMANN_W_m2K4
from gearfem.thermal.balance import HeatBalance
from gearfem.thermal.boundary import ThermalBoundary
from gearfem.thermal.domain import ROLES, ThermalDomain
from gearfem.thermal.newton import Effort, NewtonSolver, SolverStatistics
from gearfem.thermal.options import ThermalOptions
from gearfem.thermal.periodic import PeriodicTie
from gearfem.thermal.properties import antiderivative, antiderivative_ufl, table_ufl
from gearfem.thermal.source_terms import HeatSources, field_ufl
from gearfem.thermal.timestepping import (
    StepController,
    bdf2_coefficients,
    estimator_factor,
    extrapolation_weights,
)

log = logging.getLogger(__name__)


@dataclasses.dataclass(frozen=True)
class StepRecord:
    """State after one accepted step (or the initial/steady state).

    ``temperatures_K``: ``max_surface`` (max nodal value on the exterior surface without cut
    faces, what an IR camera sees), ``mean_bulk`` (volume mean) and ``<monitor>_mean`` /
    ``<monitor>_max`` for each monitored surface set.
    """

    step: int
    time_s: float
    dt_s: float
    order: int
    newton_iterations: int
    error_estimate_K: float
    temperatures_K: dict[str, float]
    balance: HeatBalance

    def row(self) -> dict[str, float]:
        """Flat CSV row (temperatures in C)."""
        out: dict[str, float] = {
            "step": self.step,
            "time_s": self.time_s,
            "dt_s": self.dt_s,
            "order": self.order,
            "newton_iterations": self.newton_iterations,
            "error_estimate_K": self.error_estimate_K,
        }
        for k, v in self.temperatures_K.items():
            out[f"T_{k}_C"] = v - ZERO_CELSIUS_K
        out.update(self.balance.as_dict())
        return out


class _Observer:
    """Interface of what ``run`` reports to (see :class:`gearfem.thermal.outputs.ThermalWriter`)."""

    def on_step(self, problem: ThermalProblem, record: StepRecord, write_field: bool) -> None: ...


#: Subdomain ids of the surfaces the thermal forms integrate over (:meth:`ThermalDomain.
#: surface_measure`): the roles, the prescribed (or constant-mu) flank flux and a friction law's
#: flux model. The compiled forms then do not depend on how a mesh numbers its facet groups: the
#: same form on a sector of 1 or 8 teeth is compiled once.
SURFACE_IDS = {"teeth": 1, "sides": 2, "bore": 3, "cuts": 4, "flux": 5, "flux_model": 6}
#: Subdomain ids of the gear's monitored surfaces (other monitors: from 21, in name order).
MONITOR_IDS = {"flank": 11, "coast_flank": 12, "tip": 13, "root": 14}


class ThermalProblem:
    """The heat equation on a :class:`ThermalDomain` with given sources and boundary model.

    Args:
        domain: Mesh and facet roles.
        material: Density, k(T), c_p(T).
        sources: Hysteresis and friction (and prescribed) sources.
        boundary: Surface exchanges of teeth, sides, bore.
        options: Discretisation, time stepping, solver tolerances, initial temperature.
        petsc_options_prefix: Prefix of the KSP/PC options (unique per problem).

    The unknown is :attr:`T` (kelvin); :attr:`time_s` the time of its current value.
    """

    def __init__(
        self,
        domain: ThermalDomain,
        material: Material,
        sources: HeatSources,
        boundary: ThermalBoundary,
        options: ThermalOptions,
        *,
        petsc_options_prefix: str = "gearfem_thermal_",
    ) -> None:
        self.domain, self.material, self.sources, self.boundary, self.options = (
            domain,
            material,
            sources,
            boundary,
            options,
        )
        self._prefix = petsc_options_prefix
        mesh = domain.mesh
        self.comm = mesh.comm
        p = options.degree
        self.V = fem.functionspace(mesh, ("Lagrange", p))
        # periodic cut faces: the unknowns are reduced by the tie (gearfem.thermal.periodic)
        self._tie = PeriodicTie(self.V, domain) if domain.periodic is not None else None
        self.T = fem.Function(self.V, name="temperature_K")
        self._T_n = fem.Function(self.V)
        self._T_nm1 = fem.Function(self.V)
        self._T_nm2 = fem.Function(self.V)
        self._T_pred = fem.Function(self.V)
        self.initial_K = (
            options.ambient_C if options.initial_C is None else options.initial_C
        ) + ZERO_CELSIUS_K
        for f in (self.T, self._T_n, self._T_nm1, self._T_nm2):
            f.x.array[:] = self.initial_K
        self.time_s = 0.0
        self._history_times: list[float] = [0.0]  # times of T_n, T_nm1, T_nm2 (newest first)
        self._n_steps = 0

        # time and BDF constants (compiled once, updated per step)
        self._t = fem.Constant(mesh, 0.0)
        self._dt = fem.Constant(mesh, 1.0)
        self._a = [fem.Constant(mesh, c) for c in (1.0, -1.0, 0.0)]

        qv, qs = 2 * p + 1, 2 * p + 3
        dx = ufl.Measure("dx", domain=mesh, metadata={"quadrature_degree": qv})
        surfaces = self._surfaces(domain, sources)
        self._surface_ids = {key: i for i, (key, _) in surfaces.items()}
        ds = domain.surface_measure(
            {i: names for i, (_, names) in surfaces.items()}, {"quadrature_degree": qs}
        )
        self._dx, self._ds = dx, ds
        x = ufl.SpatialCoordinate(mesh)
        T, v = self.T, ufl.TestFunction(self.V)

        rho = material.density_kg_m3
        cp, kT = material.specific_heat(), material.conductivity()
        # the enthalpy's reference (the initial temperature, often the ambient) as a constant,
        # like every number that differs between runs (_const)
        g_ref = self._const(float(antiderivative(cp, self.initial_K)))
        e = lambda u: rho * (antiderivative_ufl(cp, u) - g_ref)
        stored = (
            self._a[0] * e(T) + self._a[1] * e(self._T_n) + self._a[2] * e(self._T_nm1)
        ) / self._dt

        vol = self._volume_sources(T, x)
        surf = self._surface_terms(T, x)
        self._cp_const, self._k_const = cp.is_constant, kT.is_constant
        self._split = self._residual_split(T, v, vol, surf, stored)

        self._content = kept_form(e(T) * dx)
        self._w_vol = self._weights(v * dx)
        self._fast_stored = self._cp_const
        self._rho_cp = rho * float(cp.values[0])
        self._balance_forms, self._fast_conv = self._balance_forms_of(v, vol, surf, stored)

        # CG/Cholesky needs a symmetric positive definite Jacobian: constant k (else the k'(T)
        # grad T term is not symmetric) and no surface flux model whose heat can rise with T
        # (which can make it indefinite). A rising H(T) is checked at run time: CG that meets an
        # indefinite Jacobian switches to GMRES/LU (NewtonSolver.use_general_solver).
        self._symmetric = kT.is_constant and not sources.flank_flux_may_rise
        self._hist = fem.Function(self.V)  # (a1 T^n + a2 T^{n-1}) / dt
        self._transient_solver: NewtonSolver | None = None  # built on first use
        self._steady_solver: NewtonSolver | None = None

        self._probes(v)
        self._controller = StepController(options.time_error_K, options.dt_min_s, options.dt_max_s)
        self._dF_dscale = (
            kept_form(-sum(q * v * m for q, m in self._friction_unscaled))
            if self._friction_unscaled
            else None
        )
        self._capacity_form = kept_form(
            rho * table_ufl(cp, T) * ufl.TrialFunction(self.V) * v * self._dx
        )

    # --- the forms, one builder per part ----------------------------------------------------------
    @staticmethod
    def _surfaces(domain: ThermalDomain, sources: HeatSources) -> dict[int, tuple[Any, tuple]]:
        """The surfaces the forms integrate over, by subdomain id (:data:`SURFACE_IDS`,
        :data:`MONITOR_IDS`; other monitors from 21 in the order of their names): id -> (key,
        group names), the key what :meth:`_on` takes."""
        out: dict[int, tuple[Any, tuple]] = {}
        for role in ROLES:
            if getattr(domain, role):
                out[SURFACE_IDS[role]] = (role, tuple(getattr(domain, role)))
        if sources.flank_flux_W_m2 is not None:
            out[SURFACE_IDS["flux"]] = ("flux", tuple(sources.flux_surfaces))
        if sources.flank_flux_model is not None:
            out[SURFACE_IDS["flux_model"]] = (
                "flux_model",
                tuple(sources.flank_flux_model.surfaces),
            )
        others = iter(range(21, 21 + len(domain.monitors)))
        for mon in sorted(domain.monitors):
            i = MONITOR_IDS[mon] if mon in MONITOR_IDS else next(others)
            out[i] = (("monitor", mon), tuple(domain.monitors[mon]))
        return out

    def _on(self, key):
        """The surface measure of a surface of :meth:`_surfaces` (a role, ``"flux"``,
        ``"flux_model"`` or ``("monitor", name)``)."""
        return self._ds(self._surface_ids[key])

    def _const(self, value: float) -> fem.Constant:
        """A number of the forms as a constant of the mesh, not a literal: the compiled forms then
        do not depend on it, and a run with another convection coefficient, ambient, emissivity,
        conductivity or loading frequency (a study, a diagnosis's surrogate nodes) reuses them
        instead of compiling anew (FFCx keys its cache by the form's code)."""
        return fem.Constant(self.domain.mesh, PETSc.ScalarType(value))

    def _field(self, value, x):
        """A prescribed source (a number: a constant of :meth:`_const`; else a field of space and
        time, :func:`gearfem.thermal.source_terms.field_ufl`) as a UFL expression."""
        return (
            self._const(value) if isinstance(value, (int, float)) else field_ufl(value, x, self._t)
        )

    def _volume_sources(self, T, x) -> dict[str, Any]:
        """Volumetric sources (W/m³): hysteresis s_h f H(T) U_max and a prescribed q_v."""
        src = self.sources
        vol: dict[str, Any] = {}
        if src.u_max is not None:
            vol["hysteresis"] = (
                self._const(src.hysteresis_scale * src.loading_frequency_Hz)
                * table_ufl(src.hysteresis, T)
                * src.u_max
            )
        if src.volumetric_W_m3 is not None:
            vol["volumetric"] = self._field(src.volumetric_W_m3, x)
        return vol

    def _surface_terms(self, T, x) -> dict[str, list[tuple[Any, Any]]]:
        """Surface heat flows (W/m², outward positive except the friction input) with their
        measures: friction q_f (times μ(T)/μ_ref if given), convection h(T)(T − T_f), radiation
        ε σ (T⁴ − T_r⁴), and the bore's heat path."""
        src, domain = self.sources, self.domain
        surf: dict[str, list[tuple[Any, Any]]] = {
            "friction": [],
            "convected": [],
            "radiated": [],
            "bore": [],
        }
        # the friction heat times a scale (1; continuation in the heat input changes it,
        # gearfem.thermal.branches); the unscaled terms give dF/d(scale)
        self._fscale = fem.Constant(domain.mesh, 1.0)
        self._friction_unscaled: list[tuple[Any, Any]] = []
        if src.flank_flux_W_m2 is not None:
            # a number as a constant: a form of any flux value
            qf = self._const(src.flux_scale) * self._field(src.flank_flux_W_m2, x)
            if src.flux_temperature_factor is not None:
                qf = qf * src.flux_temperature_factor(T)
            self._friction_unscaled.append((qf, self._on("flux")))
            surf["friction"].append((self._fscale * qf, self._on("flux")))
        self._flux_model = src.flank_flux_model
        if self._flux_model is not None:
            # q = q(T̄) per cell, T̄ the cell's mean temperature over its facets on the model's
            # surfaces: T̄ = (B T)_c / A_c with B_cj = ∫ φ_j ds over those facets; the Jacobian
            # term -s Bᵀ diag(q'(T̄)/A) B is added as a matrix (_flux_jacobian), exactly
            m = self._flux_model
            dsm = self._on("flux_model")
            Q0 = m.value.function_space
            self._flux_Tbar = fem.Function(Q0, name="surface_mean_temperature_K")
            w0 = ufl.TestFunction(Q0)
            self._tbar_form = kept_form(T * w0 * dsm)
            area = assemble_vector(kept_form(w0 * dsm))
            area.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
            self._tbar_area = area.array.copy()
            area.destroy()
            self._tbar_vec = assemble_vector(self._tbar_form)
            self._flux_B = assemble_matrix(kept_form(ufl.TrialFunction(self.V) * w0 * dsm))
            self._flux_B.assemble()
            qm = self._const(src.flux_scale) * m.value
            self._friction_unscaled.append((qm, dsm))
            surf["friction"].append((self._fscale * qm, dsm))
        sigma = STEFAN_BOLTZMANN_W_m2K4
        for role, ex in self.boundary.exchanges().items():
            names = getattr(domain, role)
            if not names:
                continue
            dsr = self._on(role)
            h = ex.h(T)
            conv_term = (self._const(h) if isinstance(h, float) else h) * (
                T - self._const(ex.fluid_K)
            )
            rad_term = (
                self._const(ex.emissivity * sigma) * (T**4 - self._const(ex.radiation_K**4))
                if ex.emissivity > 0.0
                else None
            )
            if role == "bore":
                surf["bore"].append((conv_term if rad_term is None else conv_term + rad_term, dsr))
            else:
                surf["convected"].append((conv_term, dsr))
                if rad_term is not None:
                    surf["radiated"].append((rad_term, dsr))
        return surf

    def _residual_split(self, T, v, vol, surf, stored) -> dict[str, Any]:
        """The residual split for the Newton solver (:mod:`gearfem.thermal.newton`): constant c_p
        and k give matrices assembled once (``mass``, ``stiffness``); everything else is in
        ``F_nl`` (``F_nl_transient`` adds the storage term when c_p(T) varies)."""
        dx = self._dx
        u = ufl.TrialFunction(self.V)
        cp, kT = self.material.specific_heat(), self.material.conductivity()
        F_nl = 0
        if not self._k_const:
            F_nl += table_ufl(kT, T) * ufl.inner(ufl.grad(T), ufl.grad(v)) * dx
        for q in vol.values():
            F_nl -= q * v * dx
        for name, terms in surf.items():
            sign = -1.0 if name == "friction" else 1.0
            for q, m in terms:
                F_nl += sign * q * v * m
        rho = self.material.density_kg_m3
        return {
            "F_nl": F_nl,
            "F_nl_transient": F_nl if self._cp_const else F_nl + stored * v * dx,
            "mass": self._const(rho * float(cp.values[0])) * u * v * dx if self._cp_const else None,
            "stiffness": (
                self._const(float(kT.values[0])) * ufl.inner(ufl.grad(u), ufl.grad(v)) * dx
                if self._k_const
                else None
            ),
            "pattern": u * v * dx,
        }

    def _balance_forms_of(self, v, vol, surf, stored):
        """The heat balance: the residual's terms tested with v = 1. Terms linear in T with
        constant coefficients (storage with constant c_p, convection with constant h) are
        evaluated as dot products with the weight vectors ∫φ_i (exactly the same sums); the rest
        as forms. Returns (forms by balance name, fast convection terms)."""
        dx, domain = self._dx, self.domain
        forms: dict[str, Any] = {} if self._fast_stored else {"stored_W": kept_form(stored * dx)}
        names = {"hysteresis": "hysteresis_W", "volumetric": "volumetric_W"}
        for name, q in vol.items():
            forms[names[name]] = kept_form(q * dx)
        fast_conv = []  # (h, T_fluid, weights, area) per role with constant h
        exchanges = self.boundary.exchanges()
        if all(not callable(exchanges[r].h_W_m2K) for r in ("teeth", "sides")):
            for role in ("teeth", "sides"):
                if getattr(domain, role):
                    ex = exchanges[role]
                    on = self._on(role)
                    fast_conv.append(
                        (
                            float(ex.h_W_m2K),
                            ex.fluid_K,
                            self._weights(v * on),
                            self._integrate(1.0 * on),
                        )
                    )
        for name, terms in surf.items():
            if terms and not (name == "convected" and fast_conv):
                forms[f"{name}_W"] = kept_form(sum(q * m for q, m in terms))
        return forms, fast_conv

    def _probes(self, v) -> None:
        """Volume, role areas, surface dofs and the monitors (weights ∫_S φ_i, area, dofs on S)."""
        domain = self.domain
        fdim = domain.mesh.topology.dim - 1
        self._volume = self._integrate(1.0 * self._dx)
        self.volume_m3 = self._volume
        self._role_areas = {
            role: self._integrate(1.0 * self._on(role))
            for role in ("teeth", "sides", "bore", "cuts")
            if getattr(domain, role)
        }
        self._surface_dofs = self._dofs(fdim, domain.teeth + domain.sides + domain.bore)
        self._monitors = {}
        for mon, groups in domain.monitors.items():
            area = self._integrate(1.0 * self._on(("monitor", mon)))
            self._monitors[mon] = (
                self._weights(v * self._on(("monitor", mon))),
                area,
                self._dofs(fdim, groups),
            )

    def _flux_jacobian(self, J) -> None:
        """Add the surface flux model's Jacobian, -s Bᵀ diag(q'(T̄)/A) B (after assembly)."""
        m = self._flux_model
        B = self._flux_B
        n = len(self._tbar_area)
        d = np.where(
            self._tbar_area > 0,
            m.slope.x.array[:n] / np.where(self._tbar_area > 0, self._tbar_area, 1.0),
            0.0,
        )
        C = B.copy()
        dv = C.createVecLeft()
        dv.array[:] = d
        C.diagonalScale(L=dv)
        K = B.transposeMatMult(C)
        J.axpy(
            -float(self._fscale.value) * self.sources.flux_scale,
            K,
            PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN,
        )
        for obj in (K, C, dv):
            obj.destroy()

    def _update_flux_model(self) -> None:
        """Hand the surface flux model the surface-mean temperature of every cell next to its
        surfaces (collective; before every residual evaluation)."""
        if self._flux_model is None:
            return
        b = self._tbar_vec
        with b.localForm() as bl:
            bl.set(0.0)
        assemble_vector(b, self._tbar_form)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        area = self._tbar_area
        n = len(area)
        f = self._flux_Tbar
        f.x.array[:n] = np.where(area > 0, b.array / np.where(area > 0, area, 1.0), 0.0)
        f.x.scatter_forward()
        self._flux_model.update(f.x.array)

    # ------------------------------------------------------------------------------------------
    def close(self) -> None:
        """Free the solvers' PETSc objects (collective; also ``with ThermalProblem(...) as p:``).

        Call it on every rank when done with a parallel problem: freeing a MUMPS factorisation is
        collective, and the garbage collector may otherwise free it at different times on
        different ranks (e.g. when rank 0 keeps frames alive a little longer while plotting).
        """
        for name in ("_transient_solver", "_steady_solver"):
            solver = getattr(self, name)
            if solver is not None:
                solver.destroy()
                setattr(self, name, None)
        if getattr(self, "_tbar_vec", None) is not None:
            self._tbar_vec.destroy()
            self._flux_B.destroy()
            self._tbar_vec = self._flux_B = None
        if getattr(self, "_tie", None) is not None:
            self._tie.destroy()
            self._tie = None

    def __enter__(self) -> ThermalProblem:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # ------------------------------------------------------------------------------------------
    # set-up helpers
    # ------------------------------------------------------------------------------------------
    def _integrate(self, expr) -> float:

        return self.comm.allreduce(fem.assemble_scalar(kept_form(expr)), op=MPI.SUM)

    def _weights(self, linear_form):
        """The vector int phi_i (assembled once): w . T is the integral of T (exact, same
        quadrature)."""

        w = assemble_vector(kept_form(linear_form))
        w.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        return w

    def _dot(self, w, f) -> float:
        return w.dot(f.x.petsc_vec)

    def _dofs(self, fdim: int, groups: tuple[str, ...]) -> np.ndarray:

        facets = self.domain.facets(groups)
        dofs = fem.locate_dofs_topological(self.V, fdim, facets)
        n_owned = self.V.dofmap.index_map.size_local * self.V.dofmap.index_map_bs
        return dofs[dofs < n_owned]

    def role_areas_m2(self) -> dict[str, float]:
        """Surface area of each role present (teeth, sides, bore, cuts), m^2."""
        return dict(self._role_areas)

    @property
    def num_dofs(self) -> int:
        im = self.V.dofmap.index_map
        return im.size_global * self.V.dofmap.index_map_bs

    def _petsc_options(self) -> dict[str, Any]:
        """KSP/PC options (under the problem's prefix), see ``ThermalOptions.linear_solver``."""
        o = self.options
        opts: dict[str, Any] = {}
        # CG for the symmetric Jacobian (constant k: radiation, H(T), c_p(T), h(T) keep it
        # symmetric), GMRES when k(T) adds the non-symmetric k'(T) grad T term.
        krylov = {
            "ksp_type": "cg" if self._symmetric else "gmres",
            "ksp_rtol": 1e-10,
            "ksp_max_it": 2000,
        }
        if o.linear_solver == "direct":
            # Krylov iterations preconditioned by a MUMPS factorisation that is kept while
            # alpha = a0/dt stays close to its value at factorisation (NewtonSolver.REBUILD_RATIO):
            # one or two iterations when only radiation/H(T) changed, a few after a small change
            # of dt; refactorised otherwise. Cholesky (LDL^T) for the symmetric Jacobian.
            opts.update(
                krylov
                | {
                    "pc_type": "cholesky" if self._symmetric else "lu",
                    "pc_factor_mat_solver_type": "mumps",
                }
            )
        elif o.linear_solver == "iterative":
            # block Jacobi (one block per rank) with incomplete Cholesky / LU(0) blocks: cheapest on
            # the thermal meshes measured (mass-dominated at small steps): benchmarks/performance/
            opts.update(
                krylov | {"pc_type": "bjacobi", "sub_pc_type": "icc" if self._symmetric else "ilu"}
            )
        else:  # multigrid: BoomerAMG when PETSc has hypre, else PETSc's GAMG
            from petsc4py import PETSc

            opts.update(krylov)
            if PETSc.Sys.hasExternalPackage("hypre"):
                opts.update({"pc_type": "hypre", "pc_hypre_type": "boomeramg"})
            else:
                opts.update({"pc_type": "gamg"})
        return opts

    def _make_solver(self, transient: bool) -> NewtonSolver:

        sp = self._split
        F = sp["F_nl_transient"] if transient else sp["F_nl"]
        if isinstance(F, int):  # no sources, no exchange, constant properties: F_nl vanishes
            F = fem.Constant(self.domain.mesh, 0.0) * ufl.TestFunction(self.V) * self._dx
        o = self.options
        return NewtonSolver(
            self.T,
            kept_form(F),
            kept_derivative_form(F, self.T),
            kept_form(sp["mass"]) if (transient and sp["mass"] is not None) else None,
            kept_form(sp["stiffness"]) if sp["stiffness"] is not None else None,
            kept_form(sp["pattern"]),
            f"{self._prefix}{'transient' if transient else 'steady'}_",
            self._petsc_options(),
            rtol=o.newton_rtol,
            atol_W=o.newton_atol_W,
            max_it=o.newton_max_it,
            reuse_preconditioner=transient and o.linear_solver == "direct",
            pre_residual=self._update_flux_model if self._flux_model is not None else None,
            extra_jacobian=self._flux_jacobian if self._flux_model is not None else None,
            tie=self._tie,
        )

    # ------------------------------------------------------------------------------------------
    # the steady system, for branch tracing and stability (gearfem.thermal.branches)
    # ------------------------------------------------------------------------------------------
    @property
    def friction_scale(self) -> float:
        """Multiplier of the friction heat (1: as given)."""
        return float(self._fscale.value)

    def set_friction_scale(self, value: float) -> None:
        self._fscale.value = float(value)

    @property
    def has_friction(self) -> bool:
        return self._dF_dscale is not None

    def steady_system(self):
        """(J, F) of the steady residual at the current T in the unknowns of :meth:`state_vector`
        (with periodic cut faces the reduced P^T J P and P^T F; PETSc Mat and Vec owned by the
        problem's steady solver; collective)."""
        if self._steady_solver is None:
            self._steady_solver = self._make_solver(transient=False)
        s = self._steady_solver
        s.set_time_terms(0.0, None)
        self._t.value = self.time_s
        s._residual()
        s._jacobian()
        return s.operator, s.residual_vector

    def friction_scale_derivative(self):
        """dF/d(friction scale) at the current T: minus the friction heat per test function
        (a new PETSc Vec of the unknowns of :meth:`state_vector`; collective). The flux model
        must be current (call after :meth:`steady_system`)."""

        b = assemble_vector(self._dF_dscale)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        if self._tie is None:
            return b
        r = self._tie.create_vector()
        self._tie.restrict(b, r)
        b.destroy()
        return r

    def heat_capacity_matrix(self):
        """M = rho c_p(T) (mass matrix at the current T) in the unknowns of :meth:`state_vector`,
        a new PETSc Mat (collective)."""

        M = assemble_matrix(self._capacity_form)
        M.assemble()
        if self._tie is None:
            return M
        Mr = self._tie.reduce_matrix(M)
        M.destroy()
        return Mr

    def state_vector(self):
        """The unknowns of the current T as a new PETSc Vec: T's DOFs, or with periodic cut faces
        the reduced unknowns (every DOF but the end face's). :meth:`set_state` writes it back."""
        if self._tie is None:
            return self.T.x.petsc_vec.copy()
        y = self._tie.create_vector()
        self._tie.inject(self.T.x.petsc_vec, y)
        return y

    def set_state(self, x) -> None:
        """T from a vector of the unknowns of :meth:`state_vector` (collective)."""
        if self._tie is None:
            x.copy(self.T.x.petsc_vec)
        else:
            self._tie.prolong(x, self.T.x.petsc_vec)
        self.T.x.scatter_forward()

    @property
    def num_unknowns(self) -> int:
        """Size of the solved systems: :attr:`num_dofs` less the tied end face's DOFs."""
        return self.num_dofs if self._tie is None else self._tie.num_reduced

    @property
    def transient_statistics(self) -> SolverStatistics | None:
        """The transient Newton solver's work so far (None before the first step)."""
        s = self._transient_solver
        return None if s is None else s.statistics()

    @property
    def petsc_prefix(self) -> str:
        return self._prefix

    # ------------------------------------------------------------------------------------------
    # quantities
    # ------------------------------------------------------------------------------------------
    def heat_balance(self) -> HeatBalance:
        """Heat flows of the current step (as last solved), W."""
        self._update_flux_model()  # the flux of the current T (as the last residual had it)

        vals = {
            k: self.comm.allreduce(fem.assemble_scalar(f), op=MPI.SUM)
            for k, f in self._balance_forms.items()
        }
        if self._fast_stored:
            a0, a1, a2 = (float(c.value) for c in self._a)
            dt = float(self._dt.value)
            w = self._w_vol
            vals["stored_W"] = (
                self._rho_cp
                * (
                    a0 * self._dot(w, self.T)
                    + a1 * self._dot(w, self._T_n)
                    + a2 * self._dot(w, self._T_nm1)
                )
                / dt
            )
        if self._fast_conv:
            vals["convected_W"] = sum(
                h * (self._dot(w, self.T) - Tf * area) for h, Tf, w, area in self._fast_conv
            )
        return HeatBalance(**vals)

    def temperatures_K(self) -> dict[str, float]:
        """max_surface, mean_bulk and monitor mean/max of the current T, kelvin (collective)."""

        arr = self.T.x.array

        def gmax(dofs):
            local = float(arr[dofs].max()) if len(dofs) else -math.inf
            return self.comm.allreduce(local, op=MPI.MAX)

        out = {
            "max_surface": gmax(self._surface_dofs),
            "mean_bulk": self._dot(self._w_vol, self.T) / self._volume,
        }
        for mon, (w, area, dofs) in self._monitors.items():
            out[f"{mon}_mean"] = self._dot(w, self.T) / area
            out[f"{mon}_max"] = gmax(dofs)
        return out

    def heat_content_J(self) -> float:
        """int e(T) dV of the current T relative to the initial temperature, J (collective)."""

        return self.comm.allreduce(fem.assemble_scalar(self._content), op=MPI.SUM)

    def set_initial(self, T_K: float | Callable[[np.ndarray], np.ndarray] | Any) -> None:
        """Restart at time 0 from ``T_K`` (kelvin): a number, a Function on :attr:`V`, or a
        callable of the coordinates (3, n) returning n values."""
        if isinstance(T_K, (int, float)):
            self.T.x.array[:] = float(T_K)
        else:
            self.T.interpolate(T_K)
        self.T.x.scatter_forward()
        if self._tie is not None:  # a start that is not periodic is made so (end face <- start)
            self._tie.make_periodic(self.T)
        for f in (self._T_n, self._T_nm1, self._T_nm2):
            f.x.array[:] = self.T.x.array
        self.time_s = 0.0
        self._history_times = [0.0]
        self._n_steps = 0

    def _record(self, step, dt, order, its, err, balance) -> StepRecord:
        return StepRecord(step, self.time_s, dt, order, its, err, self.temperatures_K(), balance)

    def initial_record(self) -> StepRecord:
        return self._record(0, 0.0, 0, 0, math.nan, HeatBalance.undefined())

    # ------------------------------------------------------------------------------------------
    # steady state
    # ------------------------------------------------------------------------------------------
    def solve_steady(self, effort: Effort | None = None) -> StepRecord:
        """Steady state (from the current T as initial guess). Raises ConvergenceError when Newton
        fails, e.g. when hysteresis grows faster with T than the losses (thermal runaway).
        ``effort``: a cap on the Newton work below the options' (a probe whose failure is an
        answer, :mod:`gearfem.thermal.branches`)."""
        if self._steady_solver is None:
            self._steady_solver = self._make_solver(transient=False)
        self._t.value = self.time_s
        self._steady_solver.set_time_terms(0.0, None)
        its = self._steady_solver.solve(
            "steady state (no steady solution if the heating runs away)",
            linesearch="bt",
            effort=effort,
        )
        self._T_n.x.array[:] = self.T.x.array
        self._a[0].value, self._a[1].value, self._a[2].value = (
            0.0,
            0.0,
            0.0,
        )  # stored = 0 in the balance
        rec = self._record(0, 0.0, 0, its, math.nan, self.heat_balance())
        return rec

    # ------------------------------------------------------------------------------------------
    # transient
    # ------------------------------------------------------------------------------------------
    def _predict(self, t_new: float) -> None:
        """T_pred at t_new: quadratic (3 levels), linear (2) or constant extrapolation."""
        ts = self._history_times
        a_n, a_1, a_2 = self._T_n.x.array, self._T_nm1.x.array, self._T_nm2.x.array
        if len(ts) >= 3:
            w = extrapolation_weights((ts[0], ts[1], ts[2]), t_new)
            self._T_pred.x.array[:] = w[0] * a_n + w[1] * a_1 + w[2] * a_2
        elif len(ts) == 2:
            s = (t_new - ts[0]) / (ts[0] - ts[1])
            self._T_pred.x.array[:] = a_n + s * (a_n - a_1)
        else:
            self._T_pred.x.array[:] = a_n

    def try_step(self, dt: float) -> tuple[int, float]:
        """Solve one step of size dt from the current history without accepting it.

        Returns (Newton iterations, local error estimate in K or nan when not available).
        """

        ts = self._history_times
        dt_prev = ts[0] - ts[1] if len(ts) >= 2 else None
        a = bdf2_coefficients(dt, dt_prev)
        for c, val in zip(self._a, a):
            c.value = val
        self._dt.value = dt
        t_new = self.time_s + dt
        self._t.value = t_new
        self._predict(t_new)
        self.T.x.array[:] = self._T_pred.x.array
        self._hist.x.array[:] = (a[1] * self._T_n.x.array + a[2] * self._T_nm1.x.array) / dt
        if self._transient_solver is None:
            self._transient_solver = self._make_solver(transient=True)
        self._transient_solver.set_time_terms(a[0] / dt, self._hist.x.petsc_vec)
        # a surface flux that may rise with T (a friction law switching across T_g) is steep and
        # its Jacobian approximate (gearfem.coupling.friction_heat): full Newton steps with
        # backtracking, no chord iterations
        rising = self.sources.flank_flux_may_rise
        its = self._transient_solver.solve(
            f"t = {t_new:.6g} s (dt = {dt:.4g} s)",
            linesearch="bt" if rising else "basic",
            chord=not rising,
        )
        err = math.nan
        if len(ts) >= 3:
            f = estimator_factor(dt, ts[0] - ts[1], ts[1] - ts[2])
            n_owned = self.V.dofmap.index_map.size_local
            diff = np.abs(self.T.x.array[:n_owned] - self._T_pred.x.array[:n_owned])
            local = float(diff.max()) if n_owned else 0.0
            err = f * self.comm.allreduce(local, op=MPI.MAX)
        return its, err

    def accept_step(self, dt: float, its: int, err: float) -> StepRecord:
        """Accept the last tried step: balance, shift history, advance time."""
        order = 1 if len(self._history_times) < 2 else 2
        balance = self.heat_balance()
        self._T_nm2.x.array[:] = self._T_nm1.x.array
        self._T_nm1.x.array[:] = self._T_n.x.array
        self._T_n.x.array[:] = self.T.x.array
        self.time_s = self.time_s + dt
        self._history_times = [self.time_s, *self._history_times[:2]]
        self._n_steps += 1
        return self._record(self._n_steps, dt, order, its, err, balance)

    def integrate(
        self, observer: _Observer | None = None, duration_s: float | None = None
    ) -> list[StepRecord]:
        """Integrate to ``duration_s`` (default: options) from the current state; return the records
        (initial state first). Steps land exactly on ``options.output_times_s`` and the end."""
        o = self.options
        end = o.duration_s if duration_s is None else duration_s
        targets = [t for t in o.output_times_s if self.time_s < t < end] + [end]
        records = [self.initial_record()] if self._n_steps == 0 else []
        if observer is not None and records:
            observer.on_step(self, records[0], write_field=True)
        dt = o.dt_initial_s
        adaptive = o.time_stepping == "adaptive"
        ctrl = self._controller
        while targets:
            target = targets[0]
            remaining = target - self.time_s
            h = remaining if dt * 1.05 >= remaining else dt
            try:
                its, err = self.try_step(h)
            except ConvergenceError as err:
                if not adaptive or h * 0.5 < o.dt_min_s:
                    raise
                log.info(
                    "Newton failed at t = %.6g s with dt = %.4g s; halving the step (%s)",
                    self.time_s + h,
                    h,
                    err.reason,
                )
                dt = 0.5 * h
                continue
            if adaptive and not math.isnan(err) and not ctrl.accept(err):
                dt = h * ctrl.ratio(err)
                if dt < o.dt_min_s:
                    raise ConvergenceError(
                        "thermal time stepping",
                        f"local error {err:.3g} K > tolerance "
                        f"{o.time_error_K:g} K with dt < dt_min_s = {o.dt_min_s:g} s",
                        step=f"t = {self.time_s:.6g} s",
                    )
                continue
            rec = self.accept_step(h, its, err)
            landed = h == remaining
            if landed:  # remove the round-off of time_s + h
                self.time_s = self._history_times[0] = target
                rec = dataclasses.replace(rec, time_s=target)
                targets.pop(0)
            records.append(rec)
            if observer is not None:
                observer.on_step(self, rec, write_field=landed)
            if adaptive and not math.isnan(err):
                dt = max(o.dt_min_s, ctrl.next_dt(h, err))
            elif not adaptive:
                dt = o.dt_initial_s
            # (adaptive, first two steps: no estimate yet, dt stays)
        return records
