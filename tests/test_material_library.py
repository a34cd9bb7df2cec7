"""The materials library (gearfem/data/materials/, gearfem.core.material_library): every material
loads and validates, every value names its source and uncertainty, estimates say why, PEEK 450G is
the shipped gearfem/data/peek450g data, unknown names are refused with the library's names, the
effusivity partition against a hand calculation, the input-uncertainty intervals. No solver."""

from __future__ import annotations

import dataclasses
import math
from importlib import resources

import pytest

from gearfem import baselines as B
from gearfem.config import case_from_dict, case_to_dict, load_case
from gearfem.core.errors import ParameterError
from gearfem.core.material_library import (
    VALUE_UNITS,
    effusivity,
    effusivity_partition,
    effusivity_partition_range,
    input_uncertainties,
    library_material,
    library_names,
    parse_material,
)
from gearfem.core.materials import (
    NO_HYSTERESIS,
    Material,
    input_ranges,
    peek450g_hysteresis,
    read_csv,
    read_toml,
)

NAMES = ("PA66", "PEEK 450G", "POM", "steel")
UNIT_OF_SUFFIX = {
    "_kg_m3": "kg/m^3",
    "_Pa": "Pa",
    "_W_mK": "W/(m K)",
    "_J_kgK": "J/(kg K)",
    "_1_K": "1/K",
    "_C": "degC",
}


def test_every_library_material_loads_and_validates():
    files = sorted(
        f.name
        for f in resources.files("gearfem").joinpath("data", "materials").iterdir()
        if f.name.endswith(".toml")
    )
    assert files == ["pa66.toml", "peek450g.toml", "pom.toml", "steel.toml"]
    assert library_names() == NAMES
    for name in NAMES:
        mat = library_material(name)
        assert mat.name == name and mat.kind in ("polymer", "steel")
        assert mat.grade and mat.summary
        for key in ("density_kg_m3", "youngs_modulus_Pa", "thermal_conductivity_W_mK"):
            assert mat.value(key) > 0
        assert 0.0 < mat.value("emissivity") <= 1.0
        assert 0.0 < mat.value("poissons_ratio") < 0.5
    assert library_material("steel").kind == "steel"
    assert {library_material(n).kind for n in ("PA66", "PEEK 450G", "POM")} == {"polymer"}


def test_every_value_has_a_source_a_unit_and_an_uncertainty():
    """Each value: a citation from its file's [sources] (every listed source cited by some value
    or table), the unit its key names, exactly one uncertainty; each file's header says where its
    numbers come from."""
    for name in NAMES:
        mat = library_material(name)
        cited = set()
        for key, v in mat.values.items():
            assert v.source == mat.sources[v.source_key] and len(v.source) > 20, key
            cited |= {v.source_key, *v.also}
            suffix = next((s for s in UNIT_OF_SUFFIX if key.endswith(s)), None)
            assert v.unit == VALUE_UNITS[key] == (UNIT_OF_SUFFIX[suffix] if suffix else "1"), key
            given = [v.range, v.uncertainty_rel, v.uncertainty_abs]
            assert sum(g is not None for g in given) == 1, key
        cited |= {t.source_key for t in mat.tables.values()}
        assert cited == set(mat.sources), name
        text = resources.files("gearfem").joinpath("data", "materials", mat.file.split("/")[-1])
        head = text.read_text(encoding="utf-8").splitlines()[:3]
        assert all(line.startswith("#") for line in head), mat.file


def test_estimates_are_flagged_with_a_reason():
    """Values no stored source confirms say so and why; PEEK 450G has none (all shipped or
    thesis values), the others list theirs."""
    est = {n: sorted(v.name for v in library_material(n).estimates()) for n in NAMES}
    assert est["PEEK 450G"] == []
    assert est["POM"] == ["emissivity", "friction_against_self"]
    assert est["PA66"] == [
        "emissivity",
        "friction_against_self",
        "friction_against_steel",
        "poissons_ratio",
    ]
    assert est["steel"] == ["emissivity", "max_service_temperature_C", "thermal_expansion_1_K"]
    for n in NAMES:
        for v in library_material(n).estimates():
            assert len(v.reason) > 20 and v.source_key == "estimate", (n, v.name)
        for v in library_material(n).values.values():
            assert v.estimate or not v.reason, (n, v.name)


