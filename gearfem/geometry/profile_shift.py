"""Profile-shifted external spur pairs: the ISO 21771 relations in plain numpy (no gmsh or DOLFINx).

Given the tooth numbers z1, z2, the module m, the basic rack (pressure angle alpha, addendum
h_aP* m, dedendum h_fP* m, tip radius rho_fP* m) and the profile shift coefficients x1, x2 (the
rack moved x m away from the gear's centre), for a pair meshing without backlash (ISO 21771:2007,
DIN 3960; as in Niemann & Winter, Maschinenelemente II):

* involute function inv(alpha) = tan(alpha) - alpha and its inverse (Newton),
  :func:`gearfem.geometry.involute.inv`, :func:`gearfem.geometry.involute.inv_inverse`;
* working pressure angle: inv(alpha_w) = inv(alpha) + 2 tan(alpha) (x1 + x2) / (z1 + z2);
* centre distance a_w = a cos(alpha) / cos(alpha_w), a = m (z1 + z2) / 2 the reference centre
  distance; centre distance modification y m = a_w - a; or, for a given a_w, the sum of the shifts
  x1 + x2 = (z1 + z2) (inv(alpha_w) - inv(alpha)) / (2 tan(alpha)) with cos(alpha_w) = a
  cos(alpha) / a_w (:func:`shift_sum_for_centre_distance`);
* radii: reference r = m z / 2, base r_b = r cos(alpha), working pitch r_w = r_b / cos(alpha_w),
  root r_f = r - (h_fP* - x) m, tip r_a = r + (h_aP* + x + k) m with the tip alteration
  k m = a_w - a - (x1 + x2) m <= 0 (tip shortening, which keeps the tip clearance of the
  unshifted pair, c = (h_fP* - h_aP*) m; ``tip_shortening=False`` sets k = 0);
* tooth thickness on the reference circle s = m (pi/2 + 2 x tan(alpha)), at a radius r_y on the
  involute s_y = 2 r_y (s / (2 r) + inv(alpha) - inv(alpha_y)), cos(alpha_y) = r_b / r_y; the tip
  thickness s_a at r_a;
* transverse contact ratio at the working centre distance
  eps_alpha = (sqrt(r_a1^2 - r_b1^2) + sqrt(r_a2^2 - r_b2^2) - a_w sin(alpha_w)) / p_b,
  p_b = pi m cos(alpha), and its parts eps_1 (recess, pinion tip), eps_2 (approach, wheel tip);
* tip form radius r_Fa = r_a (sharp tip edges); start of active profile, the radius on one gear
  that the mate's tip reaches, r_Nf1 = sqrt(r_b1^2 + (a_w sin(alpha_w) - sqrt(r_a2^2 -
  r_b2^2))^2); root form radius r_Ff, where the rack's straight flank ends, r_Ff = sqrt(r_b^2 +
  (r sin(alpha) - (h_FfP* - x) m / sin(alpha))^2) with h_FfP* = h_fP* - rho_fP* (1 - sin(alpha));
* undercut limit: the rack's straight flank ends above the interference point when
  x >= x_min = h_FfP* - z sin^2(alpha) / 2 (the textbook h_a0* - z sin^2(alpha) / 2, h_a0* = 1, for
  h_fP* = 1.25, rho_fP* = 0.25 / (1 - sin(alpha))).

:func:`profile_shifted_pair` returns a frozen :class:`ProfileShiftedPair` (units in the field
names). Bad input raises :class:`~gearfem.core.errors.ParameterError` (a ValueError) naming the
parameter, its value and the allowed range: too few teeth, a pressure angle outside 10-35 deg, a
shift that makes a tip pointed or a root radius negative, a shift sum whose working pressure angle
does not exist, a centre distance below the sum of the base radii, a mate's tip that reaches past
the base-tangent point (involute interference), a contact ratio below 1.

The meshed geometry (:class:`gearfem.geometry.involute.GearPairGeometry`,
``profile_shift_pinion``/``_wheel``) builds the same pair; this module gives the analytic values
it is checked against (tests/test_profile_shift.py).
"""

from __future__ import annotations

import dataclasses
import math

