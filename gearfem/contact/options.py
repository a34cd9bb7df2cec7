"""Contact and nonlinear-solver parameters (the ``[contact]`` table of a case file)."""

from __future__ import annotations

import dataclasses

from gearfem.core.params import (
    require_choice,
    require_int,
    require_nonnegative,
    require_positive,
    require_range,
)


@dataclasses.dataclass(frozen=True)
class ContactOptions:
    """How contact is enforced and how the nonlinear problem is solved.

    Normal contact: penalty p = ε⟨−g⟩ or augmented Lagrangian p = ⟨λ − εg⟩ with Uzawa updates of λ
    until the largest penetration is below the tolerance. ε = ``penalty_factor`` · E / h per slave
    facet (E: the Young's modulus the caller gives for the slave body, h: the facet size) unless
    ``penalty_Pa_m`` is set. The gear cycle gives both bodies the softer one's modulus
    (:class:`gearfem.cycle.model.GearContactModel`): with each slave's own, a steel slave's pass
    would be some 50 times stiffer than a polymer slave's and the two-pass average would split the
    load between the passes in about that ratio.

    Friction: Coulomb gross sliding, traction −μ p ŝ with ŝ = v_T / sqrt(|v_T|² + v_ε²) from the
    bodies' kinematic relative velocity v_T (regularised near zero slip by v_ε =
    ``slip_regularization_m_s``).

    Attributes (units in names):
        method: "penalty" or "augmented_lagrangian".
        penalty_factor: dimensionless ε·h/E (default 1: with the augmented Lagrangian a soft penalty
            keeps the pressure smooth; stiff penalties over-constrain Gauss-point contact on P2 and
            make the pressure oscillate near the contact edge).
        penalty_Pa_m: explicit ε in Pa/m (overrides the factor).
        penetration_tolerance_rel: AL stop: max penetration / facet size.
        penetration_tolerance_m: AL stop as a length (overrides the relative one).
        max_uzawa: Outer iterations (multiplier updates, slip-direction updates) before giving up
            (raises ConvergenceError). With friction and the augmented Lagrangian, a solve whose
            penetration is within tolerance after them but whose slip directions still change
            holds the multipliers for up to ``max_uzawa`` more passes while the directions settle
            (near the pitch point the multiplier updates alone can keep them cycling).
        pressure_smoothing_Pa: δ of the C1 pressure ramp p = (t + sqrt(t² + δ²))/2, t = λ − εg
            (0: the exact ramp max(0, t)). A δ far below the contact pressures removes the kink
            at the edge of the contact zone on which Newton can cycle when friction makes the
            tangent non-symmetric; it adds a pressure of about δ²/(4εg) at open gaps.
        slip_tolerance: The friction slip directions are frozen within a Newton solve and updated
            between solves until they change by less than this (norm of the change of ŝ).
        friction_coefficient: Coulomb μ in [0, 2].
        slip_regularization_m_s: v_ε.
        two_pass: both surfaces act as slave in turn, each pass weighted 1/2.
        quadrature_degree: degree of the triangle rule on each segment of a slave facet.
        search_distance_rel: pairs farther apart than this many facet sizes are ignored.
        max_normal_angle_deg: candidate pairs whose normals are not opposed within this angle are
            ignored.
        projection_tolerance: a slave point counts only if its closest-point foot lies on its master
            facet within this distance in reference coordinates (curvature makes it slightly
            outside).
        newton_rtol, newton_atol_N: residual tolerances (relative to the internal force norm;
            absolute, N).
        newton_max_it: Newton iterations per solve.
        newton_stall_rtol: A Newton solve whose line search can no longer decrease the residual is
            accepted, with a warning and counted in ``SolveReport.stalled``, when the residual is
            below this (relative to the internal force norm). GPTS contact is not C1 everywhere (a
            quadrature point switching master facet or leaving the contact zone): Newton can then
            cycle at a residual far below any discretisation error (measured on the gear pair:
            4.6e-5 of the load) but above ``newton_rtol``. 0 never accepts a stalled solve.
        line_search: backtracking on the residual norm.
        uzawa_newton_rtol: Newton tolerance of the augmented-Lagrangian passes before the last
            (inexact Uzawa): the multipliers change after them anyway; the final pass uses
            ``newton_rtol``.
        geometric_tangent: assemble the variation of the closest point, the master normal and
            the frozen slip direction into the contact tangent (:mod:`gearfem.contact.tangent`):
            the exact linearisation of the residual (checked against finite differences), so
            that each augmented-Lagrangian pass converges faster near the solution. Off by
            default: on the coarse gear case (8 positions, mu 0.5, one rank) it cut the Newton
            iterations from 147 to 111 but each iteration cost 0.20 s instead of 0.12 s (the
            rank-4 terms per point in the sparse assembly, the torque border's parts), so the
            positions took 22.5 s instead of 18.0 s. The solution is the same to the Newton
            tolerance (the transmission error of every position to 1 nm).
        reuse_factorization: solve each Newton system with GMRES preconditioned by the LU factors of
            an earlier Jacobian, refactoring only when GMRES needs more than ``max_krylov_its``
            (the tangent changes only through the contact active set, so one factorization usually
            serves a whole solve; the linear systems are still solved to ``krylov_rtol``). Factors
            that needed more than ``refactor_krylov_its`` iterations are replaced at the next solve.
        max_krylov_its: GMRES iterations with reused factors after which the Jacobian is factored
            anew (``reuse_factorization``).
        refactor_krylov_its: GMRES iterations above which a factorization is replaced at the next
            solve.
        krylov_rtol: Relative tolerance of the GMRES solves with reused factors.
    """

    method: str = "augmented_lagrangian"
    penalty_factor: float = 1.0
    penalty_Pa_m: float | None = None
    penetration_tolerance_rel: float = 0.01
    penetration_tolerance_m: float | None = None
    max_uzawa: int = 25
    slip_tolerance: float = 0.02
    pressure_smoothing_Pa: float = 0.0
    friction_coefficient: float = 0.0
    slip_regularization_m_s: float = 1e-5
    two_pass: bool = True
    quadrature_degree: int = 4
    search_distance_rel: float = 1.0
    max_normal_angle_deg: float = 60.0
    projection_tolerance: float = 0.05
    newton_rtol: float = 1e-9
    newton_atol_N: float = 1e-12
    newton_max_it: int = 40
    newton_stall_rtol: float = 1e-4
    uzawa_newton_rtol: float = 1e-5
    line_search: bool = True
    geometric_tangent: bool = False
    reuse_factorization: bool = True
    max_krylov_its: int = 60
    refactor_krylov_its: int = 15
    krylov_rtol: float = 1e-12

    def __post_init__(self) -> None:
        require_choice("contact.method", self.method, ("penalty", "augmented_lagrangian"))
        require_positive("contact.penalty_factor", self.penalty_factor)
        if self.penalty_Pa_m is not None:
            require_positive("contact.penalty_Pa_m", self.penalty_Pa_m)
        require_range(
            "contact.penetration_tolerance_rel",
            self.penetration_tolerance_rel,
            0.0,
            1.0,
            lo_open=True,
        )
        if self.penetration_tolerance_m is not None:
            require_positive("contact.penetration_tolerance_m", self.penetration_tolerance_m)
        require_int("contact.max_uzawa", self.max_uzawa, 1, 1000)
        require_nonnegative("contact.pressure_smoothing_Pa", self.pressure_smoothing_Pa)
        require_range("contact.slip_tolerance", self.slip_tolerance, 0.0, 2.0, lo_open=True)
        require_range("contact.friction_coefficient", self.friction_coefficient, 0.0, 2.0)
        require_positive("contact.slip_regularization_m_s", self.slip_regularization_m_s)
        require_int("contact.quadrature_degree", self.quadrature_degree, 1, 12)
        require_positive("contact.search_distance_rel", self.search_distance_rel)
        require_range(
            "contact.max_normal_angle_deg", self.max_normal_angle_deg, 0.0, 90.0, lo_open=True
        )
        require_range("contact.projection_tolerance", self.projection_tolerance, 0.0, 1.0)
        require_range("contact.newton_rtol", self.newton_rtol, 0.0, 1.0, lo_open=True, hi_open=True)
        require_nonnegative("contact.newton_atol_N", self.newton_atol_N)
        require_range("contact.newton_stall_rtol", self.newton_stall_rtol, 0.0, 1e-2)
        require_int("contact.newton_max_it", self.newton_max_it, 1, 1000)
        require_range(
            "contact.uzawa_newton_rtol",
            self.uzawa_newton_rtol,
            0.0,
            1.0,
            lo_open=True,
            hi_open=True,
        )
        require_int("contact.max_krylov_its", self.max_krylov_its, 1, 10000)
        require_int("contact.refactor_krylov_its", self.refactor_krylov_its, 1, 10000)
        require_range("contact.krylov_rtol", self.krylov_rtol, 0.0, 1e-3, lo_open=True)
