"""The ``[cycle]`` options: how the pinion is stepped through the mesh cycle and which contact
solver does it (DOLFINx-free)."""

from __future__ import annotations

import dataclasses

from gearfem.core.errors import ParameterError
from gearfem.core.params import require_choice, require_int, require_positive, require_range
from gearfem.geometry.options import TOOTH_KINDS

#: Contact solvers of the cycle (``[cycle] solver``).
SOLVERS = ("condensed", "full")

#: How a cycle uses several MPI ranks (``[cycle] parallel``).
PARALLEL_MODES = ("positions", "mesh")

#: Where the cycle's Young's modulus comes from (``[cycle] modulus``).
MODULUS_MODES = ("constant", "thermal_state")

#: The options of the cycle <-> heat fixed point in the modulus: they decide which cycles are
#: solved, not what a cycle holds (its modulus field's digest does), so not part of its key.
MODULUS_LOOP_KEYS = ("modulus", "modulus_tolerance", "modulus_max_passes")


@dataclasses.dataclass(frozen=True)
class CycleOptions:
    """How the mesh cycle is swept (the ``[cycle]`` table).

    Attributes:
        positions_per_pitch: Pinion positions per tooth pitch (one pitch is 12° for 30 teeth).
        pitches: Length of the cycle solve in pitches. 1 uses the rotational periodicity of the
            state (every pitch repeats with the tooth numbers shifted by one) to get each tooth's
            whole engagement; 3 covers 36° as the thesis did.
        start_angle_deg: Pinion angle of the first position relative to the mesh as built (where
            the reference teeth touch at the pitch point).
        check_periodicity: Also solve the position one pitch after the start and report how far it
            is from the first position mapped by one tooth (costs one position).
        contact_kinds: Tooth surfaces that may touch the other gear.
        mesh_stiffness_guess_N_mm_um: Only for the first predictor of the wind-up (a gear pair's
            mesh stiffness per unit face width, scaled from PEEK with the Young's modulus).
        initial_interference_m: Rigid pre-rotation of the wheel (along the line of action) that
            gives the first Newton iteration contact stiffness before the torque is balanced.
        creep_ratio: Slip (relative to the rolling speed) at which friction approaches μ p. Near the
            pitch point the flanks roll with little sliding and the contact is in micro-slip
            (Carter;
            Johnson, Contact Mechanics §8.2: full slip of a rolling line contact needs a creep of
            about μ a / R). The gross-sliding law is regularised there with
            v_ε = creep_ratio · v_roll (v_roll: rolling speed of the flanks at the pitch point);
            None: Carter's estimate μ a / (2 R) from the Hertz half-width at the nominal load.
            This sets ``ContactOptions.slip_regularization_m_s`` for the gear cycle.
        pressure_smoothing_fraction: δ of the C1 pressure ramp
            (``ContactOptions.pressure_smoothing_Pa``) as a fraction of the nominal Hertz pressure
            at the pitch point, used when the contact options leave it 0. With friction, the exact
            ramp's kink at the edge of the contact zone (rounded tips entering and leaving contact)
            can make Newton cycle at a residual just above tolerance (measured on the 4-tooth test
            mesh at 8 N m, μ = 0.5: 40 iterations stuck at 7e-5 relative; with δ = 0.4 % of p0:
            13-18 iterations). 0 keeps the exact ramp.
        solver: ``"condensed"``: each gear's stiffness is condensed once (per mesh and material)
            onto the contact surfaces of the teeth that can engage over the solved angles, and
            every position is solved on those surfaces only (:mod:`gearfem.contact.condensed`; the
            volume field by back-substitution). ``"full"``: the whole 3D system at every Newton
            iteration (the reference). Both solve the same discrete problem.
        condensed_margin_pitches: With the condensed solver, how far beyond the rigid contact the
            condensed surfaces reach, in base pitches along the line of action: per tooth pair,
            the range of the contact parameter S that the rigid pair sweeps over the solved
            angles, clipped to the path of contact, is widened by this margin at each end, and the
            condensed surfaces hold the contact facets whose involute roll places them in that
            range (:meth:`gearfem.cycle.model.GearContactModel.condensed_facets`). The margin
            covers the contact's width and the loaded teeth's longer path. The facets left out
            are checked after every position: a contact there raises an error naming the tooth.
        parallel: How the condensed solver uses several MPI ranks. ``"positions"``: every rank
            holds the whole pair mesh and solves its own contiguous block of the positions (the
            gears' compliances computed once, one gear per rank); the positions are independent
            once the compliances exist, so the cycle scales with the ranks. ``"mesh"``: the mesh
            is distributed, the contact points are evaluated by the ranks that own them and the
            dense active-set algebra runs on rank 0. Both give the same result within the contact
            solver's tolerance (a block's first position starts from zero contact force), so the
            choice, like the number of ranks, is not part of the stored cycle's key. The full
            solver always distributes the mesh.
        modulus: Where the cycle's Young's modulus comes from. ``"constant"``: each material's
            ``youngs_modulus_Pa``. ``"thermal_state"``: cell by cell from the gears' thermal state
            through the material's E(T) table, E_c = E e(T_c) with e the table relative to its
            first value (:mod:`gearfem.cycle.modulus_field`), iterated with the heat: the first
            cycle at the constant modulus, each next one with the field of the previous thermal
            state, until no cell's relative modulus moves by ``modulus_tolerance`` or more; both
            gears' thermal models are run. Needs a material with an E(T) table (every polymer of
            the library: PEEK 450G's from a tension study, POM's and PA66's estimates); a steel
            gear keeps its modulus.
        modulus_tolerance: The largest relative change of a cell's modulus between a cycle's
            field and that of its thermal state below which the fixed point has settled (0.05:
            about 3 K where PEEK 450G's modulus falls fastest, near 155 C).
        modulus_max_passes: Cycles the fixed point may take; not settled after as many raises
            ConvergenceError naming each pass's moduli.
    """

    positions_per_pitch: int = 24
    pitches: float = 1.0
    start_angle_deg: float = 0.0
    check_periodicity: bool = False
    contact_kinds: tuple[str, ...] = ("drive_flank", "tip", "root")
    mesh_stiffness_guess_N_mm_um: float = 0.3
    initial_interference_m: float = 2e-6
    creep_ratio: float | None = None
    pressure_smoothing_fraction: float = 0.005
    solver: str = "condensed"
    condensed_margin_pitches: float = 0.5
    parallel: str = "positions"
    modulus: str = "constant"
    modulus_tolerance: float = 0.05
    modulus_max_passes: int = 4

    def __post_init__(self) -> None:
        require_int("cycle.positions_per_pitch", self.positions_per_pitch, 2, 2000)
        require_range("cycle.pitches", self.pitches, 0.0, 30.0, lo_open=True)
        require_range("cycle.start_angle_deg", self.start_angle_deg, -360.0, 360.0)
        for k in self.contact_kinds:
            if k not in TOOTH_KINDS:
                raise ParameterError("cycle.contact_kinds", k, "one of " + ", ".join(TOOTH_KINDS))
        require_positive("cycle.mesh_stiffness_guess_N_mm_um", self.mesh_stiffness_guess_N_mm_um)
        require_positive("cycle.initial_interference_m", self.initial_interference_m)
        if self.creep_ratio is not None:
            require_range("cycle.creep_ratio", self.creep_ratio, 0.0, 1.0, lo_open=True)
        require_range(
            "cycle.pressure_smoothing_fraction", self.pressure_smoothing_fraction, 0.0, 0.1
        )
        require_choice("cycle.solver", self.solver, SOLVERS)
        require_range("cycle.condensed_margin_pitches", self.condensed_margin_pitches, 0.0, 10.0)
        require_choice("cycle.parallel", self.parallel, PARALLEL_MODES)
        require_choice("cycle.modulus", self.modulus, MODULUS_MODES)
        require_range("cycle.modulus_tolerance", self.modulus_tolerance, 0.0, 0.5, lo_open=True)
        require_int("cycle.modulus_max_passes", self.modulus_max_passes, 1, 20)

    @property
    def positions_over_ranks(self) -> bool:
        """Whether several ranks solve different positions (the condensed solver with
        ``parallel = "positions"``)."""
        return self.solver == "condensed" and self.parallel == "positions"