from gearfem.core.errors import ParameterError
from gearfem.core.params import require_finite, require_int, require_positive, require_range
from gearfem.geometry.involute import inv, inv_inverse

#: Fewest teeth accepted (as :class:`gearfem.geometry.involute.GearPairGeometry`: 6).
MIN_TEETH = 6
PRESSURE_ANGLE_RANGE_DEG = (10.0, 35.0)


@dataclasses.dataclass(frozen=True)
class ProfileShiftedPair:
    """An external spur pair with profile shift, meshing without backlash (ISO 21771).

    Index 1: the pinion, 2: the wheel. Lengths in metres, angles in degrees, coefficients per
    module. See the module docstring for the relations.
    """

    teeth1: int
    teeth2: int
    module_m: float
    pressure_angle_deg: float
    profile_shift1: float
    profile_shift2: float
    addendum_coef: float
    dedendum_coef: float
    rack_fillet_coef: float
    tip_shortening: bool
    # pair
    shift_sum: float
    reference_centre_distance_m: float
    centre_distance_m: float
    working_pressure_angle_deg: float
    centre_distance_modification_coef: float  # y = (a_w - a) / m
    tip_alteration_coef: float  # k = y - (x1 + x2), <= 0; 0 without tip shortening
    base_pitch_m: float
    contact_ratio: float
    eps_1: float  # recess part (pinion tip)
    eps_2: float  # approach part (wheel tip)
    tip_clearance1_m: float  # pinion tip to wheel root
    tip_clearance2_m: float  # wheel tip to pinion root
    # per gear
    reference_radius1_m: float
    reference_radius2_m: float
    base_radius1_m: float
    base_radius2_m: float
    working_pitch_radius1_m: float
    working_pitch_radius2_m: float
    tip_radius1_m: float
    tip_radius2_m: float
    root_radius1_m: float
    root_radius2_m: float
    tooth_thickness1_m: float  # on the reference circle
    tooth_thickness2_m: float
    tip_thickness1_m: float
    tip_thickness2_m: float
    tip_form_radius1_m: float  # = tip radius (sharp tip edges)
    tip_form_radius2_m: float
    start_of_active_profile1_m: float
    start_of_active_profile2_m: float
    root_form_radius1_m: float  # nan when the rack undercuts (its flank ends below the base circle)
    root_form_radius2_m: float
    min_shift_no_undercut1: float
    min_shift_no_undercut2: float

    @property
    def undercut1(self) -> bool:
        return self.profile_shift1 < self.min_shift_no_undercut1

    @property
    def undercut2(self) -> bool:
        return self.profile_shift2 < self.min_shift_no_undercut2

    def active_profile_margin_m(self, gear: int) -> float:
        """Start of active profile minus root form radius of gear 1 or 2 (m): negative when the
        mate's tip reaches below the involute, onto the fillet (or the gear is undercut: nan)."""
        if gear == 1:
            return self.start_of_active_profile1_m - self.root_form_radius1_m
        if gear == 2:
            return self.start_of_active_profile2_m - self.root_form_radius2_m
        raise ParameterError("gear", gear, "1 or 2")

    def thickness_at_m(self, gear: int, radius_m: float) -> float:
        """Circular tooth thickness of gear 1 or 2 at a radius on its involute (m)."""
        if gear not in (1, 2):
            raise ParameterError("gear", gear, "1 or 2")
        z, x = (
            (self.teeth1, self.profile_shift1) if gear == 1 else (self.teeth2, self.profile_shift2)
        )
        return _thickness(z, self.module_m, math.radians(self.pressure_angle_deg), x, radius_m)


# ------------------------------------------------------------------------------------------------
# relations
# ------------------------------------------------------------------------------------------------


def _alpha(pressure_angle_deg: float) -> float:
    lo, hi = PRESSURE_ANGLE_RANGE_DEG
    require_range("pressure_angle_deg", pressure_angle_deg, lo, hi, unit="deg")
    return math.radians(pressure_angle_deg)


def _teeth(name: str, z: int) -> int:
    return require_int(name, z, lo=MIN_TEETH)


