"""Foundation: import guards, parameter errors, logging, `gearfem info`, a first MPI check."""

from __future__ import annotations

import dataclasses
import logging
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from mpi4py import MPI

import gearfem
from gearfem.core.errors import ConvergenceError, ParameterError
from gearfem.core.params import from_dict, require_range, to_dict


def _run_python(code: str, tmp_path) -> subprocess.CompletedProcess:
    env = dict(os.environ)
    env["PYTHONPATH"] = str(tmp_path) + os.pathsep + env.get("PYTHONPATH", "")
    return subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120
    )


def test_import_without_dolfinx_says_how_to_install(tmp_path):
    # A sitecustomize that makes `dolfinx` (and the wheel bootstrap) unimportable.
    (tmp_path / "sitecustomize.py").write_text(
        textwrap.dedent("""
        import sys
        class _Block:
            def find_spec(self, name, path=None, target=None):
                if name.split('.')[0] in ('dolfinx', 'dolfinx_solver'):
                    raise ImportError('blocked for test: ' + name)
        sys.meta_path.insert(0, _Block())
    """)
    )
    r = _run_python("import gearfem", tmp_path)
    assert r.returncode != 0
    assert "gearfem needs DOLFINx" in r.stderr
    assert "dolfinx-solver-real" in r.stderr and "conda" in r.stderr


def test_import_with_old_dolfinx_is_refused(tmp_path):
    pkg = tmp_path / "dolfinx"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("__version__ = '0.9.0'\n")
    (tmp_path / "sitecustomize.py").write_text(
        textwrap.dedent("""
        import sys
        class _Block:
            def find_spec(self, name, path=None, target=None):
                if name.split('.')[0] == 'dolfinx_solver':
                    raise ImportError('blocked for test')
        sys.meta_path.insert(0, _Block())
    """)
    )
    r = _run_python("import gearfem", tmp_path)
    assert r.returncode != 0
    assert "DOLFINx >= 0.10, found 0.9.0" in r.stderr


def test_dolfinx_version_is_supported():
    import dolfinx

    assert gearfem._version_tuple(dolfinx.__version__) >= gearfem.MIN_DOLFINX


def test_parameter_error_names_parameter_value_and_range():
    with pytest.raises(ParameterError) as e:
        require_range("geometry.pressure_angle_deg", 50.0, 10.0, 35.0, unit="deg")
    msg = str(e.value)
    assert "geometry.pressure_angle_deg" in msg and "50.0" in msg and "[10, 35] deg" in msg


@dataclasses.dataclass(frozen=True)
class _Inner:
    width_mm: float = 1.0

    def __post_init__(self):
        require_range("inner.width_mm", self.width_mm, 0.0, 10.0, lo_open=True)


@dataclasses.dataclass(frozen=True)
class _Outer:
    teeth: int = 30
    inner: _Inner = dataclasses.field(default_factory=_Inner)


def test_from_dict_round_trip_and_unknown_key():
    o = from_dict(_Outer, {"teeth": 20, "inner": {"width_mm": 2}})
    assert o == _Outer(20, _Inner(2.0))
    assert from_dict(_Outer, to_dict(o)) == o
    with pytest.raises(ParameterError, match="unknown key"):
        from_dict(_Outer, {"teeht": 20})
    with pytest.raises(ParameterError, match="inner.width_mm"):
        from_dict(_Outer, {"inner": {"width_mm": -1}})
    with pytest.raises(ParameterError, match="an integer"):
        from_dict(_Outer, {"teeth": 2.5})


def test_convergence_error_carries_reason_and_step():
    err = ConvergenceError(
        "contact Newton", "DIVERGED_LINE_SEARCH (-6)", step="pinion angle 3.0 deg", iteration=7
    )
    assert (
        "DIVERGED_LINE_SEARCH" in str(err) and "3.0 deg" in str(err) and "iteration 7" in str(err)
    )


def test_log_level_from_environment(monkeypatch):
    from gearfem.core.log import resolve_level, setup_logging

    monkeypatch.setenv("GEARFEM_LOG_LEVEL", "debug")
    assert resolve_level() == logging.DEBUG
    monkeypatch.setenv("GEARFEM_LOG_LEVEL", "loud")
    with pytest.raises(ParameterError, match="GEARFEM_LOG_LEVEL"):
        resolve_level()
    logger = setup_logging("WARNING")
    assert (
        logger.level == logging.WARNING
        and len([h for h in logger.handlers if getattr(h, "_gearfem", False)]) == 1
    )


def test_info_reports_versions(capsys):
    from gearfem.cli import main

    assert main(["info", "--json"]) == 0
    import json

    if MPI.COMM_WORLD.rank == 0:
        info = json.loads(capsys.readouterr().out)
        for key in ("gearfem", "dolfinx", "petsc", "petsc_scalar_type", "gmsh", "mpi_size"):
            assert info[key] is not None, key
        assert info["petsc_scalar_type"] == "float64"
        assert info["mpi_size"] == MPI.COMM_WORLD.size


def _unit_cube_volume_and_moment(comm: MPI.Comm) -> tuple[float, float]:
    import dolfinx
    import ufl
    from dolfinx import fem

    mesh = dolfinx.mesh.create_box(
        comm, [np.zeros(3), np.array([2.0, 1.0, 0.5])], [6, 5, 4], dolfinx.mesh.CellType.tetrahedron
    )
    x = ufl.SpatialCoordinate(mesh)
    vol = comm.allreduce(fem.assemble_scalar(fem.form(1.0 * ufl.dx(domain=mesh))), op=MPI.SUM)
    mom = comm.allreduce(fem.assemble_scalar(fem.form(x[0] * x[0] * ufl.dx)), op=MPI.SUM)
    return vol, mom


@pytest.mark.mpi
def test_volume_same_on_one_and_all_ranks(comms):
    serial, world = comms
    v1, m1 = _unit_cube_volume_and_moment(serial)
    vn, mn = _unit_cube_volume_and_moment(world)
    # Analytic: V = 2*1*0.5 = 1; int x^2 = (2^3/3) * 1 * 0.5 = 4/3 (P1 geometry is exact for a box).
    assert v1 == pytest.approx(1.0, rel=1e-12) and m1 == pytest.approx(4.0 / 3.0, rel=1e-12)
    assert vn == pytest.approx(v1, rel=1e-12) and mn == pytest.approx(m1, rel=1e-12)
