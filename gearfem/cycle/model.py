"""The gear pair as a contact problem: rigid bores, prescribed pinion angle, torque-held wheel.

Each body keeps its mesh and displacement in its own frame; rigid rotations place it (pinion by
the prescribed angle φ, wheel by ψ = ψ_kin(φ) + δψ). The wheel's wind-up δψ is solved together
with the displacements so that the contact moment about its axis balances the resisting torque
(:class:`~gearfem.contact.problem.ControlledRotation`). Bores are clamped in their body frames
(thesis 5.1.1: the metal hub is rigid). Quasi-static, no inertia (thesis 5.1.5).
"""

from __future__ import annotations

import dataclasses
import logging
import math

import numpy as np
from dolfinx import fem
from dolfinx.mesh import entities_to_geometry
from mpi4py import MPI

from gearfem.contact import (
    ContactInterface,
    ContactOptions,
    ContactProblem,
    ContactSurface,
    RigidMotion,
)
from gearfem.contact.compliance import ComplianceStore
from gearfem.contact.condensed import CondensedContactProblem, Guard
from gearfem.contact.problem import ControlledRotation, fixed_mask
from gearfem.contact.verification import hertz_line_contact
from gearfem.core.errors import ParameterError
from gearfem.core.materials import Material
from gearfem.core.params import require_positive
from gearfem.cycle.modulus_field import ModulusField
from gearfem.cycle.options import CycleOptions
from gearfem.geometry.mesh import GearMesh, parse_group_name

log = logging.getLogger(__name__)

BODIES = ("pinion", "wheel")