def _thickness(z: int, m: float, alpha: float, x: float, r_y: float) -> float:
    """s_y = 2 r_y (s / d + inv(alpha) - inv(alpha_y)), s = m (pi/2 + 2 x tan(alpha)), d = m z."""
    r = m * z / 2.0
    rb = r * math.cos(alpha)
    s = m * (math.pi / 2.0 + 2.0 * x * math.tan(alpha))
    alpha_y = math.acos(min(1.0, rb / r_y))
    return 2.0 * r_y * (s / (2.0 * r) + inv(alpha) - inv(alpha_y))


def working_pressure_angle_deg(
    teeth1: int, teeth2: int, pressure_angle_deg: float, shift_sum: float
) -> float:
    """alpha_w from inv(alpha_w) = inv(alpha) + 2 tan(alpha) (x1 + x2) / (z1 + z2) (ISO 21771)."""
    z1, z2 = _teeth("teeth1", teeth1), _teeth("teeth2", teeth2)
    alpha = _alpha(pressure_angle_deg)
    xs = require_finite("shift_sum", shift_sum)
    inv_w = inv(alpha) + 2.0 * math.tan(alpha) * xs / (z1 + z2)
    if inv_w <= 0.0:
        raise ParameterError(
            "shift_sum",
            xs,
            f"> {-inv(alpha) * (z1 + z2) / (2.0 * math.tan(alpha)):.6g}",
            "no working pressure angle: inv(alpha_w) would be <= 0",
        )
    return math.degrees(inv_inverse(inv_w))


def shift_sum_for_centre_distance(
    teeth1: int, teeth2: int, module_m: float, pressure_angle_deg: float, centre_distance_m: float
) -> float:
    """x1 + x2 of a pair meshing without backlash at the centre distance a_w:
    cos(alpha_w) = a cos(alpha) / a_w, x1 + x2 = (z1 + z2) (inv(alpha_w) - inv(alpha)) /
    (2 tan(alpha)) (ISO 21771)."""
    z1, z2 = _teeth("teeth1", teeth1), _teeth("teeth2", teeth2)
    m = require_positive("module_m", module_m)
    alpha = _alpha(pressure_angle_deg)
    aw = require_positive("centre_distance_m", centre_distance_m)
    a = m * (z1 + z2) / 2.0
    rb_sum = a * math.cos(alpha)
    if aw <= rb_sum:
        raise ParameterError(
            "centre_distance_m", aw, f"> {rb_sum:.6g} m", "must exceed the sum of the base radii"
        )
    alpha_w = math.acos(rb_sum / aw)
    return (z1 + z2) * (inv(alpha_w) - inv(alpha)) / (2.0 * math.tan(alpha))


def min_shift_without_undercut(
    teeth: int,
    pressure_angle_deg: float,
    dedendum_coef: float = 1.25,
    rack_fillet_coef: float = 0.38,
) -> float:
    """x_min = h_FfP* - z sin^2(alpha) / 2, h_FfP* = h_fP* - rho_fP* (1 - sin(alpha)): below it the
    rack's straight flank reaches past the interference point r sin^2(alpha) and undercuts the
    involute (for 20 deg, 1.25 m, 0.38 m: h_FfP* = 1.000, z_min = 2 / sin^2(alpha) =
    17.1 at x = 0)."""
    z = _teeth("teeth", teeth)
    alpha = _alpha(pressure_angle_deg)
    h = require_positive("dedendum_coef", dedendum_coef) - require_finite(
        "rack_fillet_coef", rack_fillet_coef
    ) * (1.0 - math.sin(alpha))
    return h - z * math.sin(alpha) ** 2 / 2.0


