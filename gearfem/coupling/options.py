"""The ``[sources]`` options: where the heat sources come from and how the heat is split between
the gears (DOLFINx-free)."""

from __future__ import annotations

import dataclasses

from gearfem.core.errors import ParameterError
from gearfem.core.materials import Material
from gearfem.core.params import require_choice, require_nonnegative, require_range
from gearfem.thermal.options import LOADING_FREQUENCIES, PrescribedSources


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
        hysteresis_scale, flux_scale: Multipliers (model-discrepancy hooks).
        friction_temperature_coefficient_per_K: beta of a friction coefficient that falls with the
            local flank temperature, mu(T) = mu_ref exp(-beta (T - friction_reference_C)) (thesis
            4.3.5: PEEK-PEEK mu fell from 0.55 to 0.40 between 50 and 75 C, about 0.013 /K at its
            steepest). Applied to the friction flux at the temperature of each flank point, at
            every step and Newton iteration (mode "cycle" only). 0 (default): mu independent of T.
        friction_reference_C: Temperature at which mu = mu_ref (the cycle's friction coefficient).
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
    friction_temperature_coefficient_per_K: float = 0.0
    friction_reference_C: float = 25.0
    flank_heat_per_gear_W: float = 0.0
    u_max_J_m3: float = 0.0
    flanks: str = "drive"

    def __post_init__(self) -> None:
        require_choice("sources.mode", self.mode, ("cycle", "prescribed"))
        require_choice("sources.loading_frequency", self.loading_frequency, LOADING_FREQUENCIES)
        if self.heat_fraction_pinion is not None:
            require_range("sources.heat_fraction_pinion", self.heat_fraction_pinion, 0.0, 1.0)
        require_nonnegative("sources.hysteresis_scale", self.hysteresis_scale)
        require_nonnegative("sources.flux_scale", self.flux_scale)
        require_range(
            "sources.friction_temperature_coefficient_per_K",
            self.friction_temperature_coefficient_per_K,
            0.0,
            0.1,
            unit="1/K",
        )
        require_range(
            "sources.friction_reference_C",
            self.friction_reference_C,
            -273.15,
            1000.0,
            lo_open=True,
            unit="C",
        )
        if self.mode == "prescribed" and self.friction_temperature_coefficient_per_K > 0.0:
            raise ParameterError(
                "sources.friction_temperature_coefficient_per_K",
                self.friction_temperature_coefficient_per_K,
                "0 in mode 'prescribed'",
                "mu(T) acts on the friction flux of the contact cycle (mode 'cycle')",
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

    def heat_fractions(self, materials: dict[str, Material]) -> dict[str, float]:
        """Share of the friction heat generated in the mesh that flows into each gear:
        ``heat_fraction_pinion`` if set, else by thermal effusivity b = sqrt(k ρ c_p) (½ each for
        equal materials, thesis 5.2.3). Applied by the coupling, after the (cached) cycle."""
        if self.heat_fraction_pinion is not None:
            return {"pinion": self.heat_fraction_pinion, "wheel": 1.0 - self.heat_fraction_pinion}
        b1, b2 = (materials[b].thermal_effusivity for b in ("pinion", "wheel"))
        return {"pinion": b1 / (b1 + b2), "wheel": b2 / (b1 + b2)}
