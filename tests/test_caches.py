"""Every cache is keyed by every input that changes what it holds, and by nothing else.

For each cache (the pair mesh, the structural cycle per torque, the gear compliances of the
condensed contact solver), each input that changes the cached result must change the key (a
recompute), and each input that does not must leave it unchanged (a hit). The heat split between
the gears is applied after the cycle cache (by the coupling), so it is in the second group; the
cycle test of the coupling checks that the split then scales the friction heat
(tests/test_cycle.py::test_cycle_store_round_trip_and_heat_handed_to_the_thermal_model).
"""

from __future__ import annotations

import dataclasses

import pytest

from gearfem.config import load_case
from gearfem.core.errors import ParameterError
from gearfem.geometry.mesh import cache_key as mesh_key
from gearfem.geometry.options import MeshOptions
from gearfem.pipeline import case_compliance_context, case_cycle_key

CASE = load_case(None)


def _replace(case, table: str, **changes):
    return dataclasses.replace(
        case, **{table: dataclasses.replace(getattr(case, table), **changes)}
    )


CYCLE_CHANGES = {
    "torque": CASE.with_operating(torque_Nm=CASE.operating.torque_Nm + 1.0),
    "friction coefficient": _replace(CASE, "contact", friction_coefficient=0.3),
    "contact penalty": _replace(CASE, "contact", penalty_factor=2 * CASE.contact.penalty_factor),
    "flank element size": _replace(CASE, "mesh", size_flank_mm=0.3),
    "face width": _replace(CASE, "geometry", face_width_mm=10.0),
    "layer grading": _replace(CASE, "mesh", layer_grading=2.0),
    "positions per pitch": _replace(
        CASE, "cycle", positions_per_pitch=CASE.cycle.positions_per_pitch + 2
    ),
    "Young's modulus": _replace(
        CASE, "material", youngs_modulus_Pa=0.9 * CASE.material.youngs_modulus_Pa
    ),
    "contact solver": _replace(
        CASE, "cycle", solver="full" if CASE.cycle.solver == "condensed" else "condensed"
    ),
}

CYCLE_SAME = {
    "speed": CASE.with_operating(speed_rpm=2 * CASE.operating.speed_rpm),
    "heat split": _replace(CASE, "sources", heat_fraction_pinion=0.8),
    "hysteresis scale": _replace(CASE, "sources", hysteresis_scale=2.0),
    "ambient temperature": _replace(CASE, "thermal", ambient_C=40.0),
    "thermal body": _replace(CASE, "thermal", body="wheel"),
}


# The condensed solver's gear compliances (cache/compliance): one per mesh and elastic material,
# reused for every torque, friction law, contact option and speed. The store adds each gear's
# contact DOFs and supports to the key (test_compliance_store_key_holds_the_dofs_and_supports).
COMPLIANCE_CHANGES = {
    "flank element size": CYCLE_CHANGES["flank element size"],
    "face width": CYCLE_CHANGES["face width"],
    "Young's modulus": CYCLE_CHANGES["Young's modulus"],
    "Poisson's ratio": _replace(CASE, "material", poissons_ratio=0.35),
    "wheel material": dataclasses.replace(
        CASE,
        material_wheel=dataclasses.replace(
            CASE.material, youngs_modulus_Pa=2 * CASE.material.youngs_modulus_Pa
        ),
    ),
}

COMPLIANCE_SAME = {
    **CYCLE_SAME,
    "torque": CYCLE_CHANGES["torque"],
    "friction coefficient": CYCLE_CHANGES["friction coefficient"],
    "contact penalty": CYCLE_CHANGES["contact penalty"],
    "positions per pitch": CYCLE_CHANGES["positions per pitch"],
    "contact solver": CYCLE_CHANGES["contact solver"],
    "thermal conductivity": _replace(CASE, "material", thermal_conductivity_W_mK=0.3),
}


@pytest.mark.parametrize("name", list(COMPLIANCE_CHANGES))
def test_compliance_key_changes_with_mesh_and_elastic_constants(name):
    assert case_compliance_context(COMPLIANCE_CHANGES[name]) != case_compliance_context(CASE)


@pytest.mark.parametrize("name", list(COMPLIANCE_SAME))
def test_compliance_key_ignores_the_operating_point_and_contact_options(name):
    assert case_compliance_context(COMPLIANCE_SAME[name]) == case_compliance_context(CASE)


