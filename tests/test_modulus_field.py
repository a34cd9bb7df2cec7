"""Young's modulus per cell from a thermal state (gearfem.cycle.modulus_field).

* The sampling: a structural point takes the relative modulus e(T) of the nearest thermal cell
  of the reference tooth after a turn by whole pitches, the same on every tooth; a gear without a
  table keeps its modulus; e is rounded to the field's step, so that thermal states differing in
  round-off give one digest, and a real change gives another.
* The cycle: a uniform field is the constant modulus scaled (the same Lamé fields, the same
  cycle to round-off); the cycle's and the compliances' cache keys hold the field's digest.
* The chain: the field of a steady state of the small PEEK pair (its frames meet the structural
  mesh's) softens the hot teeth, and the transmission error of its cycle lies between those of
  the constant modulus and of the gear uniformly at its softest cell's modulus.
* The tables: a gear's own ``modulus_table`` comes before the library's E(T); a bad table, a
  steel given one and a polymer with neither are errors naming the key.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from mpi4py import MPI
from scipy.spatial import Delaunay

from gearfem import pipeline
from gearfem.config import Case, case_from_dict, case_to_dict
from gearfem.contact import ContactOptions
from gearfem.core.errors import ParameterError
from gearfem.core.material_library import library_material
from gearfem.core.materials import Material, TemperatureTable
from gearfem.cycle import CycleOptions, GearContactModel, solve_cycle
from gearfem.cycle.modulus_field import GearTemperature, ModulusField
from gearfem.geometry.options import BODIES, MeshOptions
from gearfem.geometry.placement import tooth_local
from gearfem.thermal.options import ThermalOptions

#: E(T) of a polymer through its glass transition (Pa; only ratios matter)
TABLE = TemperatureTable.from_celsius(
    (20.0, 100.0, 150.0, 200.0), (3.6e9, 3.4e9, 1.8e9, 0.4e9), name="test E(T)"
)
PITCH = 2.0 * math.pi / 30.0
ANGLES = np.array([0.5, 1.5, 2.5]) * PITCH  # three modelled teeth; the middle one is the reference


def _sector_state(T_of_r) -> GearTemperature:
    """A thermal 'mesh' of the three teeth's annulus (random tetrahedra are enough for sampling:
    only their centroids and vertex temperatures are used), temperatures by radius."""
    rng = np.random.default_rng(3)
    n = 4000
    r = rng.uniform(0.02, 0.032, n)
    a = rng.uniform(0.0, 3.0 * PITCH, n)
    z = rng.uniform(-0.003, 0.003, n)
    nodes = np.column_stack([r * np.cos(a), r * np.sin(a), z])
    cells = Delaunay(nodes).simplices
    return GearTemperature(nodes, cells, T_of_r(r), np.zeros(3), ANGLES)


def test_a_point_takes_the_nearest_reference_cell_on_every_tooth():
    state = _sector_state(lambda r: 293.15 + 200.0 * (r - 0.02) / 0.012)
    field = ModulusField.from_temperatures({"pinion": state}, {"pinion": TABLE})
    bm = field.bodies["pinion"]
    assert bm.reference_angle_rad == pytest.approx(ANGLES[1])
    # structural points on a 30-tooth gear: a point and its copies whole pitches round
    rng = np.random.default_rng(7)
    r = rng.uniform(0.021, 0.031, 200)
    a = ANGLES[1] + rng.uniform(-0.45, 0.45, 200) * PITCH
    pts = np.column_stack([r * np.cos(a), r * np.sin(a), rng.uniform(-0.002, 0.002, 200)])
    teeth = (np.arange(30) + 0.5) * PITCH
    e_ref = field.relative_at("pinion", pts, np.zeros(3), teeth)
    # the reference tooth's own points: the nearest thermal cell's rounded e
    _, j = bm._tree.query(pts)
    assert np.array_equal(e_ref, bm.relative[j])
    for k in (-7, 1, 12):
        c, s = math.cos(k * PITCH), math.sin(k * PITCH)
        turned = pts @ np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
        assert np.array_equal(field.relative_at("pinion", turned, np.zeros(3), teeth), e_ref)
    # e follows the table at the cell's temperature, within the sampling's spread in radius
    T_pts = 293.15 + 200.0 * (r - 0.02) / 0.012
    exact = TABLE(T_pts) / TABLE.values[0]
    assert np.median(np.abs(e_ref - exact)) < 0.05
    assert e_ref.min() >= TABLE.values[-1] / TABLE.values[0] - 1e-12 and e_ref.max() <= 1.0
    # a gear the field does not hold keeps its modulus
    assert np.all(field.relative_at("wheel", pts, np.zeros(3), teeth) == 1.0)


def test_the_digest_ignores_round_off_and_sees_a_change():
    state = _sector_state(lambda r: 380.0 + 100.0 * (r - 0.02) / 0.012)
    field = ModulusField.from_temperatures({"wheel": state}, {"wheel": TABLE})
    e = field.bodies["wheel"].relative
    assert np.allclose(np.log(e) / field.step, np.round(np.log(e) / field.step), atol=1e-6)
    noisy = dataclasses.replace(state, temperature_K=state.temperature_K + 1e-9)
    again = ModulusField.from_temperatures({"wheel": noisy}, {"wheel": TABLE})
    assert again.digest() == field.digest()
    warmer = dataclasses.replace(state, temperature_K=state.temperature_K + 2.0)
    assert ModulusField.from_temperatures({"wheel": warmer}, {"wheel": TABLE}).digest() != (
        field.digest()
    )
    beyond = field.bodies["wheel"].beyond_table  # T above 200 C: r > 0.02 + 0.012 * 93/100
    assert 0.0 < beyond < 0.2
    with pytest.raises(ParameterError, match="modulus_field.states"):
        ModulusField.from_temperatures({"wheel": state}, {"pinion": TABLE})
    with pytest.raises(ParameterError, match="modulus_field.step"):
        ModulusField.from_temperatures({"wheel": state}, {"wheel": TABLE}, step=0.5)


# ------------------------------------------------------------------------------- in the cycle

TINY = MeshOptions(
    teeth_in_model=4,
    refined_teeth=3,
    layers=2,
    size_flank_mm=0.35,
    size_tip_mm=0.35,
    size_root_mm=0.45,
    size_tooth_mm=1.5,
    size_body_mm=5.0,
)


def _case(modulus_Pa: float | None = None) -> Case:
    c = Case(
        mesh=TINY,
        contact=ContactOptions(friction_coefficient=0.0),
        cycle=CycleOptions(positions_per_pitch=2, check_periodicity=False),
    ).with_operating(torque_Nm=4.0)
    if modulus_Pa is not None:
        c = dataclasses.replace(
            c, material=dataclasses.replace(c.material, youngs_modulus_Pa=modulus_Pa)
        )
    return c


def _own_state(gm, body: str, T_of_r) -> GearTemperature:
    """The structural mesh of ``body`` as its thermal state (coincident meshes: exact sampling)."""
    mesh = gm.mesh
    cells = gm.cells(body)
    dofs = mesh.geometry.dofmaps[0][cells]
    center = gm.center(body)
    r = np.hypot(*(mesh.geometry.x[:, :2] - center[:2]).T)
    return GearTemperature(mesh.geometry.x, dofs, T_of_r(r), center, gm.tooth_angles(body))


def _cycle(case: Case, moduli: ModulusField | None = None, gm=None):
    gm = gm or pipeline.pair_mesh(case, MPI.COMM_WORLD)
    model = GearContactModel(
        gm, case.materials, case.contact, case.operating.torque_Nm, case.cycle, moduli=moduli
    )
    return solve_cycle(model), model


@pytest.mark.slow
def test_a_uniform_field_is_the_constant_modulus_scaled():
    case = _case()
    gm = pipeline.pair_mesh(case, MPI.COMM_WORLD)
    E = case.material.youngs_modulus_Pa
    # uniform at 150 C: the constant modulus scaled by e(150 C), rounded
    uniform = ModulusField.from_temperatures(
        {b: _own_state(gm, b, lambda r: np.full_like(r, 423.15)) for b in BODIES},
        dict.fromkeys(BODIES, TABLE),
    )
    e = float(uniform.bodies["pinion"].relative[0])
    assert e == pytest.approx(1.8 / 3.6, rel=1e-3)
    soft, model = _cycle(case, uniform, gm)
    scaled, model_scaled = _cycle(_case(E * e))
    assert np.allclose(model.lame_mu.x.array, model_scaled.lame_mu.x.array, rtol=1e-12)
    assert np.allclose(soft.te_m, scaled.te_m, rtol=1e-8)


def test_the_cache_keys_hold_the_field():
    case = _case()
    state = _sector_state(lambda r: 400.0 + 0.0 * r)
    field = ModulusField.from_temperatures({"pinion": state}, {"pinion": TABLE})
    other = ModulusField.from_temperatures(
        {"pinion": dataclasses.replace(state, temperature_K=state.temperature_K + 20.0)},
        {"pinion": TABLE},
    )
    keys = {pipeline.case_cycle_key(case, moduli=m) for m in (None, field, other)}
    contexts = {pipeline.case_compliance_context(case, m) for m in (None, field, other)}
    assert len(keys) == 3 and len(contexts) == 3
    assert pipeline.case_cycle_key(case, moduli=field) == pipeline.case_cycle_key(
        case, moduli=ModulusField.from_temperatures({"pinion": state}, {"pinion": TABLE})
    )


@pytest.mark.slow
def test_the_run_iterates_the_modulus_with_the_heat_to_a_fixed_point(tmp_path):
    """``[cycle] modulus = "thermal_state"`` on the small PEEK pair at a hot point: the first
    cycle at the constant modulus, the next with the field of its steady state, until the gears'
    mean relative modulus settles (ModulusLoop); the thermal snapshot's frames meet the
    structural mesh's (every structural cell of a gear lands within a thermal cell's reach on
    the reference tooth, not in the gap between teeth); the hot teeth are softer, and the
    transmission error of the last cycle lies between the constant modulus's and that of the gear
    uniformly at its softest cell's modulus."""
    case = case_from_dict({"name": "small PEEK pair", "material": {"name": "PEEK 450G"}})
    case = dataclasses.replace(
        case,
        mesh=TINY,
        cycle=CycleOptions(positions_per_pitch=2, check_periodicity=False, modulus="thermal_state"),
        thermal=ThermalOptions(mode="steady", degree=1, output_times_s=()),
        instruments=dataclasses.replace(
            case.instruments, camera=dataclasses.replace(case.instruments.camera, enabled=False)
        ),
    ).with_operating(speed_rpm=2000.0, torque_Nm=7.0)
    comm = MPI.COMM_SELF
    cycles = []
    stages = pipeline.thermal_stages(
        case, tmp_path, comm, progress=False, write_fields=False, write_plot=False,
        on_pass=lambda k, c, st, p: cycles.append(st.cycle),
    )  # fmt: skip
    loop = stages.modulus
    assert loop is not None and len(loop.passes) == len(cycles) >= 2
    first, last = loop.passes[0], loop.passes[-1]
    assert first.relative_cycle == (1.0, 1.0) and last.change_max < loop.tolerance
    assert all(0.3 < x < 1.0 for x in last.relative_state)  # the hot teeth are softer
    assert last.relative_cycle == pytest.approx(loop.passes[-2].relative_state, rel=1e-12)
    table = library_material("PEEK 450G").tables["youngs_modulus_Pa"].table()
    field = pipeline.state_modulus_field(stages.snapshot, dict.fromkeys(BODIES, table))
    gm = pipeline.pair_mesh(case, comm)
    x = gm.mesh.geometry.x
    for b, bm in field.bodies.items():
        pts = x[gm.mesh.geometry.dofmaps[0][gm.cells(b)]].mean(axis=1)
        local, _ = tooth_local(pts, gm.center(b), gm.tooth_angles(b), 0.0, bm.reference_angle_rad)
        d, _ = bm._tree.query(local)
        f = stages.snapshot.bodies[b]
        edge = np.linalg.norm(f.nodes_m[f.cells[:, 1]] - f.nodes_m[f.cells[:, 0]], axis=1)
        assert np.percentile(d, 99) < np.max(edge), b
    e_min = min(float(bm.relative.min()) for bm in field.bodies.values())
    E = case.material.youngs_modulus_Pa
    softest = dataclasses.replace(case, material=dataclasses.replace(case.material,
                                  youngs_modulus_Pa=E * e_min))  # fmt: skip
    soft, _, _ = pipeline.cycle(softest, comm)
    te = lambda c: float(np.mean(c.te_m))
    assert te(cycles[0]) < te(cycles[-1]) < te(soft)


