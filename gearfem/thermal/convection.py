"""Convective heat transfer coefficients of a spur gear in quiescent air (thesis eq. 5.1-5.6).

Doll (2015, section 5.1.5) treats the toothed rim as a cylinder rotating in still air and the two
side faces as a disc rotating in still air:

* teeth (tips, flanks, roots), eq. 5.1-5.3 (Özerdem's rotating-cylinder data)::

      h_t = Nu_t k_air / D_p,   Nu_t = 0.318 Re_t^0.571,   Re_t = omega D_p^2 / (2 nu),
      valid for 2 000 <= Re_t <= 40 000;

* sides, eq. 5.4-5.6 (Latour's rotating-disc data)::

      h_s = Nu_s k_air / (2 r_i),   Nu_s = 0.556 Re_s^0.5,   Re_s = omega 2 r_b r_i / nu,
      valid for 2 150 <= Re_s <= 17 200,

with omega the angular speed (rad/s), D_p the operating pitch diameter, r_b the base-circle radius
and r_i the inner radius of the gear (all in metres). Re_s is used exactly as printed in the thesis.

Air properties (:class:`AirProperties`): the thesis's constants (``"thesis"``: kinematic viscosity
1.557e-5 m^2/s of dry air at 25 C, as stated in section 5.1.5; the thesis does not state k_air, we
use 0.0261 W/(m K), dry air at 25 C from Sutherland's law below, which agrees with the
interpolated Incropera & DeWitt Table A.4 value), or Sutherland's law at the ambient temperature
(``"ambient"``) or at the local film temperature (T + T_amb)/2 (``"film"``, a UFL expression
solved implicitly with the temperature). Sutherland's law for air (F. M. White, *Viscous Fluid
Flow*, 3rd ed., 2006, Tables 1-2 and 1-3)::

      mu(T) = 1.716e-5 Pa s (T/273 K)^1.5 (273 K + 111 K)/(T + 111 K)
      k(T)  = 0.0241 W/(m K) (T/273 K)^1.5 (273 K + 194 K)/(T + 194 K)
      rho(T) = p / (R_air T),  p = 101 325 Pa,  R_air = 287.05 J/(kg K),   nu = mu / rho.

It gives nu = 1.553e-5 m^2/s at 25 C (the thesis: 1.557e-5). Outside the correlations' Reynolds
ranges the coefficients are extrapolated, never clamped: a warning is logged and the returned
:class:`ConvectionCoefficients` carries ``*_in_range = False``.

The functions work on floats and on UFL expressions alike (only ``*``, ``/`` and ``**``).
"""

from __future__ import annotations

import dataclasses
import logging
import math
from typing import Any

from gearfem.core.errors import ParameterError
from gearfem.core.params import require_choice, require_nonnegative, require_positive

log = logging.getLogger(__name__)

# Thesis section 5.1.5 (dry air at 25 C).
THESIS_AIR_NU_m2_s = 1.557e-5
# Not stated in the thesis: Sutherland (White 2006) at 298.15 K, = 0.02610; Incropera A.4
# interpolated: 0.0261.
THESIS_AIR_K_W_mK = 0.0261

RE_TEETH_RANGE = (2.0e3, 4.0e4)  # thesis eq. 5.3 (Özerdem)
RE_SIDES_RANGE = (2150.0, 17200.0)  # thesis eq. 5.6 (Latour)

_MU0, _T0_MU, _S_MU = 1.716e-5, 273.0, 111.0
_K0, _T0_K, _S_K = 0.0241, 273.0, 194.0
_P_ATM, _R_AIR = 101325.0, 287.05

AIR_MODELS = ("thesis", "ambient", "film")


def air_viscosity_Pa_s(T_K: Any) -> Any:
    """Dynamic viscosity of air, Sutherland's law (White 2006, Table 1-2), Pa s."""
    return _MU0 * (T_K / _T0_MU) ** 1.5 * (_T0_MU + _S_MU) / (T_K + _S_MU)


