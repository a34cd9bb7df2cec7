"""Analytic baselines that every FE result is shown next to.

Gear engineers judge an FE temperature or stress against the hand methods they know. This module
implements those methods in plain numpy/scipy (no DOLFINx), SI units inside and units in the
argument names, each function citing the equation it implements:

* VDI 2736-2 flank and root (bulk) temperature of plastic gears, with the tooth loss factor H_V
  (Ohlendorf) -- :func:`vdi2736_temperature_C`, :func:`tooth_loss_factor`.
* Mao's bulk temperature rise, the "gear pump" energy balance (Doll 2015 thesis eqs. 2.16-2.20) --
  :func:`mao_bulk_temperature_rise_K`.
* Blok's flash temperature (thesis eqs. 2.1-2.5), as a curve along the path of contact that can be
  overlaid on the FE flank temperature -- :func:`flash_temperature_along_path`.
* Hertz line contact: general cylinder formulas, the involute radii of curvature, and the AGMA
  pitch-point form (thesis eq. 4.1) -- :func:`hertz_line_contact`,
  :func:`agma_pitch_contact_stress_Pa`.
* Tooth root stress: ISO 6336-3 method B (30-degree tangent construction for a rack-generated
  fillet, load at the outer point of single contact) and the VDI 2736-2 check (load at the tip,
  Y_Fa, Y_Sa, Y_epsilon) -- :func:`root_form_factors`, :func:`root_stress_Pa`.
* :func:`baseline_summary`: all of the above for one operating point, as a flat dict.

Every function takes plain numbers (tooth numbers, module, pressure angle, tip radii, centre
distance, ...) so that it is usable without the geometry module. The few standard gear-pair
quantities these methods need (base radii, working pressure angle, path of contact, partial
contact ratios eps_1, eps_2) are computed by the private helper :func:`_pair`; callers will later
switch to ``gearfem.geometry`` for them.

Conventions: gear 1 (the pinion) drives; ``s`` is the position along the line of action measured
from the pitch point C, positive towards the end of contact (the pinion tip, point E), negative
towards the start of contact (the wheel tip, point A). Angles at the interface are in degrees
(``*_deg``), everything else SI.

References
----------
[Doll2015] Doll, N. (2015). Modeling thermomechanical behavior of polymer gears. MS thesis,
    University of Wisconsin-Madison. (``shared/reference/doll-2015-thesis.txt``)
[VDI2736] VDI 2736 Blatt 2 (2014). Thermoplastische Zahnraeder - Stirnradgetriebe -
    Tragfaehigkeitsberechnung. Formula as quoted in ``shared/data/README.md``.
[Ohl1958] Ohlendorf, H. (1958). Verlustleistung und Erwaermung von Stirnraedern. Dissertation,
    TU Muenchen (tooth loss factor H_V).
[Fer2018] Fernandes, C.M.C.G., Rocha, D.M.P., Martins, R.C., Magalhaes, L., Seabra, J.H.O. (2018).
    Finite element method model to predict bulk and flash temperatures on polymer gears.
    Tribology International 120, 255-268; calculation software GEARpie (C. Fernandes, MIT
    licence), report ``REPORT/S30.txt`` and ``CLASSES/VDI2736.py``.
[Blok1937] Blok, H. (1937). Theoretical study of temperature rise at surfaces of actual contact
    under oiliness lubricating conditions. Proc. General Discussion on Lubrication, IMechE, 2, 222.
[Jae1942] Jaeger, J.C. (1942). Moving sources of heat and the temperature at sliding contacts.
    Proc. Roy. Soc. New South Wales 76, 203-224.
[Joh1985] Johnson, K.L. (1985). Contact Mechanics. Cambridge University Press (Hertz line
    contact, ch. 4; frictional heating and flash temperature, ch. 12).
[ISO6336-3] ISO 6336-3:2006. Calculation of load capacity of spur and helical gears - Part 3:
    Calculation of tooth bending strength (method B, section 6.2 and 7.2).
[DIN3990-3] DIN 3990-3:1987 (method C: load at the tip, Y_Fa, Y_Sa, Y_epsilon = 0.25 + 0.75/eps).
[AGMA] AGMA 2001 / Shigley's Mechanical Engineering Design: contact stress with the geometry
    factor I = cos(phi) sin(phi) / 2 * m_G / (m_G + 1) (thesis eq. 4.1-4.2).
"""

from __future__ import annotations

import dataclasses
import functools
import logging
import math
from importlib import resources
from typing import Any, NamedTuple

import numpy as np

from gearfem.core.errors import ConvergenceError, ParameterError
from gearfem.core.materials import Material
from gearfem.core.params import (
    require_choice,
    require_int,
    require_nonnegative,
    require_positive,
    require_range,
)
from gearfem.geometry.profile_shift import max_rack_fillet_coef

log = logging.getLogger(__name__)

# ------------------------------------------------------------------------------------------------
# constants
# ------------------------------------------------------------------------------------------------

#: VDI 2736-2 heat transfer coefficients k_theta in K (m/s)^0.75 mm^1.75 / W, (flank, root).
#: plastic/plastic: as quoted in shared/data/README.md (VDI 2736-2).
#: plastic/steel: from a secondary source only -- GEARpie ``CLASSES/VDI2736.py`` [Fer2018], which
#: attributes them to VDI 2736-2; check against the guideline's table before relying on them.
VDI2736_K_THETA: dict[str, tuple[float, float]] = {
    "plastic/plastic": (9000.0, 2148.0),
    "plastic/steel": (6300.0, 895.0),
}

#: Thermal conductivity (W/(m K)) from which a gear material counts as a metal for VDI 2736's
#: material pair: gear steels are 25-55, the polymers 0.2-0.5 (PA66 with 30 % glass fibre 0.5).
METAL_CONDUCTIVITY_W_mK = 5.0


def is_metal(material: Material) -> bool:
    """Whether ``material`` is a metal gear (steel) for VDI 2736: conductivity at least
    :data:`METAL_CONDUCTIVITY_W_mK`."""
    return material.thermal_conductivity_W_mK >= METAL_CONDUCTIVITY_W_mK


def vdi2736_pairing(material1: Material, material2: Material) -> str:
    """The key of :data:`VDI2736_K_THETA` for a pair of these materials: ``"plastic/steel"`` when
    either gear is a metal (:func:`is_metal`; VDI 2736-2 gives one k_theta pair for a plastic gear
    against steel, whichever of the two drives), ``"plastic/plastic"`` otherwise. Two metal gears
    raise ParameterError: VDI 2736 is a guideline for plastic gears."""
    metal = (is_metal(material1), is_metal(material2))
    if all(metal):
        raise ParameterError(
            "material_wheel",
            material2.name,
            "a plastic for at least one gear",
            f"both gears are metals ({material1.name}, {material2.name}); VDI 2736 rates plastic "
            "gears",
        )
    return "plastic/steel" if any(metal) else "plastic/plastic"


#: Dry air at 25 C, 1 atm: density (kg/m^3) and isobaric specific heat (J/(kg K)), the fluid of
#: Mao's gear-pump model. (Ideal gas: 101325 Pa / (287.05 J/(kg K) * 298.15 K) = 1.184 kg/m^3;
#: c_p of air 1007 J/(kg K), e.g. Incropera & DeWitt, Table A.4 at 300 K.)
AIR_DENSITY_25C_kg_m3 = 1.184
AIR_SPECIFIC_HEAT_25C_J_kgK = 1007.0

#: Blok's form factor for a semi-elliptic (Hertzian) band heat source in the high-Peclet limit:
#: T_max = FF * q_mean * sqrt(w / v) / b with w the full band width 2a and q_mean the mean flux
#: [Blok1937; Jae1942]. The exact 1D Duhamel integral gives 1.1115 (tests/test_baselines.py);
#: Blok's rounded 1.11 is used. With the peak flux q_max = 4/pi q_mean and the half-width a the
#: same result reads T_max = 1.235 * q_max * sqrt(a / v) / b.
BLOK_FORM_FACTOR_SEMI_ELLIPTIC = 1.11
#: Same for a uniform band source: 2 / sqrt(pi) = 1.128 (exact).
BLOK_FORM_FACTOR_UNIFORM = 2.0 / math.sqrt(math.pi)


def _deg(name: str, value: float, lo: float = 0.0, hi: float = 45.0) -> float:
    """Validate a pressure angle in degrees (open interval) and return it in radians."""
    require_range(name, value, lo, hi, lo_open=True, hi_open=True, unit="degrees")
    return math.radians(value)


def _mu(name: str, value: float) -> float:
    return require_range(name, value, 0.0, 2.0, reason="coefficient of friction")


def _inv(alpha: float) -> float:
    """Involute function inv(alpha) = tan(alpha) - alpha (radians)."""
    return math.tan(alpha) - alpha


# ------------------------------------------------------------------------------------------------
# private gear-pair helper (the lead will switch callers to gearfem.geometry)
# ------------------------------------------------------------------------------------------------


class _Pair(NamedTuple):
    """Standard spur-pair quantities (ISO 21771 notation), lengths in m, angles in rad."""

    z1: int
    z2: int
    u: float  # gear ratio z2 / z1
    m: float  # module
    alpha: float  # generating (reference) pressure angle
    r1: float  # reference radii m z / 2
    r2: float
    rb1: float  # base radii
    rb2: float
    ra1: float  # tip radii
    ra2: float
    a: float  # centre distance
    alpha_w: float  # working pressure angle
    pb: float  # base pitch pi m cos(alpha)
    T1C: float  # distance from the pinion's base-tangent point T1 to the pitch point C
    T2C: float
    g_a: float  # recess path C -> E (pinion tip)
    g_f: float  # approach path A -> C (wheel tip)
    eps_1: float  # pinion addendum contact ratio g_a / pb
    eps_2: float  # wheel addendum contact ratio g_f / pb
    eps_alpha: float  # transverse contact ratio