def test_a_modulus_from_the_thermal_state_needs_a_table_and_a_run(monkeypatch):
    """Every library polymer has an E(T) table, each relative to its first temperature; a gear of
    a material without one (POM with its table taken away here) cannot take its modulus from the
    thermal state, a steel gear keeps its own; the diagnosis, whose runs share one cycle per
    torque, refuses the fixed point: each error names the key."""
    from gearfem.diagnose.forward import FullModel

    follows = {"modulus": "thermal_state"}
    pom = {"name": "POM", "hysteresis": [[20.0, 100.0], [0.01, 0.02]]}
    pom_pom = case_from_dict({"material": pom, "material_wheel": pom, "cycle": follows})
    tables = pipeline.modulus_tables(pom_pom)
    assert set(tables) == set(BODIES)
    # the source's curve: 2.8 GPa at 23 C, 1.2 GPa at 100 C
    assert tables["wheel"](373.15) / tables["wheel"](296.15) == pytest.approx(1.2 / 2.8)
    lookup = pipeline.library_material

    def without_e_of_t(name, *args):
        lib = lookup(name, *args)
        if lib.name != "POM":
            return lib
        rest = {k: v for k, v in lib.tables.items() if k != "youngs_modulus_Pa"}
        return dataclasses.replace(lib, tables=rest)

    monkeypatch.setattr(pipeline, "library_material", without_e_of_t)
    with pytest.raises(ParameterError, match=r"cycle\.modulus.*wheel's POM has none") as err:
        pipeline.modulus_tables(case_from_dict({"material_wheel": pom, "cycle": follows}))
    # the allowed values: the gear's own table, or the library's polymers that have one
    assert "[material_wheel] modulus_table = [[T_C...], [E_Pa...]]" in err.value.allowed
    assert err.value.allowed.endswith("(PA66, PEEK 450G)")
    with pytest.raises(ParameterError, match=r"cycle\.modulus.*\[material\] modulus_table"):
        pipeline.modulus_tables(case_from_dict({"material": pom, "cycle": follows}))
    # the gear's own table is the way out
    own = pom | {"modulus_table": [[23.0, 100.0], [2.8e9, 1.2e9]]}
    assert set(pipeline.modulus_tables(case_from_dict({"material_wheel": own, "cycle": follows})))
    monkeypatch.undo()
    steel_peek = case_from_dict({"material": {"name": "steel"}, "cycle": follows})
    steel_peek = dataclasses.replace(steel_peek, material_wheel=Case().material)
    assert set(pipeline.modulus_tables(steel_peek)) == {"wheel"}
    with pytest.raises(ParameterError, match=r"cycle\.modulus"):
        FullModel(case_from_dict({"cycle": follows}), MPI.COMM_SELF)
    with pytest.raises(ParameterError, match=r"cycle\.modulus_tolerance"):
        CycleOptions(modulus_tolerance=0.0)


