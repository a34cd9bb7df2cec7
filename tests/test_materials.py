"""Materials: the shipped data files name their source, tables behave, UFL form equals numpy
form."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gearfem.core.errors import ParameterError
from gearfem.core.materials import (
    ZERO_CELSIUS_K,
    Material,
    ShiftFactor,
    TemperatureTable,
    input_ranges,
    peek450g_hysteresis,
)
from gearfem.thermal.properties import table_ufl


def test_package_data_files_name_their_source():
    """Every shipped material and bench file says in its header where its numbers come from (the
    thesis, reference/doll-2015-thesis.txt, or the datasheets it names): gearfem reads only these
    copies, never a path outside the clone."""
    from importlib import resources

    pkg = resources.files("gearfem") / "data"
    files = [f for sub in ("peek450g", "testbench") for f in (pkg / sub).iterdir()]
    assert len(files) >= 6
    for f in files:
        head = "\n".join(f.read_text(encoding="utf-8").splitlines()[:3])
        assert head.startswith("#") and "doll-2015-thesis" in head, f"{f.name}: no source in header"


def test_default_material_is_the_data_file():
    assert Material() == Material.peek450g()
    m = Material()
    # Lame constants from E, nu: lambda = E nu / ((1+nu)(1-2nu)), mu = E / (2(1+nu))
    assert m.lame_mu_Pa == pytest.approx(3.7e9 / 2.8)
    assert m.lame_lambda_Pa == pytest.approx(3.7e9 * 0.4 / (1.4 * 0.2))
    assert m.thermal_effusivity == pytest.approx(math.sqrt(0.25 * 1300 * 1340))
    assert input_ranges()["youngs_modulus"] == (3.6e9, 4.0e9)


def test_hysteresis_table_values():
    H = peek450g_hysteresis()
    assert H(20 + ZERO_CELSIUS_K) == pytest.approx(0.001831436)
    assert H(144 + ZERO_CELSIUS_K) == pytest.approx(0.047098940)
    # midway between 20 and 79 C is the mean of the two values (linear interpolation)
    assert H(49.5 + ZERO_CELSIUS_K) == pytest.approx(0.5 * (0.001831436 + 0.002140856))
    assert H(0.0 + ZERO_CELSIUS_K) == pytest.approx(0.001831436)  # constant below the table
    assert not H.covers(0.0 + ZERO_CELSIUS_K) and H.covers(100 + ZERO_CELSIUS_K)


def test_table_ufl_matches_numpy():
    import dolfinx
    import ufl
    from dolfinx import fem
    from mpi4py import MPI

    H = peek450g_hysteresis()
    mesh = dolfinx.mesh.create_interval(MPI.COMM_SELF, 97, [250.0, 500.0])
    x = ufl.SpatialCoordinate(mesh)
    ref = np.linspace(0.0, 1.0, 7)[:, None]
    expr = fem.Expression(table_ufl(H, x[0]), ref)
    xexpr = fem.Expression(x[0], ref)
    cells = np.arange(mesh.topology.index_map(1).size_local, dtype=np.int32)
    vals, pts = expr.eval(mesh, cells).ravel(), xexpr.eval(mesh, cells).ravel()
    assert pts.min() < H.T_K[0] and pts.max() > H.T_K[-1]  # both constant ends are exercised
    np.testing.assert_allclose(vals, H(pts), rtol=1e-13, atol=1e-16)


def test_table_derivative_and_validation():
    t = TemperatureTable((300.0, 400.0), (1.0, 3.0), "t")
    assert t.derivative(350.0) == pytest.approx(0.02)
    assert t.derivative(450.0) == 0.0
    with pytest.raises(ParameterError, match="strictly increasing"):
        TemperatureTable((300.0, 300.0), (1.0, 2.0))
    with pytest.raises(ParameterError, match="material.poissons_ratio"):
        Material(poissons_ratio=0.5)
    with pytest.raises(ParameterError, match="material.hysteresis"):
        Material(hysteresis=((20.0, 100.0), (0.1, 1.5)))


def test_shift_factor_is_continuous_and_zero_at_reference():
    a = ShiftFactor.peek450g()
    assert a.log10_aT(150.0 + ZERO_CELSIUS_K) == pytest.approx(0.0, abs=1e-12)
    eps = 1e-6
    lo = a.log10_aT(a.switch_C - eps + ZERO_CELSIUS_K)
    hi = a.log10_aT(a.switch_C + eps + ZERO_CELSIUS_K)
    assert lo == pytest.approx(hi, abs=1e-4)
    # decreasing with temperature (faster molecular motion)
    T = np.linspace(60, 180, 50) + ZERO_CELSIUS_K
    assert np.all(np.diff(a.log10_aT(T)) < 0)