def _pair(
    z1: int,
    z2: int,
    module_m: float,
    pressure_angle_deg: float,
    tip_radius1_m: float,
    tip_radius2_m: float,
    centre_distance_m: float,
) -> _Pair:
    """External spur pair: base radii, working pressure angle, path of contact, eps_1, eps_2.

    Standard relations (ISO 21771): r_b = m z cos(alpha) / 2; cos(alpha_w) = (r_b1 + r_b2) / a;
    T1C = r_b1 tan(alpha_w); recess g_a = sqrt(r_a1^2 - r_b1^2) - T1C; approach
    g_f = sqrt(r_a2^2 - r_b2^2) - T2C; eps_1 = g_a / p_b, eps_2 = g_f / p_b, eps_alpha = eps_1 +
    eps_2.
    Raises ParameterError if the tips do not reach past the pitch point, if the path runs past a
    base-tangent point (interference) or if eps_alpha is not in [1, 2) (the rigid load-sharing
    model of this module has one or two pairs in contact).
    """
    z1 = require_int("teeth1", z1, 5, 10_000_000)
    z2 = require_int("teeth2", z2, 5, 10_000_000)
    m = require_positive("module_m", module_m)
    alpha = _deg("pressure_angle_deg", pressure_angle_deg)
    r1, r2 = m * z1 / 2.0, m * z2 / 2.0
    rb1, rb2 = r1 * math.cos(alpha), r2 * math.cos(alpha)
    ra1 = require_range(
        "tip_radius1_m",
        tip_radius1_m,
        r1,
        r1 + 3.0 * m,
        lo_open=True,
        unit="m",
        reason="between the reference radius m z1/2 and m z1/2 + 3 m",
    )
    ra2 = require_range(
        "tip_radius2_m",
        tip_radius2_m,
        r2,
        r2 + 3.0 * m,
        lo_open=True,
        unit="m",
        reason="between the reference radius m z2/2 and m z2/2 + 3 m",
    )
    a = require_positive("centre_distance_m", centre_distance_m)
    if a <= rb1 + rb2:
        raise ParameterError(
            "centre_distance_m", a, f"> {rb1 + rb2:.6g} m", "must exceed the sum of the base radii"
        )
    alpha_w = math.acos((rb1 + rb2) / a)
    T1C, T2C = rb1 * math.tan(alpha_w), rb2 * math.tan(alpha_w)
    g_a = math.sqrt(ra1**2 - rb1**2) - T1C
    g_f = math.sqrt(ra2**2 - rb2**2) - T2C
    if g_a <= 0 or g_f <= 0:
        raise ParameterError(
            "tip_radius1_m" if g_a <= 0 else "tip_radius2_m",
            ra1 if g_a <= 0 else ra2,
            "a tip circle that reaches past the pitch point",
            f"at centre distance {a:g} m",
        )
    if g_a > T2C or g_f > T1C:
        raise ParameterError(
            "tip_radius1_m" if g_a > T2C else "tip_radius2_m",
            ra1 if g_a > T2C else ra2,
            "a path of contact inside T1T2",
            "involute interference: the tip contacts beyond the mate's base-tangent point",
        )
    pb = math.pi * m * math.cos(alpha)
    eps_1, eps_2 = g_a / pb, g_f / pb
    eps_alpha = eps_1 + eps_2
    if not 1.0 <= eps_alpha < 2.0:
        raise ParameterError(
            "tip_radius1_m",
            ra1,
            "tip radii giving a contact ratio in [1, 2)",
            f"contact ratio is {eps_alpha:.4f}",
        )
    return _Pair(
        z1,
        z2,
        z2 / z1,
        m,
        alpha,
        r1,
        r2,
        rb1,
        rb2,
        ra1,
        ra2,
        a,
        alpha_w,
        pb,
        T1C,
        T2C,
        g_a,
        g_f,
        eps_1,
        eps_2,
        eps_alpha,
    )


def _rigid_load_share(s_m: np.ndarray, p: _Pair) -> np.ndarray:
    """Share of the total normal load carried by one tooth pair at ``s`` (rigid teeth, equal split).

    1 in the single-contact zone [g_a - p_b, p_b - g_f], 1/2 in the double-contact zones, 0 off
    the path [-g_f, g_a]. This is the load distribution behind Ohlendorf's H_V [Ohl1958].
    """
    s = np.asarray(s_m, dtype=float)
    on = (s >= -p.g_f) & (s <= p.g_a)
    single = (s >= p.g_a - p.pb) & (s <= p.pb - p.g_f)
    return np.where(on, np.where(single, 1.0, 0.5), 0.0)


# ------------------------------------------------------------------------------------------------
# tooth loss factor and VDI 2736-2 temperatures
# ------------------------------------------------------------------------------------------------


def _int_abs(lo: float, hi: float) -> float:
    """Exact integral of |x| dx from lo to hi (lo <= hi)."""

    def F(x: float) -> float:
        return 0.5 * x * abs(x)

    return F(hi) - F(lo)


def tooth_loss_factor(
    z1: int,
    z2: int,
    module_m: float,
    pressure_angle_deg: float,
    tip_radius1_m: float,
    tip_radius2_m: float,
    centre_distance_m: float,
) -> float:
    """Tooth loss factor H_V of a spur pair (Ohlendorf), as used by VDI 2736-2.

    Mean tooth-friction power loss P_V = mu * H_V * P. Derivation (also the test): a pair at
    distance s from the pitch point slides at v_g = (omega1 + omega2) |s| and carries the share
    X(s) of the normal force F_bn; averaged over one base pitch, with P = F_bn r_b1 omega1,

        H_V = (u + 1) / (u r_b1 p_b) * integral X(s) |s| ds.

    With rigid teeth sharing the load equally in the double-contact zones (X = 1 or 1/2) and
    eps_1, eps_2 <= 1 this is Ohlendorf's closed form [Ohl1958; VDI2736]

        H_V = pi (u + 1) / (z1 u cos(beta_b)) * (1 - eps_alpha + eps_1^2 + eps_2^2)   (beta_b = 0).

    The integral is evaluated exactly for the piecewise-constant X, so the function also covers
    eps_1 > 1 or eps_2 > 1 (pitch point in a double-contact zone), where the closed form does not
    apply. ``z1``, ``z2`` may be swapped: H_V is symmetric.

    Args:
        z1, z2: Tooth numbers (pinion, wheel).
        module_m: Module (m).
        pressure_angle_deg: Generating (reference) pressure angle (degrees).
        tip_radius1_m, tip_radius2_m: Tip radii (m).
        centre_distance_m: Operating centre distance (m).
    Returns:
        H_V (dimensionless).
    """
    p = _pair(z1, z2, module_m, pressure_angle_deg, tip_radius1_m, tip_radius2_m, centre_distance_m)
    lo, hi = -p.g_f, p.g_a
    d_lo, d_hi = p.g_a - p.pb, p.pb - p.g_f  # single-contact zone
    integral = _int_abs(lo, hi) - 0.5 * (_int_abs(lo, d_lo) + _int_abs(d_hi, hi))
    return (p.u + 1.0) / (p.u * p.rb1 * p.pb) * integral


def tooth_loss_factor_from_load_share(
    path_position_m: np.ndarray,
    load_share: np.ndarray,
    z1: int,
    z2: int,
    module_m: float,
    pressure_angle_deg: float,
) -> float:
    """H_V for an arbitrary load share X(s) along the path of contact (e.g. from the FE cycle).

    H_V = (u + 1) / (u r_b1 p_b) * integral X(s) |s| ds (trapezoidal rule), see
    :func:`tooth_loss_factor` for the derivation. ``load_share`` is the fraction of the total
    normal force carried by one tooth pair at ``path_position_m`` (s from the pitch point, m);
    the positions must cover the whole path of contact and increase strictly.
    """
    s = np.asarray(path_position_m, dtype=float)
    X = np.asarray(load_share, dtype=float)
    if s.ndim != 1 or s.shape != X.shape or s.size < 2:
        raise ParameterError(
            "load_share", X.shape, f"a 1-D array of the shape of path_position_m {s.shape}"
        )
    if np.any(np.diff(s) <= 0) or not np.all(np.isfinite(s)):
        raise ParameterError(
            "path_position_m",
            "non-increasing or non-finite",
            "strictly increasing finite positions",
        )
    if np.any(X < 0) or np.any(X > 1) or not np.all(np.isfinite(X)):
        raise ParameterError("load_share", f"[{X.min():g}, {X.max():g}]", "fractions in [0, 1]")
    z1 = require_int("teeth1", z1, 5)
    z2 = require_int("teeth2", z2, 5)
    m = require_positive("module_m", module_m)
    alpha = _deg("pressure_angle_deg", pressure_angle_deg)
    rb1, pb, u = m * z1 * math.cos(alpha) / 2.0, math.pi * m * math.cos(alpha), z2 / z1
    return (u + 1.0) / (u * rb1 * pb) * float(np.trapezoid(X * np.abs(s), s))