# ---------------------------------------------------------------------------- the case's own E(T)

OWN = [[20.0, 90.0, 140.0], [3.0e9, 2.0e9, 0.5e9]]


def test_a_gears_own_modulus_table_comes_before_the_librarys():
    """``[material] modulus_table`` (and ``[material_wheel]``) replaces the library's E(T) of the
    gear's material; a gear without one keeps the library's; the table reads back from a written
    case and enters the cycle's cache key."""
    follows = {"modulus": "thermal_state"}
    library = library_material("PEEK 450G").tables["youngs_modulus_Pa"].table()
    case = case_from_dict(
        {"material_wheel": {"name": "PEEK 450G", "modulus_table": OWN}, "cycle": follows}
    )
    assert case.material_wheel.modulus_table == tuple(tuple(row) for row in OWN)
    tables = pipeline.modulus_tables(case)
    assert tables["pinion"] == library
    wheel = tables["wheel"]
    assert np.allclose(wheel.T_K, (293.15, 363.15, 413.15)) and wheel.values == tuple(OWN[1])
    assert wheel(363.15) / wheel(293.15) == pytest.approx(2.0 / 3.0)
    # [material] gives both gears the table
    both = pipeline.modulus_tables(
        case_from_dict({"material": {"modulus_table": OWN}, "cycle": follows})
    )
    assert both["pinion"] == both["wheel"] == wheel
    assert case_from_dict(case_to_dict(case)) == case
    wheel_plain = dataclasses.replace(case.material_wheel, modulus_table=None)
    plain = dataclasses.replace(case, material_wheel=wheel_plain)
    assert pipeline.case_cycle_key(plain) != pipeline.case_cycle_key(case)
    assert pipeline.modulus_tables(plain)["wheel"] == library