def test_peek450g_is_the_shipped_data():
    """The library's PEEK 450G equals gearfem/data/peek450g: the constants of Material.peek450g(),
    the source ranges of material.toml, the H(T) table of hysteresis.csv, the E(T) table, the
    thesis's friction observations; to_material() is the shipped Material with the same H(T)."""
    lib = library_material("PEEK 450G")
    shipped = Material.peek450g()
    for key in (
        "density_kg_m3",
        "youngs_modulus_Pa",
        "poissons_ratio",
        "thermal_conductivity_W_mK",
        "specific_heat_J_kgK",
        "emissivity",
        "glass_transition_C",
    ):
        assert lib.value(key) == getattr(shipped, key), key
    toml = read_toml("peek450g", "material.toml")
    assert lib.value("melting_C") == toml["melting_C"]
    assert lib.value("thermal_expansion_1_K") == toml["thermal_expansion_1_K"]
    ranges = input_ranges()
    for key, shipped_key in (
        ("density_kg_m3", "density"),
        ("youngs_modulus_Pa", "youngs_modulus"),
        ("poissons_ratio", "poissons_ratio"),
        ("thermal_conductivity_W_mK", "thermal_conductivity"),
    ):
        assert lib[key].range == tuple(ranges[shipped_key]), key
    H = lib.tables["hysteresis"].table()
    ref = peek450g_hysteresis()
    assert H.T_K == ref.T_K and H.values == ref.values
    E = lib.tables["youngs_modulus_Pa"]
    assert list(E.T_C) == toml["modulus_vs_temperature_C"]
    assert list(E.values) == toml["modulus_vs_temperature_Pa"]
    obs = {(r["pair"], r["varied"]): r for r in read_csv("peek450g", "friction_observations.csv")}
    self_t = obs[("PEEK-PEEK", "temperature_C")]
    steel_t = obs[("steel-PEEK", "temperature_C")]
    assert lib["friction_against_self"].range == (float(self_t["mu_to"]), float(self_t["mu_from"]))
    assert lib.value("friction_against_steel") == float(steel_t["mu_from"])
    assert lib.value("friction_against_self") == 0.5  # the thesis model's constant (5.1.2)
    mat = lib.to_material()
    assert mat.hysteresis == "peek450g" and mat.hysteresis_table() == ref
    for field in ("density_kg_m3", "youngs_modulus_Pa", "specific_heat_J_kgK", "emissivity"):
        assert getattr(mat, field) == getattr(shipped, field)


def test_names_and_aliases_are_matched_loosely_unknown_names_refused():
    for alias, name in (
        ("peek", "PEEK 450G"),
        ("PEEK450G", "PEEK 450G"),
        ("Nylon 66", "PA66"),
        ("pa 6.6", "PA66"),
        ("POM-C", "POM"),
        ("acetal", "POM"),
        ("16mncr5", "steel"),
        ("STEEL", "steel"),
    ):
        assert library_material(alias).name == name, alias
    with pytest.raises(ParameterError) as err:
        library_material("Delrin")  # a POM homopolymer: not the copolymer data of the library
    msg = str(err.value)
    assert msg.startswith("material.name = 'Delrin' is not allowed")
    for name in NAMES:
        assert repr(name) in msg
    with pytest.raises(ParameterError, match=r"^material_wheel\.name = 'PA6' "):
        library_material("PA6", parameter="material_wheel.name")


