"""The ``[sources]`` options: where the heat sources come from and how the heat is split between
the gears (DOLFINx-free)."""

from __future__ import annotations

import dataclasses

from gearfem.core.errors import ParameterError
from gearfem.core.materials import Material
from gearfem.core.params import require_choice, require_nonnegative, require_range
from gearfem.thermal.options import LOADING_FREQUENCIES, PrescribedSources

HEAT_PARTITIONS = ("fixed", "blok", "contact_temperature")
#: How a thermal flank facet takes the reconstructed flux (:mod:`gearfem.coupling.transfer`).
FLUX_EVALUATIONS = ("reference_facets", "continuous")
#: Keys of earlier versions and what replaces them (a case file that has them is refused by name).
REMOVED_KEYS = {
    "friction_temperature_coefficient_per_K": (
        "[friction] temperature_coefficient_per_K = beta (mu = mu_T exp(-beta (T - reference_C)),"
        " beta > 0 falls with T; contact_temperature = 'flank' applies it to the flank "
        "temperature as before)"
    ),
    "friction_reference_C": "[friction] reference_C",
}


@dataclasses.dataclass(frozen=True)
class FluxReconstruction:
    """How the cycle's facet flux is reconstructed before it goes to the thermal mesh
    (:mod:`gearfem.coupling.transfer`).

    Attributes:
        sigma_m: Standard deviations (m) of the Gaussian kernel in the flank's plane and along
            the face width, both > 0.
        evaluation: One of :data:`FLUX_EVALUATIONS` (see :class:`SourceOptions`).
    """

    sigma_m: tuple[float, float]
    evaluation: str = "reference_facets"

    def __post_init__(self) -> None:
        for name, v in zip(("profile", "axial"), self.sigma_m):
            if not v > 0.0:
                raise ParameterError(f"flux reconstruction sigma_m ({name})", v, "> 0 m")
        require_choice("flux reconstruction evaluation", self.evaluation, FLUX_EVALUATIONS)