@pytest.mark.parametrize(
    ("table", "fault"),
    [
        ([[20.0, 100.0], [3.0e9, 5.0e12]], "E = 5e+12 Pa at 100 C"),
        ([[100.0, 20.0], [3.0e9, 2.0e9]], "20 C after 100 C"),
        ([[20.0], [3.0e9]], "one point"),
        ([[20.0, 100.0], [3.0e9]], "unequal length"),
        ([[20.0, math.inf], [3.0e9, 2.0e9]], "temperature inf C"),
    ],
)
def test_a_bad_modulus_table_is_an_error_naming_the_key_and_value(table, fault):
    as_tuple = tuple(tuple(row) for row in table)
    with pytest.raises(ParameterError) as err:
        Material(modulus_table=as_tuple)
    assert err.value.name == "material.modulus_table" and err.value.value == as_tuple
    assert fault in str(err.value) and "[1e+06, 1e+12] Pa" in err.value.allowed
    for key in ("material", "material_wheel"):
        with pytest.raises(ParameterError) as err:
            case_from_dict({key: {"name": "PEEK 450G", "modulus_table": table}})
        msg = str(err.value)
        assert msg.startswith(f"{key}.modulus_table = {as_tuple!r} is not allowed"), msg
        assert fault in msg


def test_a_steel_gear_given_a_modulus_table_is_refused():
    """A steel gear keeps its constant modulus: a table given to it is an error (in the case file
    and in a case built in Python), not ignored."""
    with pytest.raises(ParameterError, match=r"^material_wheel\.modulus_table = .*steel keeps"):
        case_from_dict({"material_wheel": {"name": "steel", "modulus_table": OWN}})
    steel = library_material("steel").to_material()
    own = dataclasses.replace(steel, modulus_table=((20.0, 100.0), (2e11, 2e11)))
    follows = dataclasses.replace(Case().cycle, modulus="thermal_state")
    case = dataclasses.replace(Case(), material_wheel=own, cycle=follows)
    with pytest.raises(ParameterError, match=r"^material_wheel\.modulus_table = .*steel keeps"):
        pipeline.modulus_tables(case)


def test_a_modulus_table_the_cycle_would_not_read_is_refused():
    """With ``[cycle] modulus = "constant"`` (the default) the cycle runs at the constant
    ``youngs_modulus_Pa``: a gear's own ``modulus_table`` would be left unread, so it is an error
    naming the key, not ignored."""
    for key in ("material", "material_wheel"):
        with pytest.raises(ParameterError) as err:
            case_from_dict({key: {"name": "PEEK 450G", "modulus_table": OWN}})
        assert err.value.name == f"{key}.modulus_table"
        assert "modulus = 'thermal_state'" in err.value.allowed