def test_effusivity_partition():
    """f1 = b1 / (b1 + b2), b = sqrt(k rho c_p): 1/2 for equal materials; steel against POM by
    hand: b_steel = sqrt(46 * 7830 * 465) = 12941.5, b_POM = sqrt(0.30 * 1410 * 1465) = 787.2,
    f_steel = 12941.5 / 13728.8 = 0.9427; with rolling speeds, Blok's b sqrt(v) weights."""
    assert effusivity_partition("PEEK 450G", "PEEK") == 0.5
    assert effusivity_partition("POM", "POM", 3.0, 3.0) == 0.5
    b_steel = math.sqrt(46.0 * 7830.0 * 465.0)
    b_pom = math.sqrt(0.30 * 1410.0 * 1465.0)
    assert b_steel == pytest.approx(12941.5, abs=0.1) and b_pom == pytest.approx(787.2, abs=0.1)
    assert effusivity("steel") == pytest.approx(B.effusivity(46.0, 7830.0, 465.0), rel=1e-15)
    f = effusivity_partition("steel", "POM")
    assert f == pytest.approx(b_steel / (b_steel + b_pom), rel=1e-14)
    assert f == pytest.approx(0.9427, abs=5e-5) and f > 0.9
    assert effusivity_partition("POM", "steel") == pytest.approx(1.0 - f, rel=1e-13)
    # Blok's moving-source split: b sqrt(v); same material at speeds 1 and 4 m/s -> 1/3
    assert effusivity_partition("PA66", "PA66", 1.0, 4.0) == pytest.approx(1.0 / 3.0, rel=1e-14)
    lo, hi = effusivity_partition_range("steel", "POM")
    assert lo < f < hi and hi - lo < 0.05
    lo, hi = effusivity_partition_range("PEEK", "PEEK")
    assert lo < 0.5 < hi
    with pytest.raises(ParameterError, match="speed2_m_s"):
        effusivity_partition("POM", "steel", 1.0, None)


def test_input_uncertainties_bracket_the_values():
    """Each value's interval: lo <= value <= hi, lo < hi (a range between sources may end at the
    value, as the shipped PEEK ranges do); keys are the value names, units included."""
    for name in NAMES:
        mat = library_material(name)
        intervals = input_uncertainties(name)
        assert set(intervals) == set(mat.values)
        for key, (lo, hi) in intervals.items():
            v = mat.value(key)
            assert lo <= v <= hi and lo < hi, (name, key)
    pa = library_material("PA66")
    lo, hi = input_uncertainties(pa)["youngs_modulus_Pa"]
    assert lo == pa.value("youngs_modulus_conditioned_Pa") < pa.value("youngs_modulus_Pa") <= hi
    assert input_uncertainties("steel")["density_kg_m3"] == pytest.approx((7790.85, 7869.15))


def test_to_material_needs_loss_data_and_a_polymer():
    with pytest.raises(ParameterError, match=r"material\.hysteresis .*no loss data for POM"):
        library_material("POM").to_material()
    m = library_material("POM").to_material(hysteresis=((20.0, 100.0), (0.01, 0.02)))
    assert m.youngs_modulus_Pa == 2.85e9 and m.hysteresis_table()(373.15) == pytest.approx(0.02)
    # a steel: an elastic body without hysteresis or glass transition; an H(T) given is refused
    steel = library_material("steel").to_material()
    assert steel.hysteresis == NO_HYSTERESIS and steel.glass_transition_C is None
    assert steel.youngs_modulus_Pa == 206e9 and steel.hysteresis_table()(500.0) == 0.0
    with pytest.raises(ParameterError, match=r"^material\.hysteresis = .*without hysteresis"):
        library_material("steel").to_material(hysteresis=((20.0, 100.0), (0.01, 0.02)))
    # the library's PEEK 450G is the solvers' default material, H(T) by its shipped name
    assert library_material("PEEK 450G").to_material() == Material()


def test_a_case_file_selects_library_materials_by_name():
    """``[material] name`` selects the library's constants (the table's keys override them, per
    gear); a name not in the library, a steel given H(T) and a polymer without H(T) are errors
    naming the key, the value and what is allowed. A steel is a material of the case."""
    pa66 = library_material("PA66")
    h = [[20.0, 100.0], [0.01, 0.05]]
    case = case_from_dict(
        {
            "material": {"name": "nylon 66", "hysteresis": h, "youngs_modulus_Pa": 2.0e9},
            "material_wheel": {"name": "peek"},
        }
    )
    pinion, wheel = case.materials["pinion"], case.materials["wheel"]
    assert pinion.name == "PA66" and pinion.youngs_modulus_Pa == 2.0e9
    for key in ("density_kg_m3", "thermal_conductivity_W_mK", "specific_heat_J_kgK", "emissivity"):
        assert getattr(pinion, key) == pa66.value(key), key
    assert pinion.glass_transition_C == pa66.value("glass_transition_C")
    assert pinion.hysteresis_table()(373.15) == pytest.approx(0.05)
    assert wheel == Material() and load_case().material == Material()
    # a written case reads back as the same case (its name selects, its values override)
    assert case_from_dict(case_to_dict(case)) == case
    # without a name the constants are typed (defaults PEEK 450G's)
    typed = case_from_dict({"material": {"youngs_modulus_Pa": 3.5e9}})
    assert typed.material == Material(youngs_modulus_Pa=3.5e9)
    with pytest.raises(ParameterError) as err:
        case_from_dict({"material_wheel": {"name": "my PEEK"}})
    msg = str(err.value)
    assert msg.startswith("material_wheel.name = 'my PEEK' is not allowed")
    assert all(repr(n) in msg for n in NAMES) and "top-level name" in msg
    steel = case_from_dict({"material": {"name": "steel"}, "material_wheel": {"name": "peek"}})
    assert steel.material == library_material("steel").to_material()
    assert steel.material.glass_transition_C is None  # not the default's 143 C
    with pytest.raises(ParameterError, match=r"^material_wheel\.hysteresis = .*without hyst"):
        case_from_dict({"material_wheel": {"name": "steel", "hysteresis": h}})
    with pytest.raises(ParameterError, match=r"^material_wheel\.hysteresis = None .*POM"):
        case_from_dict({"material_wheel": {"name": "POM"}})