def air_conductivity_W_mK(T_K: Any) -> Any:
    """Thermal conductivity of air, Sutherland's law (White 2006, Table 1-3), W/(m K)."""
    return _K0 * (T_K / _T0_K) ** 1.5 * (_T0_K + _S_K) / (T_K + _S_K)


def air_kinematic_viscosity_m2_s(T_K: Any) -> Any:
    """nu = mu / rho with rho from the ideal gas law at 101 325 Pa, m^2/s."""
    return air_viscosity_Pa_s(T_K) * _R_AIR * T_K / _P_ATM


@dataclasses.dataclass(frozen=True)
class AirProperties:
    """Air properties for the correlations.

    Args:
        model: ``"thesis"`` (constants at 25 C), ``"ambient"`` (Sutherland at the ambient
            temperature) or ``"film"`` (Sutherland at the local film temperature (T + T_amb)/2).
        kinematic_viscosity_m2_s: Replaces nu of the ``"thesis"`` model (not allowed otherwise).
        conductivity_W_mK: Replaces k_air of the ``"thesis"`` model (not allowed otherwise).
    """

    model: str = "thesis"
    kinematic_viscosity_m2_s: float | None = None
    conductivity_W_mK: float | None = None

    def __post_init__(self) -> None:
        require_choice("thermal.air_properties", self.model, AIR_MODELS)
        for name, value in (
            ("air_kinematic_viscosity_m2_s", self.kinematic_viscosity_m2_s),
            ("air_conductivity_W_mK", self.conductivity_W_mK),
        ):
            if value is None:
                continue
            require_positive(f"thermal.{name}", value)
            if self.model != "thesis":
                raise ParameterError(
                    f"thermal.{name}",
                    value,
                    "unset unless thermal.air_properties = 'thesis'",
                    f"air_properties = {self.model!r} computes it from Sutherland's law",
                )

    def nu(self, T_film_K: Any) -> Any:
        """Kinematic viscosity at the film temperature (ignored by the ``"thesis"`` model),
        m^2/s."""
        if self.model == "thesis":
            return self.kinematic_viscosity_m2_s or THESIS_AIR_NU_m2_s
        return air_kinematic_viscosity_m2_s(T_film_K)

    def k(self, T_film_K: Any) -> Any:
        """Thermal conductivity at the film temperature (ignored by the ``"thesis"`` model), W/(m
        K)."""
        if self.model == "thesis":
            return self.conductivity_W_mK or THESIS_AIR_K_W_mK
        return air_conductivity_W_mK(T_film_K)


@dataclasses.dataclass(frozen=True)
class GearRadii:
    """The lengths the correlations need, in metres.

    Args:
        pitch_diameter_m: Operating pitch diameter D_p (eq. 5.1, 5.3).
        base_radius_m: Base-circle radius r_b (eq. 5.6).
        inner_radius_m: Inner radius of the gear body r_i (eq. 5.4, 5.6).
    """

    pitch_diameter_m: float
    base_radius_m: float
    inner_radius_m: float

    def __post_init__(self) -> None:
        require_positive("geometry.pitch_diameter_m", self.pitch_diameter_m)
        require_positive("geometry.base_radius_m", self.base_radius_m)
        require_positive("geometry.inner_radius_m", self.inner_radius_m)
        if self.base_radius_m >= 0.5 * self.pitch_diameter_m:
            raise ParameterError(
                "geometry.base_radius_m",
                self.base_radius_m,
                f"< pitch radius {0.5 * self.pitch_diameter_m:g} m",
            )
        if self.inner_radius_m >= self.base_radius_m:
            raise ParameterError(
                "geometry.inner_radius_m",
                self.inner_radius_m,
                f"< base radius {self.base_radius_m:g} m",
            )

    @classmethod
    def thesis_gear(cls) -> GearRadii:
        """The thesis test gear: D_p = 60 mm, pressure angle 30 deg, r_i = 15 mm (assumed, see
        thesis_gear.toml)."""
        return cls(0.060, 0.030 * math.cos(math.radians(30.0)), 0.015)


def omega_rad_s(speed_rpm: Any) -> Any:
    return 2.0 * math.pi * speed_rpm / 60.0


