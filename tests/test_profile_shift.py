"""ISO 21771 profile-shift relations (gearfem.geometry.profile_shift) against analytic and textbook
values: the unshifted pair, a published worked example, round trips, x1 = -x2, the thesis pair
against gearfem.baselines and gearfem.geometry.involute, the undercut limit, and the errors.
Pure numpy, no mesh (well under a second after the import)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy.optimize import brentq

from gearfem import baselines as B
from gearfem.core.errors import ParameterError
from gearfem.core.materials import read_toml
from gearfem.geometry.involute import GearPair, GearPairGeometry, ToothProfile
from gearfem.geometry.profile_shift import (
    inv,
    inv_inverse,
    min_shift_without_undercut,
    profile_shifted_pair,
    profile_shifted_pair_at_centre_distance,
    shift_sum_for_centre_distance,
    working_pressure_angle_deg,
)

DEG = math.pi / 180.0


def test_involute_function_and_its_inverse_round_trip():
    """inv(alpha) = tan(alpha) - alpha; inv_inverse (Newton) recovers alpha to 1e-14 relative."""
    alphas = np.linspace(1.0, 60.0, 60) * DEG
    assert inv(20 * DEG) == pytest.approx(0.014904383867336446, rel=1e-15)
    for a in alphas:
        assert inv_inverse(inv(a)) == pytest.approx(a, rel=1e-14)


@pytest.mark.parametrize("z1,z2,alpha", [(30, 30, 30.0), (17, 43, 20.0), (20, 40, 25.0)])
def test_unshifted_pair_is_the_standard_pair(z1, z2, alpha):
    """x1 = x2 = 0: a_w = m (z1 + z2) / 2, alpha_w = alpha, y = k = 0, s = pi m / 2, r_a = r + m,
    r_f = r - 1.25 m, tip clearance 0.25 m."""
    m = 2e-3
    p = profile_shifted_pair(z1, z2, m, alpha)
    assert p.centre_distance_m == pytest.approx(m * (z1 + z2) / 2, rel=1e-14)
    assert p.working_pressure_angle_deg == pytest.approx(alpha, rel=1e-13)
    assert abs(p.centre_distance_modification_coef) < 1e-12
    assert abs(p.tip_alteration_coef) < 1e-12
    for i, z in ((1, z1), (2, z2)):
        r = m * z / 2
        assert getattr(p, f"tooth_thickness{i}_m") == pytest.approx(math.pi * m / 2, rel=1e-15)
        assert getattr(p, f"tip_radius{i}_m") == pytest.approx(r + m, rel=1e-13)
        assert getattr(p, f"root_radius{i}_m") == pytest.approx(r - 1.25 * m, rel=1e-13)
        assert getattr(p, f"base_radius{i}_m") == pytest.approx(r * math.cos(alpha * DEG))
        assert getattr(p, f"working_pitch_radius{i}_m") == pytest.approx(r, rel=1e-13)
    assert p.tip_clearance1_m == pytest.approx(0.25 * m, rel=1e-9)
    assert p.tip_clearance2_m == pytest.approx(0.25 * m, rel=1e-9)


def test_worked_example_khk():
    """The worked example of KHK Gears' Gear Technical Reference ('calculation of profile shifted
    spur gears'), as reproduced on the stored page
    http://bolsover.com/utilitiesforalibre/profile-shifted-external-spur-gears.html: m = 3 mm,
    alpha = 20 deg, z = 12 / 24, working centre distance 56.500 mm, x1 = 0.6 (x2 = 0.36, the sum
    0.960). Published there: inv(alpha_w) = 0.034317, alpha_w = 26.0888 deg, y = 0.83333,
    d_b = 33.8289 / 67.6579, d_w = 37.667 / 75.333, d_a = 44.840 / 79.400 (tip-shortened),
    d_f = 32.100 / 66.660, eps_alpha = 1.202.

    Both routes meet every published digit: (a) from a_w = 56.500 mm and x1 = 0.6
    (:func:`profile_shifted_pair_at_centre_distance`; x1 + x2 = 0.96006); (b) from x1 = 0.6,
    x2 = 0.36 exactly, where a_w = 56.49987 mm (56.500 to the page's three decimals) and
    alpha_w = 26.08856 deg (the page's 26.0888 belongs to the rounded a_w); (b)'s alpha_w and a_w
    also agree with an independent root of the involute equation (scipy brentq) to 1e-9."""
    m, z1, z2 = 3e-3, 12, 24
    a = profile_shifted_pair_at_centre_distance(z1, z2, m, 20.0, 56.5e-3, 0.6)
    b = profile_shifted_pair(z1, z2, m, 20.0, 0.6, 0.36)
    assert inv(a.working_pressure_angle_deg * DEG) == pytest.approx(0.034317, abs=5e-7)
    assert a.working_pressure_angle_deg == pytest.approx(26.0888, abs=5e-5)
    assert a.centre_distance_modification_coef == pytest.approx(0.83333, abs=5e-6)
    assert a.shift_sum == pytest.approx(0.960, abs=5e-4)
    assert b.centre_distance_m * 1e3 == pytest.approx(56.500, abs=5e-4)
    mm = {
        "base": (33.8289, 67.6579, 5e-5),
        "working_pitch": (37.667, 75.333, 5e-4),
        "tip": (44.840, 79.400, 5e-4),
        "root": (32.100, 66.660, 5e-4),
    }
    for p in (a, b):
        for name, (d1, d2, tol) in mm.items():
            assert 2e3 * getattr(p, f"{name}_radius1_m") == pytest.approx(d1, abs=tol), name
            assert 2e3 * getattr(p, f"{name}_radius2_m") == pytest.approx(d2, abs=tol), name
        assert p.contact_ratio == pytest.approx(1.202, abs=5e-4)
    # (b) independently: the root of tan(a) - a = inv(20 deg) + 2 tan(20 deg) 0.96 / 36
    target = math.tan(20 * DEG) - 20 * DEG + 2 * math.tan(20 * DEG) * 0.96 / 36
    aw = brentq(lambda x: math.tan(x) - x - target, 0.1, 1.2, xtol=1e-15)
    assert b.working_pressure_angle_deg == pytest.approx(math.degrees(aw), abs=1e-9)
    assert b.centre_distance_m == pytest.approx(54e-3 * math.cos(20 * DEG) / math.cos(aw), rel=1e-9)
    assert b.working_pressure_angle_deg == pytest.approx(26.08856, abs=5e-6)
    assert b.centre_distance_m * 1e3 == pytest.approx(56.49987, abs=5e-6)
    # tip shortening keeps the standard clearance 0.25 m, reference thickness m (pi/2 + 2 x tan a)
    assert b.tip_clearance1_m == pytest.approx(0.75e-3, rel=1e-9)
    assert b.tip_clearance2_m == pytest.approx(0.75e-3, rel=1e-9)
    assert b.tooth_thickness1_m == pytest.approx(m * (math.pi / 2 + 1.2 * math.tan(20 * DEG)))
    # the thickness at the reference circle from the involute relation is the same number
    assert b.thickness_at_m(1, m * z1 / 2) == pytest.approx(b.tooth_thickness1_m, rel=1e-14)


def test_shift_sum_from_centre_distance_round_trips():
    """x1 + x2 from a_w, then a_w from x1 + x2: the same to 1e-12; the split is the caller's."""
    for z1, z2, m, alpha, xs in ((12, 24, 3e-3, 20.0, 0.96), (30, 30, 2e-3, 30.0, -0.2)):
        aw = profile_shifted_pair(z1, z2, m, alpha, xs / 2, xs / 2).centre_distance_m
        assert shift_sum_for_centre_distance(z1, z2, m, alpha, aw) == pytest.approx(xs, abs=1e-12)
        q = profile_shifted_pair_at_centre_distance(z1, z2, m, alpha, aw, 0.1)
        assert q.profile_shift1 == 0.1
        assert q.profile_shift2 == pytest.approx(xs - 0.1, abs=1e-12)
        assert q.centre_distance_m == pytest.approx(aw, rel=1e-13)
    assert working_pressure_angle_deg(12, 24, 20.0, 0.96) == pytest.approx(26.0886, abs=5e-5)


def test_opposite_shifts_keep_the_centre_distance():
    """x1 = -x2: a_w = a and alpha_w = alpha exactly (y = k = 0), and only the tooth forms change:
    r_a = r + (1 + x) m, s = m (pi/2 + 2 x tan(alpha))."""
    m, alpha = 2e-3, 20.0
    for x in (0.1, 0.3, 0.5):
        p = profile_shifted_pair(17, 43, m, alpha, x, -x)
        assert p.centre_distance_m == pytest.approx(m * 60 / 2, rel=1e-14)
        assert p.working_pressure_angle_deg == pytest.approx(alpha, rel=1e-13)
        assert abs(p.tip_alteration_coef) < 1e-12
        assert p.tip_radius1_m == pytest.approx(m * 17 / 2 + (1 + x) * m, rel=1e-13)
        assert p.tip_radius2_m == pytest.approx(m * 43 / 2 + (1 - x) * m, rel=1e-13)
        s = m * (math.pi / 2 + 2 * x * math.tan(alpha * DEG))
        assert p.tooth_thickness1_m == pytest.approx(s, rel=1e-14)


def test_thesis_pair_against_baselines_and_the_involute_module():
    """The unshifted 30/30 thesis pair (m = 2 mm, 30 deg, addendum 1 m, a = 60 mm,
    thesis_gear_reference.toml): contact ratio 1.35316 as gearfem.baselines computes it
    (baseline_summary, its own formula) and as gearfem.geometry.involute.GearPair computes it with
    sharp tip edges; the start of active profile as GearPair computes it; tip thickness and root
    form radius as ToothProfile computes them for the zero-backlash tooth (s_w = pi m / 2)."""
    ref = read_toml("thesis_gear_reference.toml")
    kg, ag = ref["known"]["geometry"], ref["assumed"]["geometry"]
    z, alpha, m = kg["teeth"], kg["pressure_angle_deg"], ag["module_mm"] * 1e-3
    p = profile_shifted_pair(z, z, m, alpha, rack_fillet_coef=0.1)
    assert p.centre_distance_m == pytest.approx(kg["operating_pitch_diameter_mm"] * 1e-3)
    assert p.tip_radius1_m == pytest.approx((m * z / 2) + ag["addendum_mm"] * 1e-3)
    summary = B.baseline_summary(
        speed_rpm=1000.0,
        torque_Nm=8.0,
        mu=0.5,
        teeth1=z,
        teeth2=z,
        module_m=m,
        pressure_angle_deg=alpha,
        face_width_m=kg["face_width_mm"] * 1e-3,
        tip_radius1_m=p.tip_radius1_m,
        tip_radius2_m=p.tip_radius2_m,
        centre_distance_m=p.centre_distance_m,
        ambient_C=23.0,
    )
    assert p.contact_ratio == pytest.approx(summary["contact_ratio"], rel=1e-12)
    assert p.eps_1 == pytest.approx(summary["eps_1"], rel=1e-12)
    assert p.contact_ratio == pytest.approx(1.35316, abs=5e-6)
    # GearPair of the thesis geometry with sharp tips (its thinned tooth does not change the path)
    pair = GearPair(dataclasses.replace(GearPairGeometry(), tip_round_coefficient=0.0))
    assert p.contact_ratio == pytest.approx(pair.contact_ratio, rel=1e-12)
    assert p.start_of_active_profile1_m == pytest.approx(
        pair.start_of_active_profile_m("pinion"), rel=1e-12
    )
    prof = ToothProfile(z, m, alpha * DEG, m * z / 2, math.pi * m / 2, 1.0, 1.25, 0.1, 0.015)
    assert p.tip_thickness1_m == pytest.approx(prof.tip_thickness_m, rel=1e-12)
    assert p.root_form_radius1_m == pytest.approx(prof.form_radius_m, rel=1e-12)
    assert p.active_profile_margin_m(1) > 0  # the mate's tip stays on the involute


def test_undercut_limit():
    """x_min = h_FfP* - z sin^2(alpha) / 2: for the ISO 53 rack (20 deg, 1.25 m, 0.38 m) h_FfP* =
    1.0 and the classic z_min = 2 / sin^2(20 deg) = 17.1 teeth without shift; at x_min the
    generating rack's straight flank ends exactly on the base-tangent point (root form radius =
    base radius)."""
    s2 = math.sin(20 * DEG) ** 2
    h = 1.25 - 0.38 * (1 - math.sin(20 * DEG))
    assert h == pytest.approx(1.0, abs=1e-3)
    assert min_shift_without_undercut(17, 20.0) == pytest.approx(h - 17 * s2 / 2, rel=1e-14)
    assert min_shift_without_undercut(17, 20.0) == pytest.approx(0.0056, abs=1e-3)
    assert 2 * h / s2 == pytest.approx(17.1, abs=0.05)
    x = min_shift_without_undercut(10, 20.0)
    p = profile_shifted_pair(10, 40, 1e-3, 20.0, x, 0.0, rack_fillet_coef=0.38)
    assert p.min_shift_no_undercut1 == pytest.approx(x, rel=1e-14)
    assert p.root_form_radius1_m == pytest.approx(p.base_radius1_m, rel=1e-12)
    q = profile_shifted_pair(10, 40, 1e-3, 20.0, x - 0.05, 0.0, rack_fillet_coef=0.38)
    assert q.undercut1 and math.isnan(q.root_form_radius1_m) and not p.undercut1


def test_bad_input_names_the_parameter_value_and_range():
    with pytest.raises(ParameterError, match=r"profile_shift1 = 1\.5 .*allowed: < 0\.98"):
        profile_shifted_pair(10, 20, 1e-3, 20.0, 1.5, 0.0)  # pointed tip
    with pytest.raises(ParameterError, match=r"teeth1 = -3 .*allowed: integer in \[6, inf\]"):
        profile_shifted_pair(-3, 24, 3e-3, 20.0)
    with pytest.raises(ParameterError, match=r"pressure_angle_deg = 50\.0 .*\[10, 35\] deg"):
        profile_shifted_pair(12, 24, 3e-3, 50.0)
    with pytest.raises(ParameterError, match=r"profile_shift1 \+ profile_shift2 = -2\.0"):
        profile_shifted_pair(12, 24, 3e-3, 20.0, -1.0, -1.0)  # no working pressure angle
    with pytest.raises(ParameterError, match=r"profile_shift1 = 4\.0 .*\[-3, 3\]"):
        profile_shifted_pair(12, 24, 3e-3, 20.0, 4.0, 0.0)
    with pytest.raises(ParameterError, match=r"centre_distance_m = 0\.05 .*> 0\.0507"):
        shift_sum_for_centre_distance(12, 24, 3e-3, 20.0, 0.05)
    with pytest.raises(ParameterError, match=r"rack_fillet_coef = 0\.38 .*\[0, 0\.110"):
        profile_shifted_pair(30, 30, 2e-3, 30.0, rack_fillet_coef=0.38)  # 30 deg rack: 0.110 max
    with pytest.raises(ParameterError, match="contact ratio"):
        profile_shifted_pair(30, 30, 2e-3, 30.0, addendum_coef=0.6, dedendum_coef=0.85)
    assert issubclass(ParameterError, ValueError)


# --- the meshed geometry (GearPairGeometry / GearPair) with profile shift -------------------------

#: A shifted pair of the kind users run (20/40 teeth, 20 deg, x1 = 0.4, x2 = 0.1), sharp tips, so
#: that the tip form circles are the tip circles of ISO 21771.
SHIFTED = dict(
    module_mm=2.0,
    teeth_pinion=20,
    teeth_wheel=40,
    pressure_angle_deg=20.0,
    tooth_thickness_mm=math.pi,  # unthinned: zero backlash at the working centre distance
    root_fillet_coefficient=0.3,
    tip_round_coefficient=0.0,
    bore_radius_mm=10.0,
)


@pytest.mark.parametrize("x1, x2", [(0.4, 0.1), (0.5, -0.3), (-0.1, 0.6)])
def test_meshed_geometry_of_a_shifted_pair_is_iso_21771(x1, x2):
    """GearPair of a shifted GearPairGeometry against profile_shifted_pair: centre distance,
    working pressure angle, tip alteration, every radius, the tooth thicknesses, the start of
    active profile, the contact ratio and the tip clearances; zero backlash when unthinned."""
    g = GearPairGeometry(**SHIFTED, profile_shift_pinion=x1, profile_shift_wheel=x2)
    pair = GearPair(g)
    ref = profile_shifted_pair(20, 40, 2e-3, 20.0, x1, x2, rack_fillet_coef=0.3)
    close = lambda a, b: a == pytest.approx(b, rel=1e-11, abs=1e-15)
    assert close(g.center_distance * 1e-3, ref.centre_distance_m)
    assert close(math.degrees(pair.operating_pressure_angle_rad), ref.working_pressure_angle_deg)
    assert close(g.tip_alteration_coefficient, ref.tip_alteration_coef)
    assert close(pair.contact_ratio, ref.contact_ratio)
    assert close(pair.tip_clearance_m[0], ref.tip_clearance1_m)
    assert close(pair.tip_clearance_m[1], ref.tip_clearance2_m)
    assert abs(pair.backlash_circular_m) < 1e-15
    for body, i in (("pinion", 1), ("wheel", 2)):
        prof = pair.profile(body)
        for mine, iso in (
            (prof.base_radius_m, f"base_radius{i}_m"),
            (prof.operating_pitch_radius_m, f"working_pitch_radius{i}_m"),
            (prof.tip_radius_m, f"tip_radius{i}_m"),
            (prof.root_radius_m, f"root_radius{i}_m"),
            (prof.reference_thickness_m, f"tooth_thickness{i}_m"),
            (prof.tip_thickness_m, f"tip_thickness{i}_m"),
            (prof.form_radius_m, f"root_form_radius{i}_m"),
            (pair.start_of_active_profile_m(body), f"start_of_active_profile{i}_m"),
        ):
            assert close(mine, getattr(ref, iso)), (body, iso)


def test_thinning_of_a_shifted_pair_gives_its_backlash():
    """tooth_thickness_mm below pi m / 2 thins each shifted tooth by ds = pi m / 2 - s on the
    reference circle: the circular backlash on the working pitch circle is
    ds (r_w1 / r_1 + r_w2 / r_2) = 2 ds cos(alpha) / cos(alpha_w)."""
    ds = 0.1
    g = GearPairGeometry(
        **{**SHIFTED, "tooth_thickness_mm": math.pi - ds},
        profile_shift_pinion=0.4,
        profile_shift_wheel=0.1,
    )
    pair = GearPair(g)
    expected = (
        2 * ds * 1e-3 * math.cos(math.radians(20.0)) / math.cos(pair.operating_pressure_angle_rad)
    )
    assert pair.backlash_circular_m == pytest.approx(expected, rel=1e-12)
    # the thesis pair is the unshifted case of the same reading of tooth_thickness_mm
    thesis = GearPairGeometry()
    assert GearPair(thesis).backlash_circular_m == pytest.approx(
        2 * (math.pi - thesis.tooth_thickness_mm) * 1e-3, rel=1e-12
    )


def test_a_given_centre_distance_with_shifts():
    """With center_distance_mm given the shifts keep it: a larger one than the working centre
    distance adds backlash (no tip shortening beyond the ISO k); a smaller one is refused, naming
    center_distance_mm and the working centre distance."""
    free = GearPairGeometry(**SHIFTED, profile_shift_pinion=0.4, profile_shift_wheel=0.1)
    a_w = free.center_distance
    wider = GearPairGeometry(
        **SHIFTED, profile_shift_pinion=0.4, profile_shift_wheel=0.1, center_distance_mm=a_w + 0.05
    )
    assert GearPair(wider).backlash_circular_m > 0
    assert wider.tip_alteration_coefficient == pytest.approx(
        free.tip_alteration_coefficient + 0.05 / 2.0, rel=1e-12
    )
    with pytest.raises(ParameterError, match=r"geometry\.center_distance_mm .*working centre"):
        GearPairGeometry(
            **SHIFTED,
            profile_shift_pinion=0.4,
            profile_shift_wheel=0.1,
            center_distance_mm=a_w - 0.05,
        )


def test_bad_shifts_name_the_shift():
    """A shift that points the tip or lets the rack undercut the flank is refused naming the
    gear's shift coefficient; outside -3..3 likewise."""
    with pytest.raises(ParameterError, match=r"profile_shift_pinion = 2\.0 .*pointed"):
        GearPairGeometry(**SHIFTED, profile_shift_pinion=2.0)
    with pytest.raises(ParameterError, match=r"profile_shift_pinion = 1\.5 .*into its fillet"):
        GearPairGeometry(**SHIFTED, profile_shift_pinion=1.5)
    with pytest.raises(ParameterError, match=r"profile_shift_pinion = -0\.6 .*undercuts"):
        GearPairGeometry(**{**SHIFTED, "teeth_pinion": 14}, profile_shift_pinion=-0.6)
    with pytest.raises(ParameterError, match=r"profile_shift_wheel = 4\.0"):
        GearPairGeometry(**SHIFTED, profile_shift_wheel=4.0)
