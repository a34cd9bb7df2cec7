"""Thesis convection correlations (eq. 5.1-5.6), air properties, Reynolds-range warnings, boundary
model."""

from __future__ import annotations

import logging
import math

import pytest

from gearfem.core.errors import ParameterError
from gearfem.core.materials import ZERO_CELSIUS_K, Material
from gearfem.thermal import (
    AirProperties,
    GearRadii,
    ThermalBoundary,
    ThermalOptions,
    thesis_convection,
)
from gearfem.thermal import convection as conv


def test_correlations_by_hand_at_1000_rpm():
    """Eq. 5.1-5.6 typed out independently, thesis gear (D_p 60 mm, r_b = 30 cos 30 mm, r_i 15
    mm)."""
    radii = GearRadii.thesis_gear()
    c = thesis_convection(1000.0, radii, AirProperties(), 298.15)
    omega, nu, k = 1000.0 * 2 * math.pi / 60, 1.557e-5, 0.0261
    re_t = omega * 0.060**2 / (2 * nu)
    re_s = omega * 2 * (0.030 * math.cos(math.pi / 6)) * 0.015 / nu
    assert c.reynolds_teeth == pytest.approx(re_t, rel=1e-12)
    assert c.reynolds_sides == pytest.approx(re_s, rel=1e-12)
    assert c.h_teeth_W_m2K == pytest.approx(0.318 * re_t**0.571 * k / 0.060, rel=1e-12)
    assert c.h_sides_W_m2K == pytest.approx(0.556 * re_s**0.5 * k / 0.030, rel=1e-12)
    assert c.teeth_in_range and c.sides_in_range
    # h scales with speed as n^0.571 (teeth) and n^0.5 (sides)
    c2 = thesis_convection(2000.0, radii, AirProperties(), 298.15)
    assert c2.h_teeth_W_m2K / c.h_teeth_W_m2K == pytest.approx(2**0.571)
    assert c2.h_sides_W_m2K / c.h_sides_W_m2K == pytest.approx(2**0.5)


def test_sutherland_air_against_tabulated_values():
    """nu(25 C) vs the thesis's 1.557e-5 m^2/s; mu and k at 300 and 400 K vs Incropera & DeWitt
    Table A.4
    (mu 184.6e-7 / 230.1e-7 Pa s, k 0.0263 / 0.0338 W/(m K))."""
    assert conv.air_kinematic_viscosity_m2_s(298.15) == pytest.approx(
        conv.THESIS_AIR_NU_m2_s, rel=0.005
    )
    assert conv.air_viscosity_Pa_s(300.0) == pytest.approx(184.6e-7, rel=0.01)
    assert conv.air_viscosity_Pa_s(400.0) == pytest.approx(230.1e-7, rel=0.01)
    assert conv.air_conductivity_W_mK(300.0) == pytest.approx(0.0263, rel=0.01)
    assert conv.air_conductivity_W_mK(400.0) == pytest.approx(0.0338, rel=0.01)
    assert conv.air_conductivity_W_mK(298.15) == pytest.approx(conv.THESIS_AIR_K_W_mK, rel=0.001)


def test_reynolds_range_warning(caplog):
    radii = GearRadii.thesis_gear()
    with caplog.at_level(logging.WARNING, logger="gearfem.thermal.convection"):
        c = thesis_convection(100.0, radii, AirProperties(), 298.15)  # Re_t ~ 1200 < 2000
    assert not c.teeth_in_range and not c.sides_in_range
    assert sum("outside the correlation's range" in r.message for r in caplog.records) == 2
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="gearfem.thermal.convection"):
        c = thesis_convection(
            4000.0, radii, AirProperties(), 298.15
        )  # Re_s ~ 21000 > 17200, Re_t ~ 48000
    assert not c.sides_in_range and not c.teeth_in_range
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="gearfem.thermal.convection"):
        c = thesis_convection(1000.0, radii, AirProperties(), 298.15)
    assert c.teeth_in_range and c.sides_in_range and not caplog.records
    # extrapolated, not clamped
    assert thesis_convection(100.0, radii, AirProperties(), 298.15).h_teeth_W_m2K == pytest.approx(
        c.h_teeth_W_m2K * 0.1**0.571
    )


def test_boundary_from_options_overrides_and_factors():
    mat = Material()
    radii = GearRadii.thesis_gear()
    base = ThermalBoundary.from_options(ThermalOptions(), mat, 1000.0, radii)
    assert base.teeth.h_W_m2K == pytest.approx(base.convection.h_teeth_W_m2K)
    assert base.teeth.emissivity == 0.9 and base.teeth.fluid_K == pytest.approx(
        23.0 + ZERO_CELSIUS_K
    )
    assert base.bore is None
    b = ThermalBoundary.from_options(
        ThermalOptions(
            h_teeth_factor=0.5,
            h_sides_W_m2K=12.0,
            h_sides_factor=2.0,
            bore_h_W_m2K=100.0,
            bore_C=40.0,
            emissivity=0.5,
            ambient_C=21.0,
        ),
        mat,
        1000.0,
        radii,
    )
    assert b.teeth.h_W_m2K == pytest.approx(0.5 * base.teeth.h_W_m2K)
    assert b.sides.h_W_m2K == pytest.approx(24.0)
    assert b.bore.h_W_m2K == 100.0 and b.bore.fluid_K == pytest.approx(40.0 + ZERO_CELSIUS_K)
    assert b.teeth.emissivity == 0.5 and b.sides.fluid_K == pytest.approx(21.0 + ZERO_CELSIUS_K)
    none = ThermalBoundary.from_options(ThermalOptions(convection="none"), mat, 1000.0, None)
    assert none.teeth.h_W_m2K == 0.0 and none.sides.h_W_m2K == 0.0
    # film-temperature model: h(T) callable, equal to the Sutherland value at the film temperature
    film = ThermalBoundary.from_options(ThermalOptions(air_properties="film"), mat, 1000.0, radii)
    T = 373.15
    Tf = 0.5 * (T + 296.15)
    expect = conv.h_teeth_W_m2K(
        1000.0, radii, conv.air_kinematic_viscosity_m2_s(Tf), conv.air_conductivity_W_mK(Tf)
    )
    assert film.teeth.h(T) == pytest.approx(expect)


def test_bad_convection_inputs():
    with pytest.raises(ParameterError, match="thermal.air_properties"):
        AirProperties("sutherland")
    with pytest.raises(ParameterError, match="air_kinematic_viscosity_m2_s"):
        AirProperties("film", kinematic_viscosity_m2_s=1.6e-5)
    with pytest.raises(ParameterError, match="speed_rpm"):
        thesis_convection(-10.0, GearRadii.thesis_gear(), AirProperties(), 298.15)
    with pytest.raises(ParameterError, match="inner_radius_m"):
        GearRadii(0.06, 0.026, 0.027)
    with pytest.raises(ParameterError, match="geometry radii"):
        ThermalBoundary.from_options(ThermalOptions(), Material(), 1000.0, None)