GOOD = """# test material
name = "X"
kind = "steel"
grade = "g"
summary = "s"
[sources]
a = "a citation of some length"
[values.density_kg_m3]
value = 1.0
source = "a"
uncertainty_rel = 0.1
"""


@pytest.mark.parametrize(
    "extra, match",
    [
        ("", r"values = \['youngs_modulus_Pa'"),  # required values missing
        ('[values.foo_m]\nvalue = 1.0\nsource = "a"\nuncertainty_rel = 0.1\n', "unknown value"),
        ('[values.emissivity]\nvalue = 0.5\nsource = "b"\nuncertainty_rel = 0.1\n', "source"),
        ('[values.emissivity]\nvalue = 0.5\nsource = "a"\n', "exactly one of range"),
        ('[values.emissivity]\nvalue = 0.5\nsource = "a"\nrange = [0.6, 0.7]\n', "lo <= 0.5"),
        (
            '[values.emissivity]\nvalue = 0.5\nsource = "a"\nestimate = true\n'
            "uncertainty_abs = 0.1\n",
            "reason",
        ),
    ],
)
def test_bad_library_files_are_refused(extra, match):
    with pytest.raises(ParameterError, match=match):
        parse_material(GOOD + extra, "test.toml")


def test_a_listed_source_that_no_value_cites_is_refused():
    rest = (
        "youngs_modulus_Pa",
        "poissons_ratio",
        "thermal_conductivity_W_mK",
        "specific_heat_J_kgK",
        "emissivity",
        "max_service_temperature_C",
    )
    text = GOOD + "".join(
        f'[values.{k}]\nvalue = 0.3\nsource = "a"\nuncertainty_rel = 0.1\n' for k in rest
    )
    assert parse_material(text, "test.toml").name == "X"
    unused = text.replace("[sources]\n", '[sources]\nb = "a source nothing cites"\n')
    with pytest.raises(ParameterError, match=r"test\.toml: sources = \['b'\]"):
        parse_material(unused, "test.toml")


def test_a_run_hotter_than_its_polymer_is_said_so():
    """``gearfem run`` notes the thermal body's hottest surface above its polymer's maximum service
    temperature and VDI 2736's flank temperature above its melting temperature, from the library
    (POM: 90 C and 166 C); nothing within them, nothing for a steel gear."""
    from gearfem.cli import material_limit_notes

    pom = case_from_dict(
        {
            "material": {"name": "steel"},
            "material_wheel": {"name": "POM", "hysteresis": [[20.0, 150.0], [0.02, 0.06]]},
            "thermal": {"body": "wheel"},
        }
    )
    assert material_limit_notes(pom, 89.0, 165.0) == []
    assert material_limit_notes(pom, None, None) == []
    hot = material_limit_notes(pom, 122.7, 206.1)
    assert len(hot) == 2
    assert "122.7 C" in hot[0] and "POM's maximum service temperature, 90 C" in hot[0]
    assert "206.1 C" in hot[1] and "melting temperature, 166 C" in hot[1]
    steel = dataclasses.replace(pom, thermal=dataclasses.replace(pom.thermal, body="pinion"))
    assert material_limit_notes(steel, 500.0, None) == []
