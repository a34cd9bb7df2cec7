"""Bad inputs raise ParameterError naming the parameter; the [thermal]/[sources] tables parse from
TOML."""

from __future__ import annotations

import tomllib

import numpy as np
import pytest
from dolfinx import fem
from mpi4py import MPI
from thermal_meshes import annular_sector, box_domain, sector_domain

from gearfem.core.errors import ParameterError
from gearfem.core.materials import Material
from gearfem.core.params import from_dict, to_dict
from gearfem.thermal import HeatSources, PrescribedSources, ThermalDomain, ThermalOptions
from gearfem.thermal.source_terms import prescribed_heat_sources


@pytest.mark.parametrize(
    "kw, name",
    [
        ({"degree": 3}, "thermal.degree"),
        ({"emissivity": 1.2}, "thermal.emissivity"),
        ({"dt_initial_s": 1000.0, "dt_max_s": 500.0}, "thermal.dt_initial_s"),
        ({"dt_min_s": 10.0, "dt_max_s": 1.0}, "thermal.dt_max_s"),
        ({"duration_s": 0.0}, "thermal.duration_s"),
        ({"output_times_s": (900.0, 9000.0)}, "thermal.output_times_s[1]"),
        ({"output_times_s": (900.0, 800.0)}, "thermal.output_times_s[1]"),
        ({"time_error_K": -1.0}, "thermal.time_error_K"),
        ({"bore_C": 40.0}, "thermal.bore_C"),
        ({"h_teeth_W_m2K": -5.0}, "thermal.h_teeth_W_m2K"),
        ({"h_sides_factor": -1.0}, "thermal.h_sides_factor"),
        ({"convection": "vdi"}, "thermal.convection"),
        (
            {"air_properties": "film", "air_conductivity_W_mK": 0.03},
            "thermal.air_conductivity_W_mK",
        ),
        ({"mode": "quasi"}, "thermal.mode"),
        ({"ambient_C": -300.0}, "thermal.ambient_C"),
        ({"linear_solver": "jacobi"}, "thermal.linear_solver"),
    ],
)
def test_bad_thermal_options(kw, name):
    with pytest.raises(ParameterError) as err:
        ThermalOptions(**kw)
    assert err.value.name == name


def test_options_from_toml_and_back():
    text = """
    [thermal]
    ambient_C = 21.0
    duration_s = 900
    output_times_s = [300, 600]
    h_teeth_factor = 0.8
    degree = 2
    """
    opts = from_dict(ThermalOptions, tomllib.loads(text)["thermal"], "thermal")
    assert opts.output_times_s == (300.0, 600.0) and opts.degree == 2 and opts.duration_s == 900.0
    assert from_dict(ThermalOptions, to_dict(opts), "thermal") == opts
    with pytest.raises(ParameterError, match="thermal.h_teeth_facto"):
        from_dict(ThermalOptions, {"h_teeth_facto": 1.0}, "thermal")
    src = from_dict(PrescribedSources, {"flank_heat_per_gear_W": 40.0, "flanks": "both"}, "sources")
    assert src.flank_heat_per_gear_W == 40.0


@pytest.mark.parametrize(
    "kw, name",
    [
        ({"flank_heat_per_gear_W": -1.0}, "sources.flank_heat_per_gear_W"),
        ({"flanks": "tip"}, "sources.flanks"),
        ({"loading_frequency": "mesh"}, "sources.loading_frequency"),
        ({"u_max_J_m3": -2.0}, "sources.u_max_J_m3"),
    ],
)
def test_bad_prescribed_sources(kw, name):
    with pytest.raises(ParameterError) as err:
        PrescribedSources(**kw)
    assert err.value.name == name


def test_bad_heat_sources():
    dom = box_domain(MPI.COMM_SELF)
    u = fem.Function(fem.functionspace(dom.mesh, ("DG", 0)))
    with pytest.raises(ParameterError, match="sources.hysteresis"):
        HeatSources(u_max=u, loading_frequency_Hz=10.0)
    with pytest.raises(ParameterError, match="sources.loading_frequency_Hz"):
        HeatSources(u_max=u, hysteresis=Material().hysteresis_table())
    with pytest.raises(ParameterError, match="sources.flux_surfaces"):
        HeatSources(flank_flux_W_m2=100.0)


def test_domain_checks():
    msh, ft, groups = annular_sector(MPI.COMM_SELF, teeth=2)
    dom = ThermalDomain.from_gear_groups(msh, ft, groups, total_teeth=30)
    assert dom.model_fraction == pytest.approx(2 / 30) and dom.teeth_modelled == 2
    assert dom.flux_surfaces == ("pinion_tooth0_drive_flank", "pinion_tooth1_drive_flank")
    assert set(dom.monitors) == {"flank", "coast_flank", "tip", "root"}
    assert dom.cuts == ("pinion_cut_start", "pinion_cut_end") and dom.bore == ("pinion_bore",)
    # a facet group left out of every role would silently be adiabatic: refused
    with pytest.raises(ParameterError, match="without a role"):
        ThermalDomain(msh, ft, groups, teeth=dom.teeth, sides=dom.sides, bore=dom.bore)
    with pytest.raises(ParameterError, match="more than one role"):
        ThermalDomain(
            msh,
            ft,
            groups,
            teeth=(*dom.teeth, "pinion_bore"),
            sides=dom.sides,
            bore=dom.bore,
            cuts=dom.cuts,
        )
    with pytest.raises(ParameterError, match="domain.teeth"):
        ThermalDomain(msh, ft, groups, teeth=("nope",), sides=dom.sides)
    with pytest.raises(ParameterError, match="wheel_tooth"):
        ThermalDomain.from_gear_groups(msh, ft, groups, body="wheel")
    with pytest.raises(ParameterError, match="geometry.teeth"):
        ThermalDomain.from_gear_groups(msh, ft, groups, total_teeth=1)
    # a sector of 4 teeth: monitors on the interior teeth 1 and 2 only, flux on all drive flanks
    msh4, ft4, groups4 = annular_sector(MPI.COMM_SELF, teeth=4)
    dom4 = ThermalDomain.from_gear_groups(msh4, ft4, groups4, total_teeth=30)
    assert dom4.monitors["flank"] == ("pinion_tooth1_drive_flank", "pinion_tooth2_drive_flank")
    assert dom4.monitors["root"] == ("pinion_tooth1_root", "pinion_tooth2_root")
    assert len(dom4.flux_surfaces) == 4


def test_prescribed_flank_heat_is_scaled_to_the_sector():
    """40 W per gear on a 2-of-30-tooth sector: the drive flanks of the sector receive 40 * 2/30
    W."""
    dom = sector_domain(MPI.COMM_SELF, teeth=2, total_teeth=30)
    src = prescribed_heat_sources(
        PrescribedSources(flank_heat_per_gear_W=40.0), dom, Material(), 1000.0, 30
    )
    import ufl

    ds = ufl.Measure("ds", domain=dom.mesh, subdomain_data=dom.facet_tags)
    area = fem.assemble_scalar(fem.form(1.0 * ds(dom.tags(dom.flux_surfaces))))
    assert src.flank_flux_W_m2 * area == pytest.approx(40.0 * 2 / 30)
    assert src.u_max is None
    src = prescribed_heat_sources(
        PrescribedSources(u_max_J_m3=1e4, loading_frequency="tooth_pass"),
        dom,
        Material(),
        1200.0,
        30,
    )
    assert src.loading_frequency_Hz == pytest.approx(600.0) and np.all(src.u_max.x.array == 1e4)