def test_compliance_store_key_holds_the_dofs_and_supports(tmp_path):
    """Within one context, the key changes with the body, its contact DOFs (names, so the same on
    any number of ranks) and its supports; the global numbering of a run does not enter."""
    import numpy as np

    from gearfem.contact.compliance import BodyDofs, ComplianceStore

    store = ComplianceStore(tmp_path, case_compliance_context(CASE))
    names = np.arange(0, 300, 1, dtype=np.int64)
    body = BodyDofs("pinion", 0, np.arange(1000), np.arange(300), names, "supports")
    assert store.key(dataclasses.replace(body, free=np.arange(5, 1005))) == store.key(body)
    assert store.key(dataclasses.replace(body, contact=np.arange(1, 301))) == store.key(body)
    assert store.key(dataclasses.replace(body, owner=1)) == store.key(body)
    for other in (
        dataclasses.replace(body, name="wheel"),
        dataclasses.replace(body, contact_names=names + 3),
        dataclasses.replace(body, contact_names=names[:-1]),
        dataclasses.replace(body, fixed_hash="other supports"),
    ):
        assert store.key(other) != store.key(body)
    assert ComplianceStore(tmp_path, "another mesh").key(body) != store.key(body)


@pytest.mark.parametrize("name", list(CYCLE_CHANGES))
def test_cycle_key_changes_with_what_changes_the_cycle(name):
    assert case_cycle_key(CYCLE_CHANGES[name]) != case_cycle_key(CASE)


@pytest.mark.parametrize("name", list(CYCLE_SAME))
def test_cycle_key_ignores_what_is_applied_after_the_cycle(name):
    assert case_cycle_key(CYCLE_SAME[name]) == case_cycle_key(CASE)


def test_mesh_key_changes_with_options_geometry_and_bodies():
    base = mesh_key(CASE.geometry, CASE.mesh)
    assert mesh_key(CASE.geometry, dataclasses.replace(CASE.mesh, layers=5)) != base
    equal = mesh_key(CASE.geometry, dataclasses.replace(CASE.mesh, layer_grading=None))
    assert mesh_key(CASE.geometry, dataclasses.replace(CASE.mesh, layer_grading=4.0)) != equal
    assert mesh_key(CASE.geometry, dataclasses.replace(CASE.mesh, layer_grading=1.0)) == equal
    assert mesh_key(dataclasses.replace(CASE.geometry, bore_radius_mm=12.0), CASE.mesh) != base
    assert mesh_key(CASE.geometry, CASE.mesh, bodies=("pinion",)) != base
    # the same bodies in another order are the same mesh
    assert mesh_key(CASE.geometry, CASE.mesh, bodies=("wheel", "pinion")) == base


def test_thermal_mesh_table_is_the_thermal_models_own(tmp_path):
    """``[thermal_mesh]`` gives the thermal model its own mesh; absent, it is the ``[mesh]`` table.
    It does not touch the structural cycle's key (the cycle never sees the thermal mesh)."""
    from gearfem.config import write_case

    plain = tmp_path / "plain.toml"
    plain.write_text("[mesh]\nsize_flank_mm = 0.3\n")
    p = load_case(plain)
    assert p.thermal_mesh is None and p.thermal_mesh_options == p.mesh
    case = tmp_path / "case.toml"
    case.write_text(
        "[mesh]\nsize_flank_mm = 0.3\n\n[thermal_mesh]\nsize_flank_mm = 0.1\nlayers = 6\n"
    )
    c = load_case(case)
    assert c.mesh.size_flank_mm == 0.3 and c.mesh.layers == MeshOptions().layers
    assert c.thermal_mesh_options.size_flank_mm == 0.1 and c.thermal_mesh_options.layers == 6
    assert case_cycle_key(c) == case_cycle_key(dataclasses.replace(c, thermal_mesh=None))
    # a written case reads back the same
    again = load_case(write_case(c, tmp_path / "again.toml"))
    assert again == c
    with pytest.raises(ParameterError) as err:
        case.write_text("[thermal_mesh]\nlayers = 0\n")
        load_case(case)
    assert err.value.name == "thermal_mesh.layers"


def test_code_hashes_cover_exactly_the_code_that_computes_the_cache():
    """The cycle key hashes the modules the cycle solve imports, transitively (contact, the mesh,
    the Newton driver, the facet geometry), and not the thermal model or the diagnosis; the mesh key
    hashes the mesh generator, not the DOLFINx import."""
    from gearfem.core.provenance import source_files, source_hash

    cycle = set(source_files("gearfem.cycle.solve", "gearfem.cycle.model"))
    assert {
        "gearfem.contact.interface",
        "gearfem.geometry.mesh",
        "gearfem.core.newton",
        "gearfem.core.facets",
    } <= cycle
    assert not {"gearfem.thermal.problem", "gearfem.core.gci", "gearfem.diagnose.forward"} & cycle
    mesh = set(source_files("gearfem.geometry.gmsh_pair"))
    assert {"gearfem.geometry.extrude", "gearfem.geometry.involute"} <= mesh
    assert "gearfem.geometry.mesh" not in mesh
    assert source_hash("gearfem.cycle.solve") == source_hash("gearfem.cycle.solve")