@dataclasses.dataclass(frozen=True)
class SourceOptions:
    """``[sources]``: where the heat sources come from and how they are applied.

    Attributes:
        mode: ``"cycle"`` (from the contact cycle, the default) or ``"prescribed"`` (the fields
            below, for studies without the structural stage).
        hysteresis, friction: Include each source.
        loading_frequency: f of q_h = H U_max f: ``"rotation"`` (n/60, as the thesis) or
            ``"tooth_pass"`` (z n/60).
        heat_fraction_pinion: Share of the friction heat into the pinion (None: by thermal
            effusivity, ½ for equal materials, thesis 5.2.3).
        heat_partition: How the friction heat of each contact is shared between the gears:
            ``"fixed"`` (``heat_fraction_pinion`` or the effusivity ratio, everywhere alike; the
            thesis) or ``"blok"`` (per contact band, the share that makes both flanks' flash
            temperatures equal, Blok's postulate: f1 = (k1/g1)/(k1/g1 + k2/g2), with g the band
            source solution at each flank's Peclet number; at high Peclet numbers
            b1 sqrt(v1)/(b1 sqrt(v1) + b2 sqrt(v2)), so the faster-rolling flank takes more).
            Mode "cycle" only (:mod:`gearfem.coupling.friction_heat`). ``"contact_temperature"``:
            one share for the pair, solved for so that both gears' heat-weighted mean contact
            temperatures (flank + flash) agree within ``contact_temperature_tolerance_K`` (K)
            (:func:`gearfem.pipeline.split_by_contact_temperature`: both gears' thermal runs,
            repeated; ``heat_fraction_pinion`` is where the search starts).
        contact_temperature_tolerance_K: How closely (K) the ``"contact_temperature"`` partition
            makes the two gears' heat-weighted mean contact temperatures agree.
        hysteresis_scale, flux_scale: Multipliers (model-discrepancy hooks).
        flux_smoothing_profile_mm, flux_smoothing_axial_mm: Standard deviations (mm) of the
            Gaussian with which the cycle's friction flux, a value per structural facet summed
            over discrete positions, is spread over the neighbouring facets before it goes to the
            thermal mesh (in the flank's plane and along the face width; conservative: every
            facet's heat is kept). The contact sweeps the flank continuously; the cycle samples it
            at ``positions_per_pitch`` positions on facets of ``[mesh] size_flank_mm`` and
            ``layers``, and without the reconstruction the finer thermal meshes resolve that
            sampling (a comb of bands one facet wide) instead of the heat. Of the order of the
            structural flank element and a third of a layer; refined with the structural mesh
            (``gearfem converge --kind structural_mesh`` scales the profile width,
            ``structural_layers`` the axial one, ``positions`` the profile width with the
            positions' spacing). 0: none (piecewise constant per structural facet).
        flux_evaluation: Where the reconstruction is evaluated for the thermal facets:
            ``"reference_facets"`` (one value per structural facet, the thermal facet's mean of
            that piecewise constant field; the default) or ``"continuous"`` (the reconstruction's
            kernel evaluated at the thermal facet's own sample points: a smooth field, no steps at
            the structural facets' edges). Needs the smoothing widths > 0.
        flank_heat_per_gear_W, u_max_J_m3, flanks: Prescribed mode only (see
            :class:`gearfem.thermal.source_terms.PrescribedSources`).
    """

    mode: str = "cycle"
    hysteresis: bool = True
    friction: bool = True
    loading_frequency: str = "rotation"
    heat_fraction_pinion: float | None = None
    hysteresis_scale: float = 1.0
    flux_scale: float = 1.0
    heat_partition: str = "fixed"
    flank_heat_per_gear_W: float = 0.0
    u_max_J_m3: float = 0.0
    flanks: str = "drive"
    flux_smoothing_profile_mm: float = 0.1
    flux_smoothing_axial_mm: float = 1.5
    flux_evaluation: str = "reference_facets"
    contact_temperature_tolerance_K: float = 0.5

    def __post_init__(self) -> None:
        require_choice("sources.mode", self.mode, ("cycle", "prescribed"))
        require_choice("sources.loading_frequency", self.loading_frequency, LOADING_FREQUENCIES)
        if self.heat_fraction_pinion is not None:
            require_range("sources.heat_fraction_pinion", self.heat_fraction_pinion, 0.0, 1.0)
        require_nonnegative("sources.hysteresis_scale", self.hysteresis_scale)
        require_nonnegative("sources.flux_scale", self.flux_scale)
        require_range("sources.flux_smoothing_profile_mm", self.flux_smoothing_profile_mm, 0.0, 5.0)
        require_range("sources.flux_smoothing_axial_mm", self.flux_smoothing_axial_mm, 0.0, 50.0)
        if (self.flux_smoothing_profile_mm == 0.0) != (self.flux_smoothing_axial_mm == 0.0):
            raise ParameterError(
                "sources.flux_smoothing_profile_mm",
                (self.flux_smoothing_profile_mm, self.flux_smoothing_axial_mm),
                "both > 0 (smoothed) or both 0 (piecewise constant per structural facet)",
            )
        require_choice("sources.flux_evaluation", self.flux_evaluation, FLUX_EVALUATIONS)
        if self.flux_evaluation == "continuous" and self.flux_smoothing_profile_mm == 0.0:
            raise ParameterError(
                "sources.flux_evaluation",
                self.flux_evaluation,
                "'reference_facets' when flux_smoothing_profile_mm = flux_smoothing_axial_mm = 0",
                "the continuous evaluation is the smoothing kernel's",
            )
        require_choice("sources.heat_partition", self.heat_partition, HEAT_PARTITIONS)
        require_range(
            "sources.contact_temperature_tolerance_K",
            self.contact_temperature_tolerance_K,
            0.0,
            10.0,
            lo_open=True,
            unit="K",
        )
        if self.mode == "prescribed" and self.heat_partition != "fixed":
            raise ParameterError(
                "sources.heat_partition",
                self.heat_partition,
                "'fixed' in mode 'prescribed'",
                "Blok's partition needs the contact history of the cycle (mode 'cycle')",
            )
        self.prescribed()  # validates the prescribed fields

    def prescribed(self) -> PrescribedSources:
        return PrescribedSources(
            flank_heat_per_gear_W=self.flank_heat_per_gear_W if self.friction else 0.0,
            flanks=self.flanks,
            u_max_J_m3=self.u_max_J_m3 if self.hysteresis else 0.0,
            loading_frequency=self.loading_frequency,
            hysteresis_scale=self.hysteresis_scale,
            flux_scale=self.flux_scale,
        )

    @property
    def flux_reconstruction(self) -> FluxReconstruction | None:
        """The flux reconstruction these options ask for, None: none (piecewise constant per
        structural facet)."""
        if self.flux_smoothing_profile_mm == 0.0:
            return None
        return FluxReconstruction(
            sigma_m=(self.flux_smoothing_profile_mm * 1e-3, self.flux_smoothing_axial_mm * 1e-3),
            evaluation=self.flux_evaluation,
        )

    def heat_fractions(self, materials: dict[str, Material]) -> dict[str, float]:
        """Share of the friction heat generated in the mesh that flows into each gear:
        ``heat_fraction_pinion`` if set, else by thermal effusivity b = sqrt(k ρ c_p) (½ each for
        equal materials, thesis 5.2.3). Applied by the coupling, after the (cached) cycle."""
        if self.heat_fraction_pinion is not None:
            return {"pinion": self.heat_fraction_pinion, "wheel": 1.0 - self.heat_fraction_pinion}
        b1, b2 = (materials[b].thermal_effusivity for b in ("pinion", "wheel"))
        return {"pinion": b1 / (b1 + b2), "wheel": b2 / (b1 + b2)}