def max_rack_fillet_coef(pressure_angle_deg: float, dedendum_coef: float = 1.25) -> float:
    """Largest tip-fillet radius rho_fP* = rho_fP / m that fits the basic rack (a full-round tool
    tip).

    The tool tooth's half-width at its tip is pi/4 - h_fP* tan(alpha) (per module); a fillet
    tangent to flank and tip line is centred (1 - sin(alpha)) rho / cos(alpha) inside the corner,
    so E = pi/4 m - h_fP tan(alpha) - (1 - sin(alpha)) rho_fP / cos(alpha) >= 0 (ISO 6336-3 eq. for
    E with s_pr = 0) gives rho_fP,max* = (pi/4 - h_fP* tan(alpha)) cos(alpha) / (1 - sin(alpha)).
    For 20 deg, h_fP* = 1.25: 0.472; for 30 deg: 0.110. A rack that comes to a point above
    ``dedendum_coef`` raises ParameterError naming it.
    """
    alpha = _alpha(pressure_angle_deg)
    h = require_positive("dedendum_coef", dedendum_coef)
    half_tip = math.pi / 4.0 - h * math.tan(alpha)
    if half_tip <= 0:
        raise ParameterError(
            "dedendum_coef",
            h,
            f"< {math.pi / 4 / math.tan(alpha):.4f}",
            "the rack tooth comes to a point before reaching this depth",
        )
    return half_tip * math.cos(alpha) / (1.0 - math.sin(alpha))


def _build(
    z1: int,
    z2: int,
    m: float,
    alpha_deg: float,
    x1: float,
    x2: float,
    ha: float,
    hf: float,
    rho: float,
    tip_shortening: bool,
) -> ProfileShiftedPair:
    """All quantities, without the checks of the result (used for the limits' bisection too)."""
    alpha = math.radians(alpha_deg)
    xs = x1 + x2
    alpha_w = math.radians(working_pressure_angle_deg(z1, z2, alpha_deg, xs))
    a = m * (z1 + z2) / 2.0
    aw = a * math.cos(alpha) / math.cos(alpha_w)
    y = (aw - a) / m
    k = (y - xs) if tip_shortening else 0.0
    out: dict[str, float] = {}
    for i, z, x in ((1, z1, x1), (2, z2, x2)):
        r = m * z / 2.0
        rb = r * math.cos(alpha)
        ra = r + (ha + x + k) * m
        out[f"reference_radius{i}_m"] = r
        out[f"base_radius{i}_m"] = rb
        out[f"working_pitch_radius{i}_m"] = rb / math.cos(alpha_w)
        out[f"tip_radius{i}_m"] = ra
        out[f"root_radius{i}_m"] = r - (hf - x) * m
        out[f"tooth_thickness{i}_m"] = m * (math.pi / 2.0 + 2.0 * x * math.tan(alpha))
        out[f"tip_thickness{i}_m"] = _thickness(z, m, alpha, x, ra) if ra > rb else -math.inf
        out[f"tip_form_radius{i}_m"] = ra
        h_ff = hf - rho * (1.0 - math.sin(alpha))  # depth of the rack's straight flank end
        roll = r * math.sin(alpha) - (h_ff - x) * m / math.sin(alpha)
        out[f"root_form_radius{i}_m"] = math.hypot(rb, roll) if roll >= 0.0 else math.nan
        out[f"min_shift_no_undercut{i}"] = h_ff - z * math.sin(alpha) ** 2 / 2.0
    rb1, rb2 = out["base_radius1_m"], out["base_radius2_m"]
    ra1, ra2 = out["tip_radius1_m"], out["tip_radius2_m"]
    pb = math.pi * m * math.cos(alpha)
    line = aw * math.sin(alpha_w)  # T1T2
    reach1 = math.sqrt(max(ra1**2 - rb1**2, 0.0))  # T1 to the end of contact E
    reach2 = math.sqrt(max(ra2**2 - rb2**2, 0.0))  # T2 to the start of contact A
    g_a = reach1 - rb1 * math.tan(alpha_w)
    g_f = reach2 - rb2 * math.tan(alpha_w)
    out["start_of_active_profile1_m"] = math.hypot(rb1, line - reach2)
    out["start_of_active_profile2_m"] = math.hypot(rb2, line - reach1)
    return ProfileShiftedPair(
        teeth1=z1,
        teeth2=z2,
        module_m=m,
        pressure_angle_deg=alpha_deg,
        profile_shift1=x1,
        profile_shift2=x2,
        addendum_coef=ha,
        dedendum_coef=hf,
        rack_fillet_coef=rho,
        tip_shortening=tip_shortening,
        shift_sum=xs,
        reference_centre_distance_m=a,
        centre_distance_m=aw,
        working_pressure_angle_deg=math.degrees(alpha_w),
        centre_distance_modification_coef=y,
        tip_alteration_coef=k,
        base_pitch_m=pb,
        contact_ratio=(g_a + g_f) / pb,
        eps_1=g_a / pb,
        eps_2=g_f / pb,
        tip_clearance1_m=aw - ra1 - out["root_radius2_m"],
        tip_clearance2_m=aw - ra2 - out["root_radius1_m"],
        **out,
    )


