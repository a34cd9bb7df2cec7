"""The uncertainty store: resolution keys, stored studies, u_num of a run (gearfem.uncertainty)."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pytest

from gearfem.config import load_case
from gearfem.diagnose.data import Dataset, Measurement
from gearfem.diagnose.report import studied_u_num
from gearfem.refinement import KINDS, level_case
from gearfem.uncertainty import (
    SAME_VALUE_RTOL,
    STUDY_DESIGN_VERSION,
    StudyUncertainty,
    resolution_key,
    run_uncertainty,
    store_study,
    stored_studies,
)


@pytest.fixture
def store(tmp_path, monkeypatch):
    monkeypatch.setenv("GEARFEM_CACHE", str(tmp_path / "cache"))
    return tmp_path / "cache"


def _study(case, kind, u_max, u_bulk, max_C=250.0, bulk_C=93.0):
    return StudyUncertainty(
        kind=kind,
        resolution_key=resolution_key(case),
        case=case.name,
        speed_rpm=case.operating.speed_rpm,
        torque_Nm=case.operating.torque_Nm,
        ambient_C=case.thermal.ambient_C,
        factor=1.5,
        values={"max_surface": max_C, "mean_bulk": bulk_C},
        units={"max_surface": "C", "mean_bulk": "C"},
        u_num={"max_surface": u_max, "mean_bulk": u_bulk},
        asymptotic={"max_surface": False, "mean_bulk": True},
        design=STUDY_DESIGN_VERSION,
    )


def _with_camera(case, **camera):
    inst = case.instruments
    return dataclasses.replace(
        case,
        instruments=dataclasses.replace(inst, camera=dataclasses.replace(inst.camera, **camera)),
    )


def test_resolution_key_follows_the_discretisation_not_the_physics():
    case = load_case(None)
    key = resolution_key(case)
    physics = [
        case.with_operating(speed_rpm=2000.0, torque_Nm=4.0),
        dataclasses.replace(
            case, contact=dataclasses.replace(case.contact, friction_coefficient=0.3)
        ),
        dataclasses.replace(case, thermal=dataclasses.replace(case.thermal, ambient_C=30.0)),
        dataclasses.replace(case, sources=dataclasses.replace(case.sources, flux_scale=0.5)),
        _with_camera(case, distance_m=0.5, emissivity_setting=0.95),  # the instrument's physics
        dataclasses.replace(case, cycle=dataclasses.replace(case.cycle, solver="full")),
    ]
    for c in physics:
        assert resolution_key(c) == key
    resolution = [level_case(case, kind, 1.5) for kind in KINDS] + [
        dataclasses.replace(case, thermal=dataclasses.replace(case.thermal, degree=1)),
        dataclasses.replace(
            case, sources=dataclasses.replace(case.sources, flux_smoothing_axial_mm=3.0)
        ),
        dataclasses.replace(
            case, sources=dataclasses.replace(case.sources, flux_evaluation="reference_facets")
        ),
        # the camera reading's quadratures (a study made at 16 footprint rays holds another
        # camera reading than one at 8)
        _with_camera(case, subsamples=16),
        _with_camera(case, phases=48),
        _with_camera(case, aim_offsets=2),
    ]
    keys = {resolution_key(c) for c in resolution}
    assert key not in keys and len(keys) == len(resolution)


def test_level_case_refines_one_direction_and_pins_the_thermal_mesh():
    case = load_case(None)
    # the built-in case's thermal model has a mesh of its own ([thermal_mesh])
    assert case.thermal_mesh is not None and case.thermal_mesh != case.mesh
    s = level_case(case, "structural_mesh", 2.0)
    assert s.mesh.size_flank_mm == pytest.approx(case.mesh.size_flank_mm / 2)
    assert s.mesh.layers == case.mesh.layers and s.mesh.size_body_mm == case.mesh.size_body_mm
    assert s.thermal_mesh_options == case.thermal_mesh  # the thermal mesh does not follow
    # the reconstruction of the facet flux follows the positions' spacing and the layers, not
    # the contact zone's facets
    src = case.sources
    assert s.sources == src
    # evaluated per structural facet, the axial reconstruction follows the layers' thickness
    facets = dataclasses.replace(
        case, sources=dataclasses.replace(src, flux_evaluation="reference_facets")
    )
    assert case.mesh.layers == 4
    lay = level_case(facets, "structural_layers", 1.5)  # 4 -> 6 layers
    assert lay.mesh == dataclasses.replace(case.mesh, layers=6)
    assert lay.thermal_mesh_options == case.thermal_mesh
    assert lay.sources.flux_smoothing_axial_mm == pytest.approx(src.flux_smoothing_axial_mm * 4 / 6)
    assert lay.sources.flux_smoothing_profile_mm == src.flux_smoothing_profile_mm
    assert level_case(lay, "structural_layers", 1.5).mesh.layers == 9
    # counts are rounded up: 3 layers refined by 1.5 are 5, not 4
    three = dataclasses.replace(facets, mesh=dataclasses.replace(case.mesh, layers=3))
    assert level_case(three, "structural_layers", 1.5).mesh.layers == 5
    # evaluated continuously (the built-in case) the reconstruction is a smooth flux of its own
    # width: kept
    assert src.flux_evaluation == "continuous"
    lay_c = level_case(case, "structural_layers", 1.5)
    assert lay_c.mesh.layers == 6 and lay_c.sources == src
    t = level_case(case, "tip", 2.0)
    assert t.mesh.size_tip_mm == pytest.approx(case.mesh.size_tip_mm / 2)
    assert t.mesh.size_flank_mm == case.mesh.size_flank_mm
    p = level_case(case, "positions", 1.5)
    n = case.cycle.positions_per_pitch  # 18 on the built-in case
    assert p.cycle.positions_per_pitch == round(1.5 * n)
    assert p.thermal_mesh_options == case.thermal_mesh
    assert p.sources.flux_smoothing_profile_mm == pytest.approx(
        src.flux_smoothing_profile_mm * n / round(1.5 * n)
    )
    th = level_case(case, "thermal_mesh", 1.5)
    assert th.mesh == case.mesh and th.thermal_mesh.layers == 9
    # coarser levels (a case in the middle of a study), and back
    assert level_case(case, "positions", 1 / 1.5).cycle.positions_per_pitch == round(n / 1.5)
    coarse = level_case(case, "structural_mesh", 1 / 1.5)
    assert level_case(coarse, "structural_mesh", 1.5).mesh == case.mesh


def _unshipped_case():
    """The built-in case at a resolution no study is shipped for (P1 temperatures)."""
    case = load_case(None)
    return dataclasses.replace(case, thermal=dataclasses.replace(case.thermal, degree=1))


def test_no_study_no_uncertainty(store):
    assert run_uncertainty(_unshipped_case(), {"max_surface": 250.0}) is None


def test_studies_combine_in_quadrature_and_scale_with_the_rise(store):
    case = _unshipped_case()
    store_study(_study(case, "thermal_mesh", 3.0, 0.4))
    store_study(_study(case, "positions", 4.0, 0.3))
    assert set(stored_studies(resolution_key(case))) == {"thermal_mesh", "positions"}
    run = run_uncertainty(case, {"max_surface": 250.0, "mean_bulk": 93.0, "tip_max": 200.0})
    q = run.quantities["max_surface"]
    assert q.u_num == pytest.approx(5.0) and not q.scaled and not q.asymptotic
    assert run.quantities["mean_bulk"].u_num == pytest.approx(0.5)
    assert "tip_max" not in run.quantities  # no study measured it: no number invented
    assert run.missing == ("structural_mesh", "structural_layers", "tip")
    # another operating point: scaled by the rise above ambient (23 C)
    other = case.with_operating(speed_rpm=2000.0, torque_Nm=4.0)
    run2 = run_uncertainty(other, {"max_surface": 23.0 + 0.5 * (250.0 - 23.0)})
    q2 = run2.quantities["max_surface"]
    assert q2.scaled and q2.u_num == pytest.approx(2.5)
    assert math.isclose(run2.u_num("max_surface"), 2.5) and run2.u_num("nothing") is None
    # the study's own value as the solvers reproduce it is not scaled; a change of the heating
    # beyond their tolerance is
    near = run_uncertainty(case, {"max_surface": 250.0 * (1.0 + 0.5 * SAME_VALUE_RTOL)})
    assert not near.quantities["max_surface"].scaled
    far = run_uncertainty(case, {"max_surface": 250.0 * (1.0 + 2.0 * SAME_VALUE_RTOL)})
    assert far.quantities["max_surface"].scaled


def test_a_quantity_some_studies_lack_gets_no_u_num(store):
    """A quantity added after some studies ran (the field's surface maximum) would sum only the
    directions that measured it: it gets no u_num until every stored study follows it."""
    case = _unshipped_case()
    store_study(_study(case, "thermal_mesh", 3.0, 0.4))
    newer = _study(case, "positions", 4.0, 0.3)
    newer = dataclasses.replace(
        newer,
        values={**newer.values, "max_surface_field": 251.0},
        units={**newer.units, "max_surface_field": "C"},
        u_num={**newer.u_num, "max_surface_field": 1.0},
        asymptotic={**newer.asymptotic, "max_surface_field": True},
    )
    store_study(newer)
    run = run_uncertainty(case, {"max_surface": 250.0, "max_surface_field": 251.0})
    assert run.quantities["max_surface"].u_num == pytest.approx(5.0)
    assert "max_surface_field" not in run.quantities
    store_study(dataclasses.replace(newer, kind="thermal_mesh"))  # now both follow it
    run = run_uncertainty(case, {"max_surface": 250.0, "max_surface_field": 251.0})
    assert run.quantities["max_surface_field"].u_num == pytest.approx(math.sqrt(2.0))


def test_another_resolution_finds_nothing(store):
    case = load_case(None)
    store_study(_study(case, "thermal_mesh", 3.0, 0.4))
    finer = level_case(case, "positions", 1.5)
    assert run_uncertainty(finer, {"max_surface": 250.0}) is None


def test_the_built_in_case_ships_its_studies_at_its_own_resolution():
    """benchmarks/verification/uncertainty_builtin.py files the built-in case's studies as package
    data under its resolution key: a change of the built-in resolution (or of what the key
    covers) without re-running it leaves no study for the new key, and the main job would report
    no u_num."""
    root = Path(__file__).resolve().parent.parent / "gearfem" / "data" / "uncertainty"
    case = load_case(None)
    key = resolution_key(case)
    shipped = sorted(p.name for p in root.iterdir()) if root.is_dir() else []
    assert shipped == [key], f"shipped studies {shipped}, built-in resolution key {key}"
    kinds = sorted(p.stem for p in (root / key).glob("*.json"))
    # the thermal study at least (the headline temperatures' u_num); the others where they ran
    assert "thermal_mesh" in kinds and set(kinds) <= set(KINDS)
    for kind in kinds:
        s = StudyUncertainty.from_json(json.loads((root / key / f"{kind}.json").read_text()))
        assert s.resolution_key == key and s.kind == kind
        assert s.speed_rpm == case.operating.speed_rpm and s.torque_Nm == case.operating.torque_Nm
        assert s.design == STUDY_DESIGN_VERSION  # measured by the current refinement paths


def test_a_study_of_an_older_design_is_not_used(store, caplog):
    """A study filed by a gearfem whose refinement path of that kind has changed since (files
    without the field are design 1) is left out with a warning, not read back stale."""
    case = _unshipped_case()
    old = dataclasses.replace(_study(case, "structural_mesh", 30.0, 0.4), design=1)
    store_study(old)
    store_study(_study(case, "thermal_mesh", 3.0, 0.4))
    with caplog.at_level("WARNING", logger="gearfem.uncertainty"):
        found = stored_studies(resolution_key(case))
    assert set(found) == {"thermal_mesh"}
    assert "structural_mesh study of design 1, not the current" in caplog.text
    run = run_uncertainty(case, {"max_surface": 250.0})
    assert run.missing == ("structural_mesh", "structural_layers", "positions", "tip")
    assert run.quantities["max_surface"].u_num == pytest.approx(3.0)
    # a file written before the field existed reads as design 1
    data = json.loads(
        (store / "uncertainty" / resolution_key(case) / "thermal_mesh.json").read_text()
    )
    del data["design"]
    assert StudyUncertainty.from_json(data).design == 1


def test_diagnose_takes_u_num_from_the_studies_of_the_case_resolution(store):
    """gearfem diagnose's V&V 20 u_num: from the filed studies when every measured quantity has
    one (scaled by the rise at another operating point), else None (the P1/P2 estimate then)."""
    case = _unshipped_case()
    st = dataclasses.replace(
        _study(case, "thermal_mesh", 3.0, 0.4),
        values={"camera_max": 113.0},
        units={"camera_max": "C"},
        u_num={"camera_max": 5.0},
        asymptotic={"camera_max": False},
    )
    store_study(st)
    m = dict(time_s=None, value=0.0, uncertainty=3.0, ambient_C=case.thermal.ambient_C)
    data = Dataset(
        (
            Measurement(speed_rpm=1000.0, torque_Nm=8.0, quantity="camera_max", **m),
            Measurement(speed_rpm=2000.0, torque_Nm=4.0, quantity="camera_max", **m),
        )
    )
    rise = 113.0 - case.thermal.ambient_C
    u, note = studied_u_num(case, data, np.array([113.0, 23.0 + 0.5 * rise]))
    np.testing.assert_allclose(u, [5.0, 2.5], rtol=1e-12)
    assert "thermal_mesh" in note
    probe = Dataset((Measurement(speed_rpm=1000.0, torque_Nm=8.0, quantity="probe:web", **m),))
    u, note = studied_u_num(case, probe, np.array([60.0]))
    assert u is None and "probe:web" in note