def vdi2736_temperature_C(
    *,
    ambient_C: float,
    power_W: float,
    mu: float,
    loss_factor: float,
    teeth: int,
    face_width_m: float,
    pitch_line_speed_m_s: float,
    module_m: float,
    k_theta: float,
    housing_resistance_K_m2_W: float = 0.0,
    housing_area_m2: float | None = None,
    duty_cycle: float = 1.0,
) -> float:
    """VDI 2736-2 steady flank or root (bulk) temperature of a plastic gear, in deg C.

        theta = theta_0 + P mu H_V [ k_theta / (b z (v_t m_n)^0.75) + R_lambda,G / A_G ] ED^0.64

    [VDI2736] with, inside the bracket, b and m_n in mm and v_t in m/s (the unit system of
    k_theta, K (m/s)^0.75 mm^1.75 / W); this function converts from SI internally. Use
    k_theta = ``VDI2736_K_THETA[pairing][0]`` for the flank and ``[1]`` for the root.

    Which gear: VDI 2736-2 evaluates pinion and wheel separately; ``teeth`` and ``face_width_m``
    are those of the gear considered, while P (transmitted power), H_V (of the pair) and v_t (the
    common pitch-line velocity at the reference circle) are the same for both. (GEARpie [Fer2018]
    uses z1 for both gears; for the equal pairs tested here the two readings coincide.)

    Args:
        ambient_C: theta_0, ambient temperature (deg C).
        power_W: Transmitted power P (W), > 0.
        mu: Mean tooth friction coefficient, [0, 2].
        loss_factor: Tooth loss factor H_V (see :func:`tooth_loss_factor`), (0, 1].
        teeth: Tooth number z of the gear considered.
        face_width_m: Face width b of the gear considered (m).
        pitch_line_speed_m_s: v_t (m/s), > 0.
        module_m: Normal module m_n (m).
        k_theta: Heat transfer coefficient, K (m/s)^0.75 mm^1.75 / W.
        housing_resistance_K_m2_W: R_lambda,G; 0 for an open drive.
        housing_area_m2: A_G, the housing surface (m^2); required when R_lambda,G > 0.
        duty_cycle: ED, relative duty time in (0, 1] (1 = continuous).
    """
    theta_0 = require_range("ambient_C", ambient_C, -273.15, 1000.0, unit="degC")
    P = require_positive("power_W", power_W)
    mu = _mu("mu", mu)
    H_V = require_range("loss_factor", loss_factor, 0.0, 1.0, lo_open=True)
    z = require_int("teeth", teeth, 5)
    b_mm = require_positive("face_width_m", face_width_m) * 1e3
    v_t = require_positive("pitch_line_speed_m_s", pitch_line_speed_m_s)
    m_mm = require_positive("module_m", module_m) * 1e3
    k = require_positive("k_theta", k_theta)
    R = require_nonnegative("housing_resistance_K_m2_W", housing_resistance_K_m2_W)
    ED = require_range("duty_cycle", duty_cycle, 0.0, 1.0, lo_open=True)
    housing = 0.0
    if R > 0:
        if housing_area_m2 is None:
            raise ParameterError(
                "housing_area_m2", None, "> 0 m^2", "needed when housing_resistance_K_m2_W > 0"
            )
        housing = R / require_positive("housing_area_m2", housing_area_m2)
    rise = P * mu * H_V * (k / (b_mm * z * (v_t * m_mm) ** 0.75) + housing) * ED**0.64
    return theta_0 + rise


# ------------------------------------------------------------------------------------------------
# Mao bulk temperature
# ------------------------------------------------------------------------------------------------


def mao_bulk_temperature_rise_K(
    *,
    mu: float,
    torque_Nm: float,
    teeth: int,
    face_width_m: float,
    tip_radius_m: float,
    reference_radius_m: float,
    air_density_kg_m3: float = AIR_DENSITY_25C_kg_m3,
    air_specific_heat_J_kgK: float = AIR_SPECIFIC_HEAT_25C_J_kgK,
) -> float:
    """Mao's bulk temperature rise of a polymer gear, thesis eq. 2.20 with the air density restored.

    Mao's "gear pump" model [Doll2015, section 2.6]: all friction heat goes into the air carried
    between the teeth. Derivation from the thesis's eqs. 2.16-2.19 (the printed 2.17, 2.18 and 2.20
    are garbled; this is the dimensionally consistent reading):

    * friction power per tooth (2.16): E_f = mu P_av v_s = pi mu P / Z, with P = T omega;
    * contact ratio 1.5 (2.17): E_f,1.5 = E_f + 0.5 E_f / 2 = 1.25 E_f = 1.25 pi mu T omega / Z;
    * pumped air volume (2.18): V = 2 pi h (r_out^2 - r^2), r_out the tip (outside) radius, r the
      reference radius, h the face width;
    * all heat to the pumped air (2.19): E_f,1.5 = omega V Delta_T rho c_p, rho and c_p of AIR;

    so Delta_T_B = 1.25 pi mu T omega / (Z omega 2 pi h (r_out^2 - r^2) rho c_p)

        Delta_T_B = 0.625 mu T / (rho c_p Z h (r_out^2 - r^2))      [K]

    (units: N m / (J m^-3 K^-1 m^3) = K). The rise is independent of speed and proportional to
    torque, Mao's experimental observation. The printed eq. 2.20 lacks rho.

    Args:
        mu: Friction coefficient, [0, 2].
        torque_Nm: Transmitted torque T of this gear (N m), > 0.
        teeth: Tooth number Z of this gear.
        face_width_m: Face width h (m).
        tip_radius_m: Outside radius r_out (m).
        reference_radius_m: Reference radius r (m), < r_out.
        air_density_kg_m3, air_specific_heat_J_kgK: Properties of the pumped air (defaults: dry
            air at 25 C).
    """
    mu = _mu("mu", mu)
    T = require_positive("torque_Nm", torque_Nm)
    Z = require_int("teeth", teeth, 5)
    h = require_positive("face_width_m", face_width_m)
    r = require_positive("reference_radius_m", reference_radius_m)
    r_out = require_range(
        "tip_radius_m",
        tip_radius_m,
        r,
        10.0 * r,
        lo_open=True,
        unit="m",
        reason="must exceed the reference radius",
    )
    rho = require_positive("air_density_kg_m3", air_density_kg_m3)
    cp = require_positive("air_specific_heat_J_kgK", air_specific_heat_J_kgK)
    return 0.625 * mu * T / (rho * cp * Z * h * (r_out**2 - r**2))


# ------------------------------------------------------------------------------------------------
# Hertz line contact
# ------------------------------------------------------------------------------------------------


def effective_modulus_Pa(
    youngs1_Pa: float, poisson1: float, youngs2_Pa: float, poisson2: float
) -> float:
    """Contact modulus E* = 1 / ((1 - nu1^2)/E1 + (1 - nu2^2)/E2) [Joh1985, eq. 4.22 notation]."""
    E1 = require_positive("youngs1_Pa", youngs1_Pa)
    E2 = require_positive("youngs2_Pa", youngs2_Pa)
    n1 = require_range("poisson1", poisson1, -1.0, 0.5, lo_open=True, hi_open=True)
    n2 = require_range("poisson2", poisson2, -1.0, 0.5, lo_open=True, hi_open=True)
    return 1.0 / ((1.0 - n1**2) / E1 + (1.0 - n2**2) / E2)