def _pointed_limit(build, x_lo: float, x_hi: float, gear: int) -> float:
    """The shift of ``gear`` at which its tip thickness reaches 0 (bisection, s_a(x_lo) > 0 >=
    s_a(x_hi))."""
    for _ in range(200):
        mid = 0.5 * (x_lo + x_hi)
        if getattr(build(mid), f"tip_thickness{gear}_m") > 0.0:
            x_lo = mid
        else:
            x_hi = mid
        if x_hi - x_lo < 1e-12:
            break
    return x_lo


def _thick_tip_shift(build, x: float, gear: int) -> float:
    """A shift below ``x`` at which gear ``gear``'s tip has a positive thickness (steps of 0.25)."""
    lo = x
    while lo > -3.0:
        lo -= 0.25
        try:
            if getattr(build(lo), f"tip_thickness{gear}_m") > 0.0:
                return lo
        except ParameterError:  # no working pressure angle this far down
            break
    return lo


def profile_shifted_pair(
    teeth1: int,
    teeth2: int,
    module_m: float,
    pressure_angle_deg: float,
    profile_shift1: float = 0.0,
    profile_shift2: float = 0.0,
    *,
    addendum_coef: float = 1.0,
    dedendum_coef: float = 1.25,
    rack_fillet_coef: float | None = None,
    tip_shortening: bool = True,
) -> ProfileShiftedPair:
    """The ISO 21771 quantities of an external spur pair with profile shifts x1, x2 (module
    docstring), checked: each tip has a positive thickness, each root radius is positive, each
    tip reaches past the pitch point and not past the mate's base-tangent point, and
    eps_alpha >= 1.

    Args:
        teeth1, teeth2: Tooth numbers z1 (pinion), z2 (wheel), >= 6.
        module_m: Module m (m).
        pressure_angle_deg: Pressure angle of the basic rack, 10-35 deg.
        profile_shift1, profile_shift2: x1, x2 (per module; positive: the rack moved outwards).
        addendum_coef, dedendum_coef: h_aP*, h_fP* of the basic rack (1.0, 1.25).
        rack_fillet_coef: rho_fP* of the rack's tip (None: the full round that fits,
            :func:`max_rack_fillet_coef`); sets the root form radius and the undercut limit.
        tip_shortening: Shorten both tips by k m (ISO 21771 tip alteration) so the tip clearance
            stays (h_fP* - h_aP*) m; False keeps r_a = r + (h_aP* + x) m.
    """
    z1, z2 = _teeth("teeth1", teeth1), _teeth("teeth2", teeth2)
    m = require_positive("module_m", module_m)
    _alpha(pressure_angle_deg)
    x1 = require_range("profile_shift1", profile_shift1, -3.0, 3.0)
    x2 = require_range("profile_shift2", profile_shift2, -3.0, 3.0)
    ha = require_range("addendum_coef", addendum_coef, 0.0, 2.0, lo_open=True)
    hf = require_range("dedendum_coef", dedendum_coef, 0.0, 2.5, lo_open=True)
    rho_max = max_rack_fillet_coef(pressure_angle_deg, hf)
    if rho_max <= 0.0:
        raise ParameterError(
            "dedendum_coef", hf, "a smaller dedendum", "the basic rack's tooth comes to a point"
        )
    if rack_fillet_coef is None:
        rho = rho_max
    else:
        rho = require_range(
            "rack_fillet_coef",
            rack_fillet_coef,
            0.0,
            rho_max,
            reason="the largest tip radius that fits the basic rack's tooth",
        )
    if not isinstance(tip_shortening, bool):
        raise ParameterError("tip_shortening", tip_shortening, "true or false")
    alpha = math.radians(pressure_angle_deg)
    xs_min = -inv(alpha) * (z1 + z2) / (2.0 * math.tan(alpha))
    if x1 + x2 <= xs_min:
        raise ParameterError(
            "profile_shift1 + profile_shift2",
            x1 + x2,
            f"> {xs_min:.6g}",
            "no working pressure angle: inv(alpha_w) would be <= 0",
        )
    args = (z1, z2, m, pressure_angle_deg)
    p = _build(*args, x1, x2, ha, hf, rho, tip_shortening)

    for gear, x in ((1, x1), (2, x2)):
        if getattr(p, f"root_radius{gear}_m") <= 0.0:
            z = z1 if gear == 1 else z2
            raise ParameterError(
                f"profile_shift{gear}", x, f"> {hf - z / 2.0:.6g}", "the root radius would be <= 0"
            )
    for gear, x in ((1, x1), (2, x2)):
        if not getattr(p, f"tip_thickness{gear}_m") > 0.0:

            def build(xi: float, gear: int = gear):
                xx = (xi, x2) if gear == 1 else (x1, xi)
                return _build(*args, *xx, ha, hf, rho, tip_shortening)

            limit = _pointed_limit(build, _thick_tip_shift(build, x, gear), x, gear)
            raise ParameterError(
                f"profile_shift{gear}",
                x,
                f"< {limit:.4f} (with the other gear's shift {x2 if gear == 1 else x1:g})",
                "the tooth comes to a point at its tip circle (tip thickness "
                f"{getattr(p, f'tip_thickness{gear}_m') * 1e3:.4g} mm)",
            )
    if p.eps_1 <= 0.0 or p.eps_2 <= 0.0:
        gear = 1 if p.eps_1 <= 0.0 else 2
        raise ParameterError(
            "addendum_coef",
            ha,
            "a tip circle that reaches past the pitch point",
            f"gear {gear}'s tip circle lies inside its working pitch circle",
        )
    line = p.centre_distance_m * math.sin(math.radians(p.working_pressure_angle_deg))
    for gear, reach in (
        (1, math.sqrt(p.tip_radius2_m**2 - p.base_radius2_m**2)),
        (2, math.sqrt(p.tip_radius1_m**2 - p.base_radius1_m**2)),
    ):
        if reach > line:
            mate = 2 if gear == 1 else 1
            raise ParameterError(
                f"profile_shift{gear}",
                p.profile_shift1 if gear == 1 else p.profile_shift2,
                "a larger shift (or a smaller addendum of the mate)",
                f"involute interference: gear {mate}'s tip reaches past gear {gear}'s "
                "base-tangent point",
            )
    if p.contact_ratio < 1.0:
        raise ParameterError(
            "profile_shift1, profile_shift2",
            (x1, x2),
            "shifts giving a transverse contact ratio >= 1",
            f"contact ratio is {p.contact_ratio:.4f}",
        )
    return p


def profile_shifted_pair_at_centre_distance(
    teeth1: int,
    teeth2: int,
    module_m: float,
    pressure_angle_deg: float,
    centre_distance_m: float,
    profile_shift1: float,
    **options,
) -> ProfileShiftedPair:
    """The pair whose shifts sum to :func:`shift_sum_for_centre_distance` at ``centre_distance_m``,
    with x1 = ``profile_shift1`` and x2 the rest; ``options`` as :func:`profile_shifted_pair`."""
    xs = shift_sum_for_centre_distance(
        teeth1, teeth2, module_m, pressure_angle_deg, centre_distance_m
    )
    x1 = require_finite("profile_shift1", profile_shift1)
    return profile_shifted_pair(
        teeth1, teeth2, module_m, pressure_angle_deg, x1, xs - x1, **options
    )


__all__ = [
    "MIN_TEETH",
    "PRESSURE_ANGLE_RANGE_DEG",
    "ProfileShiftedPair",
    "inv",
    "inv_inverse",
    "max_rack_fillet_coef",
    "min_shift_without_undercut",
    "profile_shifted_pair",
    "profile_shifted_pair_at_centre_distance",
    "shift_sum_for_centre_distance",
    "working_pressure_angle_deg",
]