def reynolds_teeth(speed_rpm: Any, radii: GearRadii, nu_m2_s: Any) -> Any:
    """Re_t = omega D_p^2 / (2 nu), thesis eq. 5.3."""
    return omega_rad_s(speed_rpm) * radii.pitch_diameter_m**2 / (2.0 * nu_m2_s)


def reynolds_sides(speed_rpm: Any, radii: GearRadii, nu_m2_s: Any) -> Any:
    """Re_s = omega 2 r_b r_i / nu, thesis eq. 5.6 (as printed)."""
    return omega_rad_s(speed_rpm) * 2.0 * radii.base_radius_m * radii.inner_radius_m / nu_m2_s


def h_teeth_W_m2K(speed_rpm: Any, radii: GearRadii, nu_m2_s: Any, k_air_W_mK: Any) -> Any:
    """h_t = 0.318 Re_t^0.571 k_air / D_p, thesis eq. 5.1-5.2."""
    return (
        0.318
        * reynolds_teeth(speed_rpm, radii, nu_m2_s) ** 0.571
        * k_air_W_mK
        / radii.pitch_diameter_m
    )


def h_sides_W_m2K(speed_rpm: Any, radii: GearRadii, nu_m2_s: Any, k_air_W_mK: Any) -> Any:
    """h_s = 0.556 Re_s^0.5 k_air / (2 r_i), thesis eq. 5.4-5.5."""
    return (
        0.556
        * reynolds_sides(speed_rpm, radii, nu_m2_s) ** 0.5
        * k_air_W_mK
        / (2.0 * radii.inner_radius_m)
    )


@dataclasses.dataclass(frozen=True)
class ConvectionCoefficients:
    """Result of the thesis correlations at one speed and film temperature (floats, SI)."""

    speed_rpm: float
    film_K: float
    nu_m2_s: float
    k_air_W_mK: float
    reynolds_teeth: float
    reynolds_sides: float
    h_teeth_W_m2K: float
    h_sides_W_m2K: float
    teeth_in_range: bool
    sides_in_range: bool

    def as_dict(self) -> dict[str, float | bool]:
        return dataclasses.asdict(self)


def _check_range(
    what: str, re: float, bounds: tuple[float, float], speed_rpm: float, film_K: float
) -> bool:
    lo, hi = bounds
    ok = lo <= re <= hi
    if not ok:
        log.warning(
            "%s Reynolds number %.4g at %g rpm (air at %.1f C) is outside the correlation's range "
            "[%g, %g]; the coefficient is extrapolated",
            what,
            re,
            speed_rpm,
            film_K - 273.15,
            lo,
            hi,
        )
    return ok


def thesis_convection(
    speed_rpm: float, radii: GearRadii, air: AirProperties, film_K: float
) -> ConvectionCoefficients:
    """Evaluate eq. 5.1-5.6 at ``speed_rpm`` with air properties at ``film_K`` (kelvin).

    Logs a warning (and sets ``*_in_range = False``) when a Reynolds number leaves its range.
    """
    require_nonnegative("operating.speed_rpm", speed_rpm)
    require_positive("film temperature (K)", film_K)
    nu, k = float(air.nu(film_K)), float(air.k(film_K))
    re_t = reynolds_teeth(speed_rpm, radii, nu)
    re_s = reynolds_sides(speed_rpm, radii, nu)
    return ConvectionCoefficients(
        speed_rpm=float(speed_rpm),
        film_K=float(film_K),
        nu_m2_s=nu,
        k_air_W_mK=k,
        reynolds_teeth=re_t,
        reynolds_sides=re_s,
        h_teeth_W_m2K=h_teeth_W_m2K(speed_rpm, radii, nu, k),
        h_sides_W_m2K=h_sides_W_m2K(speed_rpm, radii, nu, k),
        teeth_in_range=_check_range(
            "Teeth (rotating cylinder, eq. 5.3)", re_t, RE_TEETH_RANGE, speed_rpm, film_K
        ),
        sides_in_range=_check_range(
            "Side (rotating disc, eq. 5.6)", re_s, RE_SIDES_RANGE, speed_rpm, film_K
        ),
    )
