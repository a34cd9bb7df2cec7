"""The resolved thermal boundary model: what each surface role exchanges with its surroundings.

A :class:`SurfaceExchange` is the outward heat flux density of one surface role (W/m^2)::

    q_out = h(T) (T - T_fluid) + eps sigma (T^4 - T_surr^4),

with h a number or a function of the local temperature (UFL). :class:`ThermalBoundary` holds one
for the teeth, one for the sides and optionally one for the bore (a Robin heat path; None is
adiabatic, the thesis's choice). Cut faces are always adiabatic.

This object, not :class:`~gearfem.thermal.options.ThermalOptions`, is what the solver uses, so a
model extension (convection multiplier or speed exponent, extra bore heat path, ambient offset)
builds its own boundary with :func:`dataclasses.replace` or the constructor, without touching the
solver. :meth:`ThermalBoundary.from_options` builds the thesis model.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

from gearfem.core.errors import ParameterError
from gearfem.core.materials import ZERO_CELSIUS_K, Material
from gearfem.core.params import require_positive, require_range
from gearfem.thermal import convection as conv
from gearfem.thermal.options import ThermalOptions

HeatTransferCoefficient = float | Callable[[Any], Any]  # W/(m^2 K), or T (kelvin, UFL) -> W/(m^2 K)


@dataclasses.dataclass(frozen=True)
class SurfaceExchange:
    """Convection and radiation of one surface role.

    Args:
        h_W_m2K: Heat transfer coefficient, or a callable of the local temperature (kelvin, UFL).
        fluid_K: Temperature of the fluid the convection leads to, K.
        emissivity: Surface emissivity in [0, 1] (0: no radiation).
        surroundings_K: Radiation sink temperature, K (None: ``fluid_K``).
    """

    h_W_m2K: HeatTransferCoefficient
    fluid_K: float
    emissivity: float = 0.0
    surroundings_K: float | None = None

    def __post_init__(self) -> None:
        if not callable(self.h_W_m2K):
            require_range("h_W_m2K", self.h_W_m2K, 0.0, float("inf"))
        require_positive("fluid_K", self.fluid_K)
        require_range("emissivity", self.emissivity, 0.0, 1.0)
        if self.surroundings_K is not None:
            require_positive("surroundings_K", self.surroundings_K)

    @property
    def radiation_K(self) -> float:
        return self.fluid_K if self.surroundings_K is None else self.surroundings_K

    def h(self, T: Any) -> Any:
        """The coefficient as a UFL expression (or float) at temperature T."""
        return self.h_W_m2K(T) if callable(self.h_W_m2K) else float(self.h_W_m2K)


@dataclasses.dataclass(frozen=True)
class ThermalBoundary:
    """Surface exchanges by role; the bore is adiabatic when ``bore`` is None.

    ``convection`` carries the correlation results (Reynolds numbers, range flags) when the
    thesis model built it, for reporting.
    """

    teeth: SurfaceExchange
    sides: SurfaceExchange
    bore: SurfaceExchange | None = None
    convection: conv.ConvectionCoefficients | None = None

    def exchanges(self) -> dict[str, SurfaceExchange]:
        out = {"teeth": self.teeth, "sides": self.sides}
        if self.bore is not None:
            out["bore"] = self.bore
        return out

    @classmethod
    def from_options(
        cls,
        options: ThermalOptions,
        material: Material,
        speed_rpm: float,
        radii: conv.GearRadii | None,
    ) -> ThermalBoundary:
        """The thesis boundary model at ``speed_rpm`` (eq. 5.1-5.6, eps from the material, 23 C).

        ``radii`` may be None only when both coefficients are given explicitly or convection is off.
        """
        amb = options.ambient_C + ZERO_CELSIUS_K
        eps = material.emissivity if options.emissivity is None else options.emissivity
        air = options.air()
        coeffs = None
        h_t: HeatTransferCoefficient
        h_s: HeatTransferCoefficient
        if options.convection == "none":
            h_t = h_s = 0.0
        else:
            need = options.h_teeth_W_m2K is None or options.h_sides_W_m2K is None
            if need:
                if radii is None:
                    raise ParameterError(
                        "geometry radii",
                        None,
                        "pitch, base and inner radius for the thesis correlations",
                    )
                coeffs = conv.thesis_convection(
                    speed_rpm, radii, air, amb if air.model != "thesis" else 298.15
                )
            if options.h_teeth_W_m2K is not None:
                h_t = options.h_teeth_W_m2K
            elif air.model == "film":
                h_t = _film_h(conv.h_teeth_W_m2K, speed_rpm, radii, air, amb)
            else:
                h_t = coeffs.h_teeth_W_m2K
            if options.h_sides_W_m2K is not None:
                h_s = options.h_sides_W_m2K
            elif air.model == "film":
                h_s = _film_h(conv.h_sides_W_m2K, speed_rpm, radii, air, amb)
            else:
                h_s = coeffs.h_sides_W_m2K
        h_t = _scaled(h_t, options.h_teeth_factor)
        h_s = _scaled(h_s, options.h_sides_factor)
        bore = None
        if options.bore_h_W_m2K > 0.0:
            bore_K = amb if options.bore_C is None else options.bore_C + ZERO_CELSIUS_K
            bore = SurfaceExchange(options.bore_h_W_m2K, bore_K, 0.0)
        return cls(
            teeth=SurfaceExchange(h_t, amb, eps),
            sides=SurfaceExchange(h_s, amb, eps),
            bore=bore,
            convection=coeffs,
        )


def _scaled(h: HeatTransferCoefficient, factor: float) -> HeatTransferCoefficient:
    if factor == 1.0:
        return h
    if callable(h):
        return lambda T, _h=h, _f=factor: _f * _h(T)
    return factor * h


def _film_h(correlation, speed_rpm, radii, air, amb_K):
    """h(T) with air properties at the local film temperature (T + T_amb)/2."""

    def h(T):
        film = 0.5 * (T + amb_K)
        return correlation(speed_rpm, radii, air.nu(film), air.k(film))

    return h