def hertz_line_contact(
    load_per_length_N_m: float | np.ndarray,
    radius1_m: float | np.ndarray,
    radius2_m: float | np.ndarray,
    effective_modulus: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Hertz contact of two parallel cylinders (plane strain) [Joh1985, section 4.2].

        1/R = 1/R1 + 1/R2,   a = sqrt(4 w R / (pi E*)),   p0 = 2 w / (pi a) = sqrt(w E* / (pi R))

    Args:
        load_per_length_N_m: Normal load per unit length w (N/m), >= 0 (array allowed).
        radius1_m, radius2_m: Radii of curvature (m), > 0 (convex).
        effective_modulus: E* (Pa), see :func:`effective_modulus_Pa`.
    Returns:
        (half_width_m a, peak_pressure_Pa p0), arrays of the broadcast shape; 0 where w = 0.
    """
    w = np.asarray(load_per_length_N_m, dtype=float)
    R1 = np.asarray(radius1_m, dtype=float)
    R2 = np.asarray(radius2_m, dtype=float)
    if np.any(w < 0) or not np.all(np.isfinite(w)):
        raise ParameterError("load_per_length_N_m", "negative or non-finite", ">= 0 N/m")
    if np.any(R1 <= 0) or np.any(R2 <= 0):
        raise ParameterError(
            "radius_m", f"min {min(R1.min(), R2.min()):g}", "> 0 m (convex surfaces)"
        )
    Es = require_positive("effective_modulus", effective_modulus)
    R = R1 * R2 / (R1 + R2)
    a = np.sqrt(4.0 * w * R / (math.pi * Es))
    p0 = np.sqrt(w * Es / (math.pi * R))
    return a, p0


def involute_curvature_radii_m(
    path_position_m: float | np.ndarray,
    z1: int,
    z2: int,
    module_m: float,
    pressure_angle_deg: float,
    tip_radius1_m: float,
    tip_radius2_m: float,
    centre_distance_m: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Radii of curvature of the two involute flanks at contact position ``s`` on the line of
    action.

    An involute's radius of curvature at a point is its distance from the base-tangent point:
    rho1 = T1C + s, rho2 = T2C - s (s from the pitch point, positive towards the pinion tip).
    """
    p = _pair(z1, z2, module_m, pressure_angle_deg, tip_radius1_m, tip_radius2_m, centre_distance_m)
    s = np.asarray(path_position_m, dtype=float)
    if np.any(s < -p.g_f - 1e-12 * p.m) or np.any(s > p.g_a + 1e-12 * p.m):
        raise ParameterError(
            "path_position_m",
            f"[{s.min():g}, {s.max():g}]",
            f"[{-p.g_f:g}, {p.g_a:g}] m",
            "the path of contact",
        )
    return p.T1C + s, p.T2C - s


def agma_pitch_contact_stress_Pa(
    *,
    tangential_load_N: float,
    pitch_diameter_m: float,
    face_width_m: float,
    pressure_angle_deg: float,
    speed_ratio: float,
    youngs_pinion_Pa: float,
    poisson_pinion: float,
    youngs_gear_Pa: float,
    poisson_gear: float,
) -> float:
    """AGMA pitch-point contact stress, thesis eq. 4.1-4.2 [AGMA; Doll2015 section 4.1.1].

        sigma_H = sqrt( W_t / (D_p b I) * 1 / (pi ((1 - nu_p^2)/E_p + (1 - nu_g^2)/E_g)) ),
        I = cos(phi) sin(phi) / 2 * m_G / (m_G + 1),  m_G = N_g / N_p

    with W_t the tangential load carried by one tooth pair, D_p the pinion pitch diameter. It is
    Hertz's p0 at the pitch point with normal load W_t / cos(phi) and radii r sin(phi) (test).
    """
    Wt = require_positive("tangential_load_N", tangential_load_N)
    Dp = require_positive("pitch_diameter_m", pitch_diameter_m)
    b = require_positive("face_width_m", face_width_m)
    phi = _deg("pressure_angle_deg", pressure_angle_deg)
    mG = require_positive("speed_ratio", speed_ratio)
    Es = effective_modulus_Pa(youngs_pinion_Pa, poisson_pinion, youngs_gear_Pa, poisson_gear)
    I = math.cos(phi) * math.sin(phi) / 2.0 * mG / (mG + 1.0)  # noqa: E741 (AGMA's symbol)
    return math.sqrt(Wt / (Dp * b * I) * Es / math.pi)


# ------------------------------------------------------------------------------------------------
# Blok flash temperature
# ------------------------------------------------------------------------------------------------


def effusivity(conductivity_W_mK: float, density_kg_m3: float, specific_heat_J_kgK: float) -> float:
    """Thermal effusivity b = sqrt(k rho c_p), W s^0.5 / (m^2 K) (thesis eq. 2.2)."""
    k = require_positive("conductivity_W_mK", conductivity_W_mK)
    rho = require_positive("density_kg_m3", density_kg_m3)
    cp = require_positive("specific_heat_J_kgK", specific_heat_J_kgK)
    return math.sqrt(k * rho * cp)


def band_source_flash_K(
    mean_flux_W_m2: float | np.ndarray,
    width_m: float | np.ndarray,
    speed_m_s: float | np.ndarray,
    effusivity_value: float,
    form_factor: float = BLOK_FORM_FACTOR_SEMI_ELLIPTIC,
) -> np.ndarray:
    """Maximum surface temperature rise under a band heat source moving at high Peclet number.

        T_max = FF q_av sqrt(w / v) / b        (thesis eq. 2.1, [Blok1937; Jae1942])

    Heat then flows only normal to the surface (1D), and a surface point under the source for the
    time w / v heats as a semi-infinite body. FF = 2/sqrt(pi) for uniform flux, 1.11 for a
    semi-elliptic (Hertzian) flux (``BLOK_FORM_FACTOR_*``). Valid for Pe = v w / (4 kappa) >~ 5.
    """
    q = np.asarray(mean_flux_W_m2, dtype=float)
    w = np.asarray(width_m, dtype=float)
    v = np.asarray(speed_m_s, dtype=float)
    if np.any(w < 0) or np.any(v <= 0) or np.any(q < 0):
        raise ParameterError(
            "band source", "negative flux/width or non-positive speed", "q >= 0, w >= 0, v > 0"
        )
    b = require_positive("effusivity_value", effusivity_value)
    FF = require_positive("form_factor", form_factor)
    return FF * q * np.sqrt(w / v) / b


def blok_flash_temperature_K(
    mu: float,
    load_per_length_N_m: float | np.ndarray,
    half_width_m: float | np.ndarray,
    speed1_m_s: float | np.ndarray,
    speed2_m_s: float | np.ndarray,
    effusivity1: float,
    effusivity2: float,
    form_factor: float = BLOK_FORM_FACTOR_SEMI_ELLIPTIC,
) -> np.ndarray:
    """Blok's flash temperature of a sliding Hertzian line contact [Blok1937; thesis eqs. 2.1-2.5].

    The friction heat q = mu p v_s, v_s = |v1 - v2| (2.3, 2.4), is split between the bodies so
    that both reach the same maximum temperature (Blok's postulate); with eq. 2.1 for each body,
    q_i is proportional to b_i sqrt(v_i) and

        theta_fl = FF mu w |v1 - v2| / ( sqrt(2a) (b1 sqrt(v1) + b2 sqrt(v2)) ),

    which for b1 = b2 = b is the thesis's eq. 2.5, FF mu w |sqrt(v1) - sqrt(v2)| / (b sqrt(2a)).
    Here v1, v2 are the speeds at which the contact moves over each surface (rolling speeds), w the
    normal load per unit length, 2a the Hertz contact width. Scaling: proportional to mu, to
    w^(3/4) (a ~ w^(1/2)) and to sqrt(speed). Zero where w = 0 or v1 = v2.
    """
    mu = _mu("mu", mu)
    w = np.asarray(load_per_length_N_m, dtype=float)
    a = np.asarray(half_width_m, dtype=float)
    v1 = np.asarray(speed1_m_s, dtype=float)
    v2 = np.asarray(speed2_m_s, dtype=float)
    if np.any(w < 0) or np.any(a < 0) or np.any(v1 < 0) or np.any(v2 < 0):
        raise ParameterError("flash inputs", "negative load, width or speed", ">= 0")
    b1 = require_positive("effusivity1", effusivity1)
    b2 = require_positive("effusivity2", effusivity2)
    FF = require_positive("form_factor", form_factor)
    denom = np.sqrt(2.0 * a) * (b1 * np.sqrt(v1) + b2 * np.sqrt(v2))
    num = FF * mu * w * np.abs(v1 - v2)
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.where(num > 0, num / np.where(denom > 0, denom, 1.0), 0.0)
    if np.any((num > 0) & (denom <= 0)):
        raise ParameterError("half_width_m", 0.0, "> 0 where the load is > 0")
    return out


#: Flux distributions over a band source of half-width a: the mean over the band is 1.
BAND_SHAPES = ("uniform", "semi_elliptic")
#: Peclet range tabulated by :func:`band_source_rise`; beyond it the asymptotes are used.
_PECLET_TABLE = (1e-3, 1e3)


def _band_shape(shape: str):
    if shape == "uniform":
        return lambda x: np.ones_like(x)
    if shape == "semi_elliptic":
        return lambda x: 4.0 / math.pi * np.sqrt(np.clip(1.0 - x * x, 0.0, None))
    raise ParameterError("band shape", shape, "one of " + ", ".join(BAND_SHAPES))


def _band_surface_rise(L: float, shape: str, X: float) -> float:
    """Dimensionless surface temperature k theta / (q_mean a) at X = x/a under a steady band source
    on [-1, 1] moving at Peclet number L = V a / (2 kappa): the exact 2D solution

        theta(x) = 1/(pi k) int q(xi) exp(-V (x - xi) / (2 kappa)) K0(V |x - xi| / (2 kappa)) dxi

    (the moving line source on an insulated half-space, [Jae1942; Carslaw & Jaeger 10.7]), the
    band moving towards +x (the trailing edge at X = -1)."""
    from scipy import integrate, special

    f = _band_shape(shape)

    def kernel(xi):
        u = X - xi
        z = L * abs(u)
        # exp(-L u) K0(L |u|) = exp(-L u - L |u|) k0e(L |u|)
        return float(f(np.asarray(xi))) * math.exp(-L * u - z) * float(special.k0e(z))

    pts = [X] if -1.0 < X < 1.0 else None
    val = integrate.quad(kernel, -1.0, 1.0, points=pts, limit=400, epsabs=0, epsrel=1e-10)[0]
    return val / math.pi


@functools.cache
def _clustered_rule(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre on [0, 1] mapped by s = (1 - cos(pi t))/2: nodes and weights ds."""
    t, w = np.polynomial.legendre.leggauss(n)
    t, w = 0.5 * (t + 1.0), 0.5 * w
    return 0.5 * (1.0 - np.cos(math.pi * t)), 0.5 * math.pi * np.sin(math.pi * t) * w


def _band_surface_rise_fast(L: float, shape: str, X: np.ndarray, n: int = 200) -> np.ndarray:
    """The integral of :func:`_band_surface_rise` for many X at once, by Gauss-Legendre on each side
    of X with the map xi = X -+ d (1 - cos(pi t))/2, which clusters the nodes at X (log singularity
    of K0) and at the band's edges (square-root edge of the semi-elliptic flux); agrees with the
    adaptive quadrature to about 1e-7 (tests/test_friction.py)."""
    from scipy import special

    f = _band_shape(shape)
    s, ds = _clustered_rule(n)
    X = np.atleast_1d(np.asarray(X, dtype=float))
    out = np.zeros_like(X)
    for side, d in ((-1.0, X + 1.0), (1.0, 1.0 - X)):  # xi below X (u > 0), above X (u < 0)
        xi = X[:, None] + side * d[:, None] * s[None, :]
        u = X[:, None] - xi
        z = L * np.abs(u)
        with np.errstate(divide="ignore", invalid="ignore"):
            kern = np.where(z > 0, np.exp(-L * u - z) * special.k0e(z), 0.0)
        out += np.sum(f(xi) * kern * (d[:, None] * ds[None, :]), axis=1)
    return out / math.pi


#: The shipped table of :func:`compute_band_table` for every band shape (the exact 2D solution at
#: 61 Peclet numbers, 1.8 s of quadrature per shape and process otherwise), equal to a new
#: computation to the bit (tests/test_friction.py); :func:`write_band_table` writes it again.
BAND_TABLE_FILE = "band_source_rise.npz"


def _band_table_path():
    return resources.files("gearfem") / "data" / BAND_TABLE_FILE


@functools.cache
def _band_table(shape: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(log L, max, mean) of :func:`compute_band_table`, read from the shipped table."""
    _band_shape(shape)  # a shape that is not one of BAND_SHAPES: its error
    with np.load(_band_table_path()) as z:
        return z[f"{shape}_logL"], z[f"{shape}_max"], z[f"{shape}_mean"]


def compute_band_table(shape: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(log L, max, mean) of k theta sqrt(L) / (q_mean a) on a log grid of Peclet numbers."""
    logL = np.linspace(math.log(_PECLET_TABLE[0]), math.log(_PECLET_TABLE[1]), 61)
    xg, wg = np.polynomial.legendre.leggauss(64)
    xs = np.linspace(-1.0, 1.0, 401)
    mx, mn = [], []
    for lg in logL:
        L = math.exp(lg)
        mn.append(0.5 * float(_band_surface_rise_fast(L, shape, xg) @ wg))
        vals = _band_surface_rise_fast(L, shape, xs)
        i = int(np.argmax(vals))
        fine = np.linspace(xs[max(i - 1, 0)], xs[min(i + 1, len(xs) - 1)], 101)
        mx.append(float(max(vals.max(), _band_surface_rise_fast(L, shape, fine).max())))
    s = np.sqrt(np.exp(logL))
    return logL, np.asarray(mx) * s, np.asarray(mn) * s


def write_band_table(path=None) -> None:
    """Compute the table of every band shape and write it to ``path`` (default: the shipped
    file, gearfem/data/band_source_rise.npz)."""
    arrays = {}
    for shape in BAND_SHAPES:
        for name, a in zip(("logL", "max", "mean"), compute_band_table(shape), strict=True):
            arrays[f"{shape}_{name}"] = a
    np.savez(path if path is not None else str(_band_table_path()), **arrays)


#: High-Peclet limits of k theta sqrt(L) / (q_mean a) for the band source: maximum and mean
#: (uniform: 2/sqrt(pi) = 1.128 and 2/3 of it; Jaeger's 1.596 and 1.064 for theta k / (q
#: sqrt(kappa a / V)) divided by sqrt(2); semi-elliptic: the 1D Duhamel integral's 1.1115 and its
#: mean (computed once by the same integral).
@functools.cache
def band_source_high_peclet(shape: str, which: str = "max") -> float:
    """k theta sqrt(L) / (q_mean a) as L -> infinity (the 1D, heat-normal-to-the-surface limit):
    surface temperature of a semi-infinite solid passing under the flux for the time 2a/V."""
    from scipy import integrate

    f = _band_shape(shape)

    def I(x):  # noqa: E743 - int_x^1 f(xi)/sqrt(xi - x) dxi (the band moves towards +x)
        return integrate.quad(
            lambda t: 2.0 * float(f(np.asarray(x + t * t))),
            0.0,
            math.sqrt(max(1.0 - x, 0.0)),
            limit=200,
        )[0]

    # theta(X) = 1/pi sqrt(pi / (2L)) I(X) (K0 asymptote) in units of q a / k
    scale = 1.0 / math.pi * math.sqrt(math.pi / 2.0)
    if which == "mean":
        xg, wg = np.polynomial.legendre.leggauss(64)
        return scale * 0.5 * float(sum(w * I(x) for x, w in zip(xg, wg)))
    from scipy import optimize

    res = optimize.minimize_scalar(
        lambda x: -I(x), bounds=(-1.0, 0.5), method="bounded", options={"xatol": 1e-10}
    )
    return scale * max(-float(res.fun), I(-1.0))


def band_source_low_peclet_uniform(peclet: float, which: str = "max") -> float:
    """k theta / (q a) of a uniform band source as L -> 0: the small-argument expansion
    K0(z) = -ln(z/2) - gamma of the exact solution gives (2/pi)(1 - gamma + ln 2 - ln L) at the
    centre (the maximum) and (2/pi)(3/2 - gamma - ln L) for the mean over the band [Jae1942]. A
    band (2D) source has no stationary limit: the temperature grows like ln(1/L)."""
    g = 0.5772156649015329
    if which == "mean":
        return 2.0 / math.pi * (1.5 - g - math.log(peclet))
    return 2.0 / math.pi * (1.0 - g + math.log(2.0) - math.log(peclet))


def band_source_rise(
    peclet: float | np.ndarray, shape: str = "semi_elliptic", which: str = "max"
) -> np.ndarray:
    """Dimensionless flash temperature g(L) = k theta / (q_mean a) of a band heat source of
    half-width a and mean flux q_mean moving at Peclet number L = V a / (2 kappa) over a
    semi-infinite body, for any L (exact 2D steady solution, tabulated once on 1e-3 <= L <= 1e3 and
    interpolated in log L; beyond: the high-Peclet asymptote, and the low-Peclet expansion for the
    uniform band). ``which``: ``"max"`` (the surface maximum, Blok's flash temperature) or
    ``"mean"`` (over the band). Regimes: L < 0.1 low (heat spreads ahead of the source), L > 5
    high (Blok's formula, eq. 2.1, is within a few per cent)."""
    require_choice("which", which, ("max", "mean"))
    L = np.asarray(peclet, dtype=float)
    if np.any(~np.isfinite(L)) or np.any(L <= 0):
        raise ParameterError("peclet", "non-positive or non-finite", "> 0")
    from scipy.interpolate import CubicSpline

    logL, mx, mn = _band_table(shape)
    tab = mx if which == "max" else mn
    lg = np.log(L)
    out = CubicSpline(logL, tab)(np.clip(lg, logL[0], logL[-1])) / np.sqrt(L)
    hi = lg > logL[-1]
    if np.any(hi):
        out = np.where(hi, band_source_high_peclet(shape, which) / np.sqrt(L), out)
    lo = lg < logL[0]
    if np.any(lo):
        if shape != "uniform":
            raise ParameterError(
                "peclet", float(L.min()), f">= {_PECLET_TABLE[0]:g} for a {shape} band"
            )
        low = np.vectorize(lambda v: band_source_low_peclet_uniform(v, which))(np.where(lo, L, 1.0))
        out = np.where(lo, low, out)
    return out


def peclet_regime(peclet: float) -> str:
    """'low' (L < 0.1), 'intermediate' or 'high' (L > 5) for a band source (Jaeger's ranges)."""
    return "low" if peclet < 0.1 else ("high" if peclet > 5.0 else "intermediate")


@dataclasses.dataclass(frozen=True)
class FlashTemperatureCurve:
    """Blok flash temperature along the path of contact (arrays over the positions ``s_m``).

    Attributes:
        s_m: Position along the line of action from the pitch point (m), + towards the pinion tip.
        roll_angle1_deg: Pinion rotation from the pitch-point position, s / r_b1 (degrees).
        load_per_length_N_m: Normal load per unit face width carried by the pair, w(s).
        half_width_m: Hertz half-width a(s).
        peak_pressure_Pa: Hertz p0(s).
        speed1_m_s, speed2_m_s: Rolling speeds omega_i rho_i of the contact over flank 1 and 2.
        sliding_speed_m_s: |v1 - v2|.
        flash_K: Flash temperature rise theta_fl(s) (K), add the bulk temperature for the contact
            temperature.
        peclet1, peclet2: v_i a / (2 kappa_i); Blok's high-speed form needs them >~ 5.
    """

    s_m: np.ndarray
    roll_angle1_deg: np.ndarray
    load_per_length_N_m: np.ndarray
    half_width_m: np.ndarray
    peak_pressure_Pa: np.ndarray
    speed1_m_s: np.ndarray
    speed2_m_s: np.ndarray
    sliding_speed_m_s: np.ndarray
    flash_K: np.ndarray
    peclet1: np.ndarray
    peclet2: np.ndarray

    @property
    def max_K(self) -> float:
        return float(np.max(self.flash_K))

    @property
    def s_at_max_m(self) -> float:
        return float(self.s_m[int(np.argmax(self.flash_K))])

    @property
    def min_peclet(self) -> float:
        """Smallest Peclet number where the pair carries load."""
        loaded = self.load_per_length_N_m > 0
        return float(min(self.peclet1[loaded].min(), self.peclet2[loaded].min()))


def flash_temperature_along_path(
    *,
    z1: int,
    z2: int,
    module_m: float,
    pressure_angle_deg: float,
    tip_radius1_m: float,
    tip_radius2_m: float,
    centre_distance_m: float,
    face_width_m: float,
    torque1_Nm: float,
    speed1_rpm: float,
    mu: float,
    material1: Material,
    material2: Material,
    path_position_m: np.ndarray | None = None,
    load_per_length_N_m: np.ndarray | None = None,
    n_points: int = 201,
    form_factor: float = BLOK_FORM_FACTOR_SEMI_ELLIPTIC,
) -> FlashTemperatureCurve:
    """Blok flash temperature theta_fl(s) along the path of contact of a spur pair.

    Along the line of action: flank radii rho1 = T1C + s, rho2 = T2C - s
    (:func:`involute_curvature_radii_m`); rolling speeds v_i = omega_i rho_i with
    omega2 = omega1 z1 / z2; Hertz half-width a(s) from w(s), rho1, rho2 and E*
    (:func:`hertz_line_contact`); flash temperature from :func:`blok_flash_temperature_K`.
    The curve is zero at the pitch point (v1 = v2) and largest towards the ends of the path.

    Load: by default w(s) = X(s) F_bn / b with F_bn = T1 / r_b1 and X the rigid equal load share
    (1 in single contact, 1/2 in double contact). Pass ``path_position_m`` and
    ``load_per_length_N_m`` (same length, s increasing) to use a load from the FE cycle instead.

    Args:
        z1, z2, module_m, pressure_angle_deg, tip_radius1_m, tip_radius2_m, centre_distance_m:
            Pair geometry (pinion = gear 1, driving).
        face_width_m: Common face width (m).
        torque1_Nm: Pinion torque (N m), > 0.
        speed1_rpm: Pinion speed (rpm), > 0.
        mu: Friction coefficient, [0, 2].
        material1, material2: Elastic and thermal properties (room-temperature constants).
        path_position_m, load_per_length_N_m: Optional load w(s) (N/m) at positions s (m).
        n_points: Number of positions when ``path_position_m`` is not given.
        form_factor: Blok's form factor FF (1.11 for the semi-elliptic Hertz flux).
    """
    p = _pair(z1, z2, module_m, pressure_angle_deg, tip_radius1_m, tip_radius2_m, centre_distance_m)
    b = require_positive("face_width_m", face_width_m)
    T1 = require_positive("torque1_Nm", torque1_Nm)
    n1 = require_positive("speed1_rpm", speed1_rpm)
    mu = _mu("mu", mu)
    if path_position_m is None:
        if load_per_length_N_m is not None:
            raise ParameterError(
                "path_position_m", None, "positions for the given load_per_length_N_m"
            )
        n = require_int("n_points", n_points, 3)
        s = np.linspace(-p.g_f, p.g_a, n)
        w = _rigid_load_share(s, p) * (T1 / p.rb1) / b
    else:
        s = np.asarray(path_position_m, dtype=float)
        if load_per_length_N_m is None:
            w = _rigid_load_share(s, p) * (T1 / p.rb1) / b
        else:
            w = np.asarray(load_per_length_N_m, dtype=float)
            if w.shape != s.shape:
                raise ParameterError(
                    "load_per_length_N_m", w.shape, f"the shape of path_position_m {s.shape}"
                )
        if s.ndim != 1 or np.any(np.diff(s) <= 0):
            raise ParameterError(
                "path_position_m", "not strictly increasing", "strictly increasing positions (m)"
            )
    rho1, rho2 = involute_curvature_radii_m(
        s, z1, z2, module_m, pressure_angle_deg, tip_radius1_m, tip_radius2_m, centre_distance_m
    )
    Es = effective_modulus_Pa(
        material1.youngs_modulus_Pa,
        material1.poissons_ratio,
        material2.youngs_modulus_Pa,
        material2.poissons_ratio,
    )
    a, p0 = hertz_line_contact(w, rho1, rho2, Es)
    omega1 = n1 * 2.0 * math.pi / 60.0
    omega2 = omega1 * p.z1 / p.z2
    v1, v2 = omega1 * rho1, omega2 * rho2
    m1, m2 = material1, material2
    b1 = effusivity(m1.thermal_conductivity_W_mK, m1.density_kg_m3, m1.specific_heat_J_kgK)
    b2 = effusivity(m2.thermal_conductivity_W_mK, m2.density_kg_m3, m2.specific_heat_J_kgK)
    theta = blok_flash_temperature_K(mu, w, a, v1, v2, b1, b2, form_factor)
    kappa1 = m1.thermal_conductivity_W_mK / (m1.density_kg_m3 * m1.specific_heat_J_kgK)
    kappa2 = m2.thermal_conductivity_W_mK / (m2.density_kg_m3 * m2.specific_heat_J_kgK)
    return FlashTemperatureCurve(
        s_m=s,
        roll_angle1_deg=np.degrees(s / p.rb1),
        load_per_length_N_m=w,
        half_width_m=a,
        peak_pressure_Pa=p0,
        speed1_m_s=v1,
        speed2_m_s=v2,
        sliding_speed_m_s=np.abs(v1 - v2),
        flash_K=theta,
        peclet1=v1 * a / (2.0 * kappa1),
        peclet2=v2 * a / (2.0 * kappa2),
    )


# ------------------------------------------------------------------------------------------------
# hysteresis: the viscoelastic loss of one load cycle
# ------------------------------------------------------------------------------------------------


def viscoelastic_loss_per_cycle(strain: np.ndarray, loss_modulus_Pa: float) -> float:
    """Energy dissipated per unit volume over one period by a linear viscoelastic solid with a
    frequency-independent loss modulus E'' under the periodic strain ``strain`` (uniform samples
    of one period), J/m³:

        W = pi E'' sum_n n |eps_n|²,

    eps_n the amplitude of the n-th harmonic (each harmonic dissipates pi E'' eps_n² per cycle of
    its own, and makes n of them per period). A sinusoid of amplitude eps0 gives pi E'' eps0²; a
    pulse 0 -> eps0 -> 0 of raised-cosine shape gives pi E'' eps0² / 4 whatever its duration (the
    constant-E'' solid dissipates by strain excursion, not by rate). The mean strain does not
    dissipate."""
    e = np.asarray(strain, dtype=float)
    if e.ndim != 1 or len(e) < 4:
        raise ParameterError("strain", e.shape, "uniform samples of one period, at least 4")
    E2 = require_nonnegative("loss_modulus_Pa", loss_modulus_Pa)
    c = np.fft.rfft(e) / len(e)
    n = np.arange(len(c))
    amp2 = 4.0 * np.abs(c) ** 2  # eps_n² = (2 |c_n|)², n >= 1
    if len(e) % 2 == 0:
        amp2[-1] = np.abs(c[-1]) ** 2  # the Nyquist term is not doubled
    return float(math.pi * E2 * np.sum(n[1:] * amp2[1:]))


def hysteresis_loss_ratio(strain_energy: np.ndarray) -> float:
    """W / (H U_max): the viscoelastic loss per period of a proportionally loaded material point
    whose strain energy density over one period is ``strain_energy`` (uniform samples), against
    the loss H U_max the thesis (eq. 2.14) and gearfem assign to it, for a small loss angle
    (H = E''/|E*| ~ E''/E'). With eps(t) = eps_max sqrt(U(t)/U_max) and U_max = E' eps_max²/2,

        W / (H U_max) = 2 pi sum_n n |eps_n / eps_max|²:

    pi/2 = 1.571 for a 0 -> max -> 0 pulse of raised-cosine shape over the whole period, 2.19 for
    such a pulse much shorter than the period (a tooth loaded for a fraction of a turn). (A fully
    reversed sinusoid, which the strain energy alone cannot tell from a pulse train, gives 2 pi:
    H U_max is its loss over 2 pi.)"""
    u = np.asarray(strain_energy, dtype=float)
    if np.any(u < 0):
        raise ParameterError("strain_energy", float(u.min()), ">= 0")
    top = float(u.max())
    if top <= 0:
        return float("nan")
    eps = np.sqrt(u / top)
    return viscoelastic_loss_per_cycle(eps, 2.0)  # pi * 2 * sum n |eps_n|^2


# ------------------------------------------------------------------------------------------------
# tooth root stress: ISO 6336-3 method B / VDI 2736-2 (tip load)
# ------------------------------------------------------------------------------------------------


def profile_shift_from_thickness(
    thickness_m: float, module_m: float, pressure_angle_deg: float
) -> float:
    """Profile shift coefficient x from the circular tooth thickness s at the reference circle.

    s = m (pi/2 + 2 x tan(alpha)) (ISO 21771), so x = (s/m - pi/2) / (2 tan(alpha)). For a tooth
    thinned for backlash this is the generating profile shift (the rack position that cut the
    tooth), which is what the root geometry of :func:`root_form_factors` depends on.
    """
    m = require_positive("module_m", module_m)
    s = require_range(
        "thickness_m", thickness_m, 0.0, math.pi * m, lo_open=True, hi_open=True, unit="m"
    )
    alpha = _deg("pressure_angle_deg", pressure_angle_deg)
    return (s / m - math.pi / 2.0) / (2.0 * math.tan(alpha))


@dataclasses.dataclass(frozen=True)
class RootFormFactors:
    """Result of the ISO 6336-3 30-degree tangent construction (lengths in m).

    Attributes:
        Y_F: Form factor (Y_F at the outer point of single contact, or Y_Fa at the tip).
        Y_S: Stress correction factor (Y_S or Y_Sa), (1.2 + 0.13 L) q_s^(1 / (1.21 + 2.3/L)).
        s_Fn_m: Tooth root chord at the critical section.
        h_Fe_m: Bending moment arm (load line / tooth centre line intersection to the section).
        rho_F_m: Root fillet radius at the critical section.
        alpha_Fen_deg: Load direction angle (to the normal of the tooth centre line).
        theta_deg: Auxiliary angle theta of ISO 6336-3 (the 30-degree tangent iteration).
        d_en_m: Diameter of the load point.
        q_s: Notch parameter s_Fn / (2 rho_F); the Y_S formula is valid for 1 <= q_s < 8.
        load_at: "single_contact" (method B) or "tip".
    """

    Y_F: float
    Y_S: float
    s_Fn_m: float
    h_Fe_m: float
    rho_F_m: float
    alpha_Fen_deg: float
    theta_deg: float
    d_en_m: float
    q_s: float
    load_at: str

    @property
    def Y_S_in_range(self) -> bool:
        return 1.0 <= self.q_s < 8.0


def root_form_factors(
    z: int,
    module_m: float,
    pressure_angle_deg: float,
    profile_shift: float,
    tip_radius_m: float,
    *,
    rack_dedendum_coef: float = 1.25,
    rack_fillet_coef: float = 0.38,
    load_at: str = "single_contact",
    contact_ratio: float | None = None,
) -> RootFormFactors:
    """Y_F, Y_S of an external spur gear generated by a basic rack [ISO6336-3, 6.2 and 7.2].

    The critical section is where the tangent to the root fillet (a trochoid from the rack tip
    fillet) makes 30 degrees with the tooth centre line. With the basic rack (alpha_n, h_fP,
    rho_fP, protuberance s_pr = 0) and profile shift x, per module m:

        E = pi/4 m - h_fP tan(alpha_n) - (1 - sin(alpha_n)) rho_fP / cos(alpha_n)
        G = rho_fP/m - h_fP/m + x,   H = 2/z (pi/2 - E/m) - pi/3
        theta = 2G/z tan(theta) - H            (solved by Newton from pi/6)
        s_Fn/m = z sin(pi/3 - theta) + sqrt(3) (G/cos(theta) - rho_fP/m)
        rho_F/m = rho_fP/m + 2 G^2 / (cos(theta) (z cos^2(theta) - 2G))
        h_Fe/m = 1/2 [(cos(gamma_e) - sin(gamma_e) tan(alpha_Fen)) d_en/m - z cos(pi/3 - theta)
                      - G/cos(theta) + rho_fP/m]
        alpha_en = arccos(d_b/d_en), gamma_e = (pi/2 + 2 x tan(alpha_n))/z + inv(alpha_n) -
        inv(alpha_en),
        alpha_Fen = alpha_en - gamma_e
        Y_F = 6 (h_Fe/m) cos(alpha_Fen) / ((s_Fn/m)^2 cos(alpha_n))
        Y_S = (1.2 + 0.13 L) q_s^(1/(1.21 + 2.3/L)),  L = s_Fn/h_Fe,  q_s = s_Fn/(2 rho_F)

    Load point: ``load_at="single_contact"`` (ISO 6336-3 method B) puts it at the outer point of
    single pair contact, d_en = 2 sqrt((sqrt(r_a^2 - r_b^2) - p_b (eps_alpha - 1))^2 + r_b^2),
    which needs ``contact_ratio`` (eps_alpha of the pair). ``load_at="tip"`` puts it at the tip,
    d_en = d_a (DIN 3990-3 method C, used by VDI 2736-2 with Y_epsilon: Y_F is then Y_Fa and Y_S
    is Y_Sa).

    Args:
        z: Tooth number (spur gear, so z_n = z).
        module_m: Module (m).
        pressure_angle_deg: Basic rack pressure angle alpha_n, (0, 30] degrees (for larger angles
            the 30-degree tangent point is no longer on the fillet).
        profile_shift: x (generating), see :func:`profile_shift_from_thickness`.
        tip_radius_m: Tip radius r_a (m).
        rack_dedendum_coef: h_fP / m of the basic rack (the gear's dedendum), e.g. 1.25.
        rack_fillet_coef: rho_fP / m, at most :func:`max_rack_fillet_coef`; 0.38 is ISO 53 profile
        A.
        load_at: "single_contact" or "tip".
        contact_ratio: eps_alpha, required for "single_contact".
    """
    z = require_int("teeth", z, 5)
    m = require_positive("module_m", module_m)
    alpha = _deg("pressure_angle_deg", pressure_angle_deg, hi=30.0 + 1e-9)
    x = require_range("profile_shift", profile_shift, -1.5, 1.5)
    load_at = require_choice("load_at", load_at, ("single_contact", "tip"))
    hfP = require_positive("rack_dedendum_coef", rack_dedendum_coef) * m
    rho_max = max_rack_fillet_coef(pressure_angle_deg, rack_dedendum_coef)
    rhofP = (
        require_range(
            "rack_fillet_coef",
            rack_fillet_coef,
            0.0,
            rho_max,
            lo_open=True,
            reason="the tip fillet must fit the rack tooth (full round at the maximum)",
        )
        * m
    )
    r, rb = m * z / 2.0, m * z * math.cos(alpha) / 2.0
    ra = require_range("tip_radius_m", tip_radius_m, r - m, r + 3.0 * m, lo_open=True, unit="m")
    E = (
        math.pi / 4.0 * m
        - hfP * math.tan(alpha)
        - (1.0 - math.sin(alpha)) * rhofP / math.cos(alpha)
    )
    G = rhofP / m - hfP / m + x
    H = 2.0 / z * (math.pi / 2.0 - E / m) - math.pi / 3.0
    theta = math.pi / 6.0
    for it in range(100):
        f = theta - 2.0 * G / z * math.tan(theta) + H
        df = 1.0 - 2.0 * G / (z * math.cos(theta) ** 2)
        step = f / df
        theta -= step
        if not 0.0 < theta < math.pi / 2.0:
            raise ConvergenceError(
                "ISO 6336-3 theta iteration",
                f"left (0, pi/2): theta = {theta:.6g}",
                step=f"z = {z}, x = {x:g}",
                iteration=it,
            )
        if abs(step) < 1e-14:
            break
    else:
        raise ConvergenceError(
            "ISO 6336-3 theta iteration",
            "no convergence in 100 Newton steps",
            step=f"z = {z}, x = {x:g}",
            iteration=100,
            residual=abs(f),
        )
    s_Fn = m * (
        z * math.sin(math.pi / 3.0 - theta) + math.sqrt(3.0) * (G / math.cos(theta) - rhofP / m)
    )
    rho_F = m * (rhofP / m + 2.0 * G**2 / (math.cos(theta) * (z * math.cos(theta) ** 2 - 2.0 * G)))
    if load_at == "tip":
        d_en = 2.0 * ra
    else:
        if contact_ratio is None:
            raise ParameterError(
                "contact_ratio", None, "eps_alpha in [1, 2)", "needed for load_at='single_contact'"
            )
        eps = require_range("contact_ratio", contact_ratio, 1.0, 2.0, hi_open=True)
        pb = math.pi * m * math.cos(alpha)
        d_en = 2.0 * math.sqrt((math.sqrt(ra**2 - rb**2) - pb * (eps - 1.0)) ** 2 + rb**2)
    alpha_en = math.acos(rb / (d_en / 2.0))
    gamma_e = (math.pi / 2.0 + 2.0 * x * math.tan(alpha)) / z + _inv(alpha) - _inv(alpha_en)
    alpha_Fen = alpha_en - gamma_e
    h_Fe = (
        0.5
        * m
        * (
            (math.cos(gamma_e) - math.sin(gamma_e) * math.tan(alpha_Fen)) * d_en / m
            - z * math.cos(math.pi / 3.0 - theta)
            - G / math.cos(theta)
            + rhofP / m
        )
    )
    if s_Fn <= 0 or rho_F <= 0 or h_Fe <= 0:
        raise ParameterError(
            "profile_shift",
            x,
            "a tooth with a positive root chord and moment arm",
            f"s_Fn = {s_Fn:g} m, h_Fe = {h_Fe:g} m, rho_F = {rho_F:g} m",
        )
    Y_F = 6.0 * (h_Fe / m) * math.cos(alpha_Fen) / ((s_Fn / m) ** 2 * math.cos(alpha))
    L = s_Fn / h_Fe
    q_s = s_Fn / (2.0 * rho_F)
    Y_S = (1.2 + 0.13 * L) * q_s ** (1.0 / (1.21 + 2.3 / L))
    out = RootFormFactors(
        Y_F,
        Y_S,
        s_Fn,
        h_Fe,
        rho_F,
        math.degrees(alpha_Fen),
        math.degrees(theta),
        d_en,
        q_s,
        load_at,
    )
    if not out.Y_S_in_range:
        log.warning(
            "ISO 6336-3 Y_S used outside its range 1 <= q_s < 8 (q_s = %.3f, z = %d)", q_s, z
        )
    return out


def vdi2736_contact_ratio_factor(contact_ratio: float) -> float:
    """Y_epsilon = 0.25 + 0.75 / eps_alpha, for the tip-load root stress (DIN 3990-3 method C, VDI
    2736-2)."""
    eps = require_range("contact_ratio", contact_ratio, 1.0, 2.0, hi_open=True)
    return 0.25 + 0.75 / eps


def root_stress_Pa(
    *,
    tangential_force_N: float,
    face_width_m: float,
    module_m: float,
    factors: RootFormFactors,
    contact_ratio_factor: float = 1.0,
    helix_factor: float = 1.0,
    load_factor: float = 1.0,
) -> float:
    """Nominal tooth root stress sigma_F = K F_t / (b m_n) Y_F Y_S Y_epsilon Y_beta.

    * ISO 6336-3 method B: ``factors`` with load_at="single_contact", Y_epsilon = 1 (the load
      position already accounts for load sharing), Y_beta = 1 (spur); sigma_F0 with K = 1.
    * VDI 2736-2: ``factors`` with load_at="tip" (Y_Fa, Y_Sa) and
      Y_epsilon = :func:`vdi2736_contact_ratio_factor`.

    F_t = 2 T / d is the nominal tangential force at the reference circle (d = m z). ``load_factor``
    is K_F = K_A K_v K_Fbeta K_Falpha (1 gives the nominal sigma_F0).
    """
    Ft = require_positive("tangential_force_N", tangential_force_N)
    b = require_positive("face_width_m", face_width_m)
    m = require_positive("module_m", module_m)
    Ye = require_range("contact_ratio_factor", contact_ratio_factor, 0.0, 1.0, lo_open=True)
    Yb = require_range("helix_factor", helix_factor, 0.0, 1.0, lo_open=True)
    K = require_positive("load_factor", load_factor)
    return K * Ft / (b * m) * factors.Y_F * factors.Y_S * Ye * Yb


# ------------------------------------------------------------------------------------------------
# summary for one operating point
# ------------------------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class BaselineOptions:
    """Choices of the analytic baselines that are not part of the gear pair or operating point.

    Attributes:
        vdi_k_theta_flank, vdi_k_theta_root: VDI 2736-2 k_theta, K (m/s)^0.75 mm^1.75 / W
            (None: ``VDI2736_K_THETA`` of the pair's materials, :func:`vdi2736_pairing`).
        vdi_housing_resistance_K_m2_W: R_lambda,G (0: open drive).
        vdi_housing_area_m2: A_G (m^2), needed when R_lambda,G > 0.
        vdi_duty_cycle: ED in (0, 1].
        air_density_kg_m3, air_specific_heat_J_kgK: Air of Mao's gear-pump model.
        rack_dedendum_coef: h_fP / m of the generating rack (ISO 6336-3).
        rack_fillet_coef: rho_fP / m of the generating rack; 0.38 is ISO 53 profile A (20 deg).
            At most :func:`max_rack_fillet_coef` (0.110 for 30 deg with h_fP = 1.25 m). None: the
            full round that fits (the case runner passes the geometry's fillet when it fits).
        flash_points: Number of positions of the flash temperature curve.
    """

    vdi_k_theta_flank: float | None = None
    vdi_k_theta_root: float | None = None
    vdi_housing_resistance_K_m2_W: float = 0.0
    vdi_housing_area_m2: float | None = None
    vdi_duty_cycle: float = 1.0
    air_density_kg_m3: float = AIR_DENSITY_25C_kg_m3
    air_specific_heat_J_kgK: float = AIR_SPECIFIC_HEAT_25C_J_kgK
    rack_dedendum_coef: float = 1.25
    rack_fillet_coef: float | None = None
    flash_points: int = 201

    def __post_init__(self) -> None:
        for name in ("vdi_k_theta_flank", "vdi_k_theta_root"):
            if getattr(self, name) is not None:
                require_positive(f"baselines.{name}", getattr(self, name))
        require_nonnegative(
            "baselines.vdi_housing_resistance_K_m2_W", self.vdi_housing_resistance_K_m2_W
        )
        if self.vdi_housing_resistance_K_m2_W > 0 and self.vdi_housing_area_m2 is None:
            raise ParameterError(
                "baselines.vdi_housing_area_m2",
                None,
                "> 0 m^2",
                "needed when vdi_housing_resistance_K_m2_W > 0",
            )
        if self.vdi_housing_area_m2 is not None:
            require_positive("baselines.vdi_housing_area_m2", self.vdi_housing_area_m2)
        require_range("baselines.vdi_duty_cycle", self.vdi_duty_cycle, 0.0, 1.0, lo_open=True)
        require_positive("baselines.air_density_kg_m3", self.air_density_kg_m3)
        require_positive("baselines.air_specific_heat_J_kgK", self.air_specific_heat_J_kgK)
        require_positive("baselines.rack_dedendum_coef", self.rack_dedendum_coef)
        if self.rack_fillet_coef is not None:
            require_positive("baselines.rack_fillet_coef", self.rack_fillet_coef)
        require_int("baselines.flash_points", self.flash_points, 3, 100_000)


def baseline_summary(
    *,
    speed_rpm: float,
    torque_Nm: float,
    mu: float,
    teeth1: int,
    teeth2: int,
    module_m: float,
    pressure_angle_deg: float,
    face_width_m: float,
    tip_radius1_m: float,
    tip_radius2_m: float,
    centre_distance_m: float,
    ambient_C: float,
    material1: Material | None = None,
    material2: Material | None = None,
    profile_shift1: float = 0.0,
    profile_shift2: float = 0.0,
    options: BaselineOptions | None = None,
) -> dict[str, Any]:
    """All analytic baselines for one operating point, as a flat dict (units in the keys).

    Gear 1 drives at ``speed_rpm`` with ``torque_Nm``; both gears have the common face width.
    Materials default to PEEK 450G (``Material()``). Keys (``1``/``2``: pinion/wheel):

    * operating point: ``speed_rpm``, ``torque_Nm``, ``mu``, ``power_W``, ``pitch_line_speed_m_s``,
      ``tangential_force_N`` (F_t = T / r), ``normal_force_N`` (F_bn = T / r_b);
    * contact: ``eps_1``, ``eps_2``, ``contact_ratio``;
    * friction: ``tooth_loss_factor_HV``, ``friction_power_W`` = mu H_V P (the heat the FE flank
      flux should integrate to for a rigid, equal load share);
    * VDI 2736-2: the k_theta used, ``vdi2736_k_theta_flank``, ``vdi2736_k_theta_root`` (the
      pair's, :func:`vdi2736_pairing`, unless given in ``options``), ``vdi2736_flank{1,2}_C``,
      ``vdi2736_root{1,2}_C`` and the ``*_rise_K`` (None for a metal gear, which VDI 2736 does not
      rate);
    * Mao: ``mao_bulk_rise{1,2}_K``, ``mao_bulk{1,2}_C``;
    * Hertz at the pitch point: ``hertz_pitch_half_width_m``, ``hertz_pitch_p0_Pa``,
      ``agma_pitch_sigma_H_Pa``;
    * Blok: ``flash_max_K``, ``flash_max_at_s_m``, ``flash_min_peclet``,
      ``vdi_root_plus_flash_max_C`` (bulk = VDI root temperature of gear 1, plus the flash);
    * root stress: ``iso6336_YF{1,2}``, ``iso6336_YS{1,2}``, ``iso6336_sigmaF0_{1,2}_Pa`` (method B)
      and ``vdi2736_YFa{1,2}``, ``vdi2736_YSa{1,2}``, ``vdi2736_Yeps``, ``vdi2736_sigmaF{1,2}_Pa``
      (tip load, K_F = 1).
    """
    opt = options if options is not None else BaselineOptions()
    m1 = material1 if material1 is not None else Material()
    m2 = material2 if material2 is not None else Material()
    n1 = require_positive("speed_rpm", speed_rpm)
    T1 = require_positive("torque_Nm", torque_Nm)
    mu = _mu("mu", mu)
    b = require_positive("face_width_m", face_width_m)
    p = _pair(
        teeth1,
        teeth2,
        module_m,
        pressure_angle_deg,
        tip_radius1_m,
        tip_radius2_m,
        centre_distance_m,
    )
    omega1 = n1 * 2.0 * math.pi / 60.0
    power = T1 * omega1
    v_t = omega1 * p.r1
    Ft = T1 / p.r1
    Fbn = T1 / p.rb1
    H_V = tooth_loss_factor(
        teeth1,
        teeth2,
        module_m,
        pressure_angle_deg,
        tip_radius1_m,
        tip_radius2_m,
        centre_distance_m,
    )
    out: dict[str, Any] = {
        "speed_rpm": n1,
        "torque_Nm": T1,
        "mu": mu,
        "ambient_C": ambient_C,
        "power_W": power,
        "pitch_line_speed_m_s": v_t,
        "tangential_force_N": Ft,
        "normal_force_N": Fbn,
        "eps_1": p.eps_1,
        "eps_2": p.eps_2,
        "contact_ratio": p.eps_alpha,
        "tooth_loss_factor_HV": H_V,
        "friction_power_W": mu * H_V * power,
    }
    common = dict(
        ambient_C=ambient_C,
        power_W=power,
        mu=mu,
        loss_factor=H_V,
        face_width_m=b,
        pitch_line_speed_m_s=v_t,
        module_m=p.m,
        housing_resistance_K_m2_W=opt.vdi_housing_resistance_K_m2_W,
        housing_area_m2=opt.vdi_housing_area_m2,
        duty_cycle=opt.vdi_duty_cycle,
    )
    pairing = vdi2736_pairing(m1, m2)
    k_flank = _given_or(opt.vdi_k_theta_flank, VDI2736_K_THETA[pairing][0])
    k_root = _given_or(opt.vdi_k_theta_root, VDI2736_K_THETA[pairing][1])
    out["vdi2736_k_theta_flank"], out["vdi2736_k_theta_root"] = k_flank, k_root
    for i, z, ra, r, x, T, mat in (
        (1, p.z1, p.ra1, p.r1, profile_shift1, T1, m1),
        (2, p.z2, p.ra2, p.r2, profile_shift2, T1 * p.z2 / p.z1, m2),
    ):
        for part, k in (("flank", k_flank), ("root", k_root)):
            t = None if is_metal(mat) else vdi2736_temperature_C(teeth=z, k_theta=k, **common)
            out[f"vdi2736_{part}{i}_C"] = t
            out[f"vdi2736_{part}{i}_rise_K"] = None if t is None else t - ambient_C
        mao = mao_bulk_temperature_rise_K(
            mu=mu,
            torque_Nm=T,
            teeth=z,
            face_width_m=b,
            tip_radius_m=ra,
            reference_radius_m=r,
            air_density_kg_m3=opt.air_density_kg_m3,
            air_specific_heat_J_kgK=opt.air_specific_heat_J_kgK,
        )
        out[f"mao_bulk_rise{i}_K"], out[f"mao_bulk{i}_C"] = mao, ambient_C + mao
        rho = (
            opt.rack_fillet_coef
            if opt.rack_fillet_coef is not None
            else max_rack_fillet_coef(pressure_angle_deg, opt.rack_dedendum_coef)
        )
        out["rack_fillet_coef"] = rho
        kw = dict(rack_dedendum_coef=opt.rack_dedendum_coef, rack_fillet_coef=rho)
        fB = root_form_factors(
            z,
            p.m,
            pressure_angle_deg,
            x,
            ra,
            load_at="single_contact",
            contact_ratio=p.eps_alpha,
            **kw,
        )
        fC = root_form_factors(z, p.m, pressure_angle_deg, x, ra, load_at="tip", **kw)
        Y_eps = vdi2736_contact_ratio_factor(p.eps_alpha)
        out[f"iso6336_YF{i}"], out[f"iso6336_YS{i}"] = fB.Y_F, fB.Y_S
        out[f"iso6336_sigmaF0_{i}_Pa"] = root_stress_Pa(
            tangential_force_N=Ft, face_width_m=b, module_m=p.m, factors=fB
        )
        out[f"vdi2736_YFa{i}"], out[f"vdi2736_YSa{i}"], out["vdi2736_Yeps"] = fC.Y_F, fC.Y_S, Y_eps
        out[f"vdi2736_sigmaF{i}_Pa"] = root_stress_Pa(
            tangential_force_N=Ft,
            face_width_m=b,
            module_m=p.m,
            factors=fC,
            contact_ratio_factor=Y_eps,
        )
    # Hertz at the pitch point (load share there: 1 if C lies in the single-contact zone)
    share_C = float(_rigid_load_share(np.array([0.0]), p)[0])
    Es = effective_modulus_Pa(
        m1.youngs_modulus_Pa, m1.poissons_ratio, m2.youngs_modulus_Pa, m2.poissons_ratio
    )
    aC, p0C = hertz_line_contact(share_C * Fbn / b, p.T1C, p.T2C, Es)
    out["hertz_pitch_half_width_m"], out["hertz_pitch_p0_Pa"] = float(aC), float(p0C)
    r_w1 = p.rb1 / math.cos(p.alpha_w)  # operating pitch radius
    out["agma_pitch_sigma_H_Pa"] = agma_pitch_contact_stress_Pa(
        tangential_load_N=share_C * T1 / r_w1,
        pitch_diameter_m=2.0 * r_w1,
        face_width_m=b,
        pressure_angle_deg=math.degrees(p.alpha_w),
        speed_ratio=p.u,
        youngs_pinion_Pa=m1.youngs_modulus_Pa,
        poisson_pinion=m1.poissons_ratio,
        youngs_gear_Pa=m2.youngs_modulus_Pa,
        poisson_gear=m2.poissons_ratio,
    )
    curve = flash_temperature_along_path(
        z1=teeth1,
        z2=teeth2,
        module_m=module_m,
        pressure_angle_deg=pressure_angle_deg,
        tip_radius1_m=tip_radius1_m,
        tip_radius2_m=tip_radius2_m,
        centre_distance_m=centre_distance_m,
        face_width_m=b,
        torque1_Nm=T1,
        speed1_rpm=n1,
        mu=mu,
        material1=m1,
        material2=m2,
        n_points=opt.flash_points,
    )
    out["flash_max_K"], out["flash_max_at_s_m"] = curve.max_K, curve.s_at_max_m
    out["flash_min_peclet"] = curve.min_peclet
    root1 = out["vdi2736_root1_C"]
    out["vdi_root_plus_flash_max_C"] = None if root1 is None else root1 + curve.max_K
    return out


def _given_or(value: float | None, default: float) -> float:
    return default if value is None else value


def temperature_rise_ratio(summary_a: dict[str, Any], summary_b: dict[str, Any], key: str) -> float:
    """Ratio of two summaries' rises above ambient, (b[key] - b.ambient) / (a[key] - a.ambient)."""
    ra = summary_a[key] - summary_a["ambient_C"]
    rb = summary_b[key] - summary_b["ambient_C"]
    return rb / ra


__all__ = [
    "BAND_SHAPES",
    "BLOK_FORM_FACTOR_SEMI_ELLIPTIC",
    "BLOK_FORM_FACTOR_UNIFORM",
    "VDI2736_K_THETA",
    "AIR_DENSITY_25C_kg_m3",
    "AIR_SPECIFIC_HEAT_25C_J_kgK",
    "BaselineOptions",
    "FlashTemperatureCurve",
    "RootFormFactors",
    "agma_pitch_contact_stress_Pa",
    "band_source_flash_K",
    "band_source_high_peclet",
    "band_source_low_peclet_uniform",
    "band_source_rise",
    "baseline_summary",
    "blok_flash_temperature_K",
    "effective_modulus_Pa",
    "effusivity",
    "flash_temperature_along_path",
    "hertz_line_contact",
    "hysteresis_loss_ratio",
    "involute_curvature_radii_m",
    "mao_bulk_temperature_rise_K",
    "max_rack_fillet_coef",
    "peclet_regime",
    "profile_shift_from_thickness",
    "root_form_factors",
    "root_stress_Pa",
    "temperature_rise_ratio",
    "tooth_loss_factor",
    "tooth_loss_factor_from_load_share",
    "vdi2736_contact_ratio_factor",
    "vdi2736_temperature_C",
    "viscoelastic_loss_per_cycle",
]