class GearContactModel:
    """Contact problem of a meshed gear pair at any pinion angle, under a resisting torque.

    Args:
        gm: The gear-pair mesh (both bodies).
        materials: Material of the pinion and of the wheel.
        contact: Contact options (friction coefficient, penalty, tolerances).
        torque_Nm: Resisting torque on the wheel (> 0: the pinion drives forward).
        options: Cycle options (surfaces, predictor, solver).
        compliance_store: With ``options.solver = "condensed"``: where the gears' compliances are
            kept between runs (None: computed by this model).
        share: With the condensed solver and ``gm`` on one rank: the communicator of the ranks
            that each build this same model (to solve different positions of the cycle,
            :func:`gearfem.cycle.solve.solve_cycle`); the gears' compliances are computed once
            among them.
        moduli: Young's modulus per cell of the gears it covers, from a thermal state
            (:mod:`gearfem.cycle.modulus_field`; None: each material's constant modulus). The
            compliance store's context must say which field (``compliance_store``).

    With the condensed solver, the contact surfaces are the parts of the teeth that can engage
    over the angles the cycle solves (:meth:`condensed_facets`); the other contact facets are
    guards: a contact found on one of them after a position raises an error naming its tooth.
    """

    def __init__(
        self,
        gm: GearMesh,
        materials: dict[str, Material],
        contact: ContactOptions,
        torque_Nm: float,
        options: CycleOptions = CycleOptions(),  # noqa: B008 - frozen, immutable
        compliance_store: ComplianceStore | None = None,
        share: MPI.Comm | None = None,
        moduli: ModulusField | None = None,
    ) -> None:
        require_positive("operating.torque_Nm", torque_Nm)
        if set(gm.bodies) != set(BODIES):
            raise ParameterError(
                "bodies", gm.bodies, "both ('pinion', 'wheel') for the contact cycle"
            )
        cell_materials = materials
        if moduli is not None:
            # the regularisation (penalty, pressure smoothing, Hertz widths) takes each gear's
            # uniform modulus of the field's mean compliance (gearfem.cycle.modulus_field)
            materials = {
                b: dataclasses.replace(
                    m, youngs_modulus_Pa=m.youngs_modulus_Pa * moduli.mean_relative(b)
                )
                for b, m in materials.items()
            }
        self.gm, self.materials, self.torque_Nm, self.options = gm, materials, torque_Nm, options
        self.pair = gm.pair
        self._check_torque()
        self.creep_ratio = (
            options.creep_ratio
            if options.creep_ratio is not None
            else self.carter_creep_ratio(contact.friction_coefficient)
        )
        self.rolling_speed_m_s = self.pair.pinion.operating_pitch_radius_m * math.sin(
            self.pair.operating_pressure_angle_rad
        )  # per unit pinion speed
        contact = dataclasses.replace(
            contact, slip_regularization_m_s=max(self.creep_ratio * self.rolling_speed_m_s, 1e-12)
        )
        self.nominal_hertz_pressure_Pa = self.nominal_hertz()[1]
        if contact.pressure_smoothing_Pa == 0.0 and options.pressure_smoothing_fraction > 0.0:
            contact = dataclasses.replace(
                contact,
                pressure_smoothing_Pa=options.pressure_smoothing_fraction
                * self.nominal_hertz_pressure_Pa,
            )
        self.contact = contact
        mesh = gm.mesh
        self.comm: MPI.Comm = mesh.comm
        self.V = fem.functionspace(mesh, ("Lagrange", mesh.geometry.cmaps[0].degree, (3,)))
        # Lamé parameters per cell (DG0): each body's material, its modulus scaled per cell by
        # the modulus field where one is given
        Q = fem.functionspace(mesh, ("DG", 0))
        self.lame_mu, self.lame_lambda = fem.Function(Q), fem.Function(Q)
        self.moduli = moduli
        for b in BODIES:
            cells = gm.cells(b)
            scale = 1.0
            if moduli is not None:
                x = mesh.geometry.x[mesh.geometry.dofmaps[0][cells]].mean(axis=1)
                scale = moduli.relative_at(b, x, gm.center(b), gm.tooth_angles(b))
            self.lame_mu.x.array[cells] = cell_materials[b].lame_mu_Pa * scale
            self.lame_lambda.x.array[cells] = cell_materials[b].lame_lambda_Pa * scale
        self.lame_mu.x.scatter_forward()
        self.lame_lambda.x.scatter_forward()
        self.bcs = [
            fem.dirichletbc(
                np.zeros(3), fem.locate_dofs_topological(self.V, 2, gm.facets(f"{b}_bore")), self.V
            )
            for b in BODIES
        ]
        mask = fixed_mask(self.V, self.bcs)
        #: every modelled tooth of each gear, and those whose surfaces the contact is solved on
        self.teeth = {b: self._modelled_teeth(b) for b in BODIES}
        #: local contact facets of each gear: every one (``all_contact_facets``), and those the
        #: contact is solved on: all of them (full solver) or those the condensed surfaces hold
        #: (:meth:`condensed_facets`); the teeth they belong to (on any rank)
        self.all_contact_facets = {
            b: gm.facets(*self._contact_names(b, self.teeth[b])) for b in BODIES
        }
        self.contact_facets = (
            self.condensed_facets(options.condensed_margin_pitches)
            if options.solver == "condensed"
            else dict(self.all_contact_facets)
        )
        self.contact_teeth = {b: self._teeth_holding(b, self.contact_facets[b]) for b in BODIES}
        # the penalty of both passes from the softer body's modulus (ContactOptions): each
        # slave's own made a steel/POM pair's passes split its load about 72:1, and the
        # revolution average refused the cycle (1.96 of the mesh's friction power on a steel
        # pinion's reference tooth); for gears of one material it is the same number
        penalty_E = min(materials[b].youngs_modulus_Pa for b in BODIES)
        youngs = dict.fromkeys(BODIES, penalty_E)
        self.surfaces = {
            b: ContactSurface(self.V, self.contact_facets[b], b, mask, name=f"{b}_teeth")
            for b in BODIES
        }
        #: every contact facet of each gear's reference tooth: where the revolution averages are
        #: collected from their images on the contact surfaces, whatever part of the tooth those
        #: hold
        self.reference_surfaces = {
            b: ContactSurface(
                self.V,
                gm.facets(*self._contact_names(b, [gm.reference_tooth(b)])),
                b,
                mask,
                name=f"{b}_reference_tooth",
            )
            for b in BODIES
        }
        self.interface = ContactInterface(
            self.surfaces["pinion"], self.surfaces["wheel"], contact, youngs
        )
        z1, z2 = gm.geometry.teeth_pinion, gm.geometry.teeth_wheel
        self.ratio = z1 / z2
        self.base_radius_m = {
            "pinion": self.pair.pinion.base_radius_m,
            "wheel": self.pair.wheel.base_radius_m,
        }
        self._motion0 = {
            # kinematic speeds for the friction direction: pinion 1 rad/s (results per unit speed)
            "pinion": RigidMotion(center=tuple(gm.center("pinion")), angular_velocity_rad_s=1.0),
            "wheel": RigidMotion(
                center=tuple(gm.center("wheel")), angular_velocity_rad_s=-self.ratio
            ),
        }
        held = ControlledRotation("wheel", torque_Nm, self.base_radius_m["wheel"])
        if options.solver == "full":
            self.problem = ContactProblem(
                self.V,
                self.lame_mu,
                self.lame_lambda,
                self.bcs,
                [self.interface],
                dict(self._motion0),
                contact,
                petsc_options_prefix="gearfem_cycle_",
                controlled=held,
            )
        else:
            self.problem = CondensedContactProblem(
                self.V,
                self.lame_mu,
                self.lame_lambda,
                self.bcs,
                [self.interface],
                dict(self._motion0),
                contact,
                bodies={b: gm.cells(b) for b in BODIES},
                petsc_options_prefix="gearfem_cycle_condensed_",
                controlled=held,
                store=compliance_store,
                share=share,
                guards=self._guards(mask, youngs),
                guard_hint=(
                    "the condensed surfaces hold parts of pinion teeth "
                    f"{self.contact_teeth['pinion']} and wheel teeth "
                    f"{self.contact_teeth['wheel']} (cycle.condensed_margin_pitches = "
                    f"{options.condensed_margin_pitches:g}): raise "
                    "cycle.condensed_margin_pitches, or use cycle.solver = 'full'"
                ),
            )
        self.tooth_of_facet = {b: self._facet_teeth(b) for b in BODIES}
        self.phi = 0.0
        self.windup_rad = None  # δψ of the last converged position

    # -------------------------------------------------------------------------------------------
    def _modelled_teeth(self, body: str) -> list[int]:
        teeth = {parse_group_name(n)[1] for n in self.gm.names(body=body)}
        return sorted(k for k in teeth if k is not None)

    def _contact_names(self, body: str, teeth) -> list[str]:
        """Group names of the contact surfaces (``contact_kinds``) of the given teeth."""
        return [
            n
            for k in self.options.contact_kinds
            for n in self.gm.names(body=body, kind=k)
            if parse_group_name(n)[1] in set(teeth)
        ]

    def solved_angles_rad(self) -> tuple[float, float]:
        """The pinion angles the cycle solves, relative to the mesh as built: from the start to
        the end of the last pitch (and the periodicity check one pitch after the start)."""
        o = self.options
        pitch = 2.0 * math.pi / self.gm.geometry.teeth_pinion
        start = math.radians(o.start_angle_deg)
        return start, start + pitch * max(o.pitches, 1.0 if o.check_periodicity else 0.0)

    def roll_parameter(self, body: str, radius_m: np.ndarray) -> np.ndarray:
        """S [m] at which the rigid involute contact of a pair lies at ``radius_m`` on the flank of
        ``body`` (pinion: S = sqrt(r² − r_b1²) − r_w1 sin α_w; wheel: S = r_w2 sin α_w −
        sqrt(r² − r_b2²)); below the base circle the value at r_b."""
        pair = self.pair
        prof = pair.pinion if body == "pinion" else pair.wheel
        roll = np.sqrt(np.maximum(np.asarray(radius_m) ** 2 - prof.base_radius_m**2, 0.0))
        at_pitch = prof.operating_pitch_radius_m * math.sin(pair.operating_pressure_angle_rad)
        return roll - at_pitch if body == "pinion" else at_pitch - roll

    def condensed_facets(self, margin_pitches: float) -> dict[str, np.ndarray]:
        """Local contact facets of each gear that the condensed surfaces hold.

        Pair k_ref + j of the pinion with k_ref − j of the wheel has the rigid contact parameter
        S = r_b1 φ + j p_b (:meth:`GearPair.contact_parameter`), in contact while −g_f <= S <= g_a.
        Over the solved angles S sweeps [S0 + j p_b, S1 + j p_b]; clipped to [−g_f, g_a] and
        widened by ``margin_pitches`` p_b at each end, it gives the range of S in which that
        pair's teeth may touch (the widening covers the contact's width and the loaded teeth's
        longer path). A facet of either tooth is held when the roll parameter of its nodes
        (:meth:`roll_parameter`) meets that range; a pair whose widened range is empty holds
        nothing."""
        pair, gm = self.pair, self.gm
        rot = math.radians(gm.options.pinion_angle_deg)
        phi0, phi1 = self.solved_angles_rad()
        s0 = float(pair.contact_parameter(phi0 + rot))
        s1 = float(pair.contact_parameter(phi1 + rot))
        lo, hi, pb = -pair.approach_length_m, pair.recess_length_m, pair.base_pitch_m
        margin = margin_pitches * pb
        x = gm.mesh.geometry.x
        out = {}
        for b in BODIES:
            center = np.asarray(gm.center(b))[:2]
            ref = gm.reference_tooth(b)
            held = []
            for k in self.teeth[b]:
                j = k - ref if b == "pinion" else ref - k
                first, last = max(s0 + j * pb, lo) - margin, min(s1 + j * pb, hi) + margin
                if first > last:
                    continue
                facets = gm.facets(*self._contact_names(b, [k]))
                nodes = entities_to_geometry(gm.mesh, 2, facets)
                s = self.roll_parameter(b, np.hypot(*(x[nodes, :2] - center).transpose(2, 0, 1)))
                held.append(facets[(s.max(axis=1) >= first) & (s.min(axis=1) <= last)])
            out[b] = np.sort(np.concatenate(held)) if held else np.zeros(0, dtype=np.int32)
        return out

    def _teeth_holding(self, body: str, facets: np.ndarray) -> list[int]:
        """The teeth (on any rank) with a facet among the local ``facets`` of ``body``."""
        local = {int(k) for k in self._tooth_labels(body, facets) if k >= 0}
        return sorted(set().union(*self.comm.allgather(local)))

    def _guards(self, mask: np.ndarray, youngs: dict[str, float]) -> list[Guard]:
        """Contact checks of the contact facets left out of the condensed surfaces: per gear,
        those facets against every contact surface of the other gear (labelled by tooth)."""
        guards, every = [], self.all_contact_facets
        whole = {b: ContactSurface(self.V, every[b], b, mask, name=f"{b}") for b in BODIES}
        for b, other in (("pinion", "wheel"), ("wheel", "pinion")):
            out = np.setdiff1d(every[b], self.contact_facets[b])
            if self.comm.allreduce(len(out), op=MPI.SUM) == 0:
                continue
            left = ContactSurface(self.V, out, b, mask, name=f"{b} outside the condensed surface")
            tooth = self._teeth_of(b, left)["gathered"]
            guards.append(
                Guard(
                    ContactInterface(left, whole[other], self.contact, youngs),
                    np.array([f"{b} tooth {k}" for k in tooth], dtype=object),
                )
            )
        return guards

    def _facet_teeth(self, body: str) -> dict[str, np.ndarray]:
        """Tooth index of every facet of a body's contact surface: local and gathered order."""
        return self._teeth_of(body, self.surfaces[body])

    def _teeth_of(self, body: str, surf: ContactSurface) -> dict[str, np.ndarray]:
        local = self._tooth_labels(body, surf.facets)
        gathered = np.concatenate(self.comm.allgather(local)) if self.comm.size > 1 else local
        return {"local": local, "gathered": gathered}

    def _tooth_labels(self, body: str, facets: np.ndarray) -> np.ndarray:
        """Tooth index of each of the local ``facets`` of ``body`` (−1: not on a tooth)."""
        return self.gm.facet_groups(body, facets)[0]

    def _check_torque(self) -> None:
        """Refuse torques whose tooth deflection would close the backlash: the coast flanks are not
        contact surfaces, so the model cannot represent them touching."""
        b_mm = self.gm.geometry.face_width_mm
        E = min(m.youngs_modulus_Pa for m in self.materials.values())
        c = self.options.mesh_stiffness_guess_N_mm_um * E / 3.7e9  # N/(mm µm)
        jn = self.pair.backlash_normal_m
        t_max = c * b_mm * jn * 1e6 * self.pair.wheel.base_radius_m
        if self.torque_Nm > t_max:
            raise ParameterError(
                "operating.torque_Nm",
                self.torque_Nm,
                f"(0, {t_max:.1f}] N m for this pair",
                f"the estimated deflection would exceed the normal backlash {jn * 1e6:.0f} um; "
                "coast-flank contact is not modelled",
            )

    def nominal_hertz(self) -> tuple[float, float]:
        """(half-width a, peak pressure p0) of the Hertz line contact at the pitch point under the
        nominal load (the whole normal load on one pair, equal per unit face width)."""

        pair = self.pair
        s = math.sin(pair.operating_pressure_angle_rad)
        r1, r2 = pair.pinion.operating_pitch_radius_m * s, pair.wheel.operating_pitch_radius_m * s
        w = self.torque_Nm / pair.wheel.base_radius_m / pair.face_width_m
        mp, mw = self.materials["pinion"], self.materials["wheel"]
        return hertz_line_contact(
            w,
            r1,
            r2,
            mp.youngs_modulus_Pa,
            mp.poissons_ratio,
            mw.youngs_modulus_Pa,
            mw.poissons_ratio,
        )

    def carter_creep_ratio(self, mu: float) -> float:
        """μ a / (2 R) at the pitch point under the nominal load (Hertz line contact, equal load
        per unit face width), the creep at which a rolling contact is well into partial slip."""
        pair = self.pair
        s = math.sin(pair.operating_pressure_angle_rad)
        r1, r2 = pair.pinion.operating_pitch_radius_m * s, pair.wheel.operating_pitch_radius_m * s
        a, _ = self.nominal_hertz()
        return max(mu, 1e-3) * a / (2.0 * r1 * r2 / (r1 + r2))

    def kinematic_wheel_angle(self, phi: float) -> float:
        return float(self.pair.wheel_angle(phi))

    def set_position(self, phi_rad: float, windup_rad: float) -> None:
        self.phi = float(phi_rad)
        self.problem.set_motion(
            "pinion", dataclasses.replace(self._motion0["pinion"], angle_rad=self.phi)
        )
        self.problem.set_motion(
            "wheel",
            dataclasses.replace(
                self._motion0["wheel"], angle_rad=self.kinematic_wheel_angle(self.phi) + windup_rad
            ),
        )

    def windup_guess_rad(self) -> float:
        """First predictor of δψ: a linear mesh stiffness guess (plus the initial interference)."""
        b_mm = self.gm.geometry.face_width_mm
        rb2 = self.base_radius_m["wheel"]
        E = min(m.youngs_modulus_Pa for m in self.materials.values())
        c = self.options.mesh_stiffness_guess_N_mm_um * E / 3.7e9  # N/(mm µm)
        deflection_um = (self.torque_Nm / rb2) / (c * b_mm)
        return (deflection_um * 1e-6 + self.options.initial_interference_m) / rb2

    def solve_position(self, phi_rad: float, label: str):
        """Solve at pinion angle φ (warm start from the last position). Returns the SolveReport."""
        dpsi = self.windup_rad if self.windup_rad is not None else self.windup_guess_rad()
        self.set_position(phi_rad, dpsi)
        rep = self.problem.solve(label)
        self.windup_rad = self.problem.controlled_angle - self.kinematic_wheel_angle(phi_rad)
        return rep

    # -------------------------------------------------------------------------------------------
    def transmission_error_m(self) -> float:
        """Wind-up of the wheel as a displacement along the line of action (lag > 0), m."""
        return self.base_radius_m["wheel"] * self.windup_rad

    def pinion_torque_Nm(self) -> float:
        """Torque the pinion hub must supply (minus the contact moment on the pinion), N m."""
        mot = self.problem.motions["pinion"]
        return -self.problem.contact_moment(np.asarray(mot.center), np.asarray(mot.axis))
