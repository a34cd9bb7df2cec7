"""The materials library: shipped constants of gear materials, each with its source and uncertainty.

One TOML file per material in ``gearfem/data/materials/`` (PEEK 450G, POM, PA66, steel; format
and tables in docs/materials.md). Every value carries

* its unit, in the key's name (``density_kg_m3``, ``youngs_modulus_Pa``, ``glass_transition_C``,
  ...; ``poissons_ratio``, ``emissivity`` and ``friction_*`` are dimensionless),
* ``source``: a key of the file's ``[sources]`` table, the citation (datasheet and grade, book
  table, paper, thesis section) with where a stored copy is; ``also``: sources behind the range,
* exactly one uncertainty: ``range = [lo, hi]`` (the spread between sources, which may end at the
  value itself), ``uncertainty_rel`` or ``uncertainty_abs``,
* ``estimate = true`` and a one-line ``reason`` when no stored source confirms the value.

Temperature tables (``[tables.NAME]``: ``T_C``, ``values``, ``unit``, ``source``) hold what a
material has of H(T) = E''/|E*| (``hysteresis``) and E(T) (``youngs_modulus_Pa``,
``storage_modulus_Pa``, ``loss_modulus_Pa``, ``tan_delta``).

Look-up: :func:`library_material` matches a name case-insensitively and ignoring spaces, ``-``,
``_``, ``.`` and ``/``, against each material's name and its ``aliases`` (``"PEEK"``,
``"nylon 66"``, ``"16MnCr5"``, ...; ``"Delrin"`` is not one: the POM data are of a copolymer, Delrin
is a homopolymer). An unknown name raises :class:`~gearfem.core.errors.ParameterError` naming the
parameter, the name given and the library's names.

Numbers for the diagnosis: :func:`input_uncertainties` (each value's interval, keys with units) and
the Blok heat partition by thermal effusivity, :func:`effusivity_partition` and its interval
:func:`effusivity_partition_range`.

In a case file, ``[material] name`` selects a material of this library (gearfem.config: the
table's other keys override its values; an unknown name is the error above); a steel is an
elastic body without hysteresis. A polymer's ``youngs_modulus_Pa`` table is the E(T) that
``[cycle] modulus = "thermal_state"`` gives the cycle unless the case's ``[material]`` /
``[material_wheel]`` ``modulus_table`` gives its own (gearfem.pipeline.modulus_tables).
Pure Python and numpy (tomllib); no DOLFINx.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import tomllib
from functools import cache
from importlib import resources
from typing import Any

from gearfem.core.errors import ParameterError
from gearfem.core.materials import (
    NO_HYSTERESIS,
    Material,
    TemperatureTable,
    peek450g_hysteresis,
)

#: Value keys a library file may hold, with their units (SI; temperatures in deg C).
VALUE_UNITS: dict[str, str] = {
    "density_kg_m3": "kg/m^3",
    "youngs_modulus_Pa": "Pa",
    "youngs_modulus_conditioned_Pa": "Pa",
    "poissons_ratio": "1",
    "thermal_conductivity_W_mK": "W/(m K)",
    "specific_heat_J_kgK": "J/(kg K)",
    "thermal_expansion_1_K": "1/K",
    "emissivity": "1",
    "glass_transition_C": "degC",
    "melting_C": "degC",
    "max_service_temperature_C": "degC",
    "friction_against_self": "1",
    "friction_against_steel": "1",
}
#: Values every material must have (polymers also ``glass_transition_C`` and ``melting_C``).
REQUIRED_VALUES = (
    "density_kg_m3",
    "youngs_modulus_Pa",
    "poissons_ratio",
    "thermal_conductivity_W_mK",
    "specific_heat_J_kgK",
    "emissivity",
    "max_service_temperature_C",
)
POLYMER_VALUES = ("glass_transition_C", "melting_C")
#: Temperature tables a library file may hold, with their units.
TABLE_UNITS: dict[str, str] = {
    "hysteresis": "1",
    "youngs_modulus_Pa": "Pa",
    "storage_modulus_Pa": "Pa",
    "loss_modulus_Pa": "Pa",
    "tan_delta": "1",
}
KINDS = ("polymer", "steel")
_VALUE_KEYS = {"value", "source", "also", "range", "uncertainty_rel", "uncertainty_abs"} | {
    "estimate",
    "reason",
    "note",
}
_TABLE_KEYS = {"quantity", "unit", "source", "T_C", "values", "estimate", "reason", "note"}
_TOP_KEYS = {"name", "aliases", "kind", "grade", "state", "summary", "sources", "values", "tables"}


@dataclasses.dataclass(frozen=True)
class SourcedValue:
    """One constant of a library material.

    Attributes:
        name: The key, unit included (``"density_kg_m3"``).
        value: The value in that unit.
        unit: The unit spelt out (``"kg/m^3"``, ``"1"`` for dimensionless).
        source: The citation (from the file's ``[sources]``); ``source_key`` is its key there.
        uncertainty_rel, uncertainty_abs, range: Exactly one is set (see :meth:`interval`).
        also: Keys of further sources behind the range.
        estimate: True when no stored source confirms the value; ``reason`` says why it is used.
        note: Free text (conditions of the measurement, other sources' numbers).
    """

    name: str
    value: float
    unit: str
    source: str
    source_key: str
    uncertainty_rel: float | None = None
    uncertainty_abs: float | None = None
    range: tuple[float, float] | None = None
    also: tuple[str, ...] = ()
    estimate: bool = False
    reason: str = ""
    note: str = ""

    def interval(self) -> tuple[float, float]:
        """The input-uncertainty interval (lo, hi): the range, value (1 -+ rel), or value -+ abs.
        lo <= value <= hi and lo < hi."""
        if self.range is not None:
            return self.range
        if self.uncertainty_rel is not None:
            d = abs(self.value) * self.uncertainty_rel
        else:
            d = float(self.uncertainty_abs)  # type: ignore[arg-type]
        return (self.value - d, self.value + d)


@dataclasses.dataclass(frozen=True)
class SourcedTable:
    """A temperature table of a library material (``T_C`` increasing, ``values`` in ``unit``)."""

    name: str
    quantity: str
    unit: str
    T_C: tuple[float, ...]
    values: tuple[float, ...]
    source: str
    source_key: str
    estimate: bool = False
    reason: str = ""
    note: str = ""

    def table(self) -> TemperatureTable:
        """The table as a :class:`TemperatureTable` (kelvin, piecewise linear)."""
        return TemperatureTable.from_celsius(self.T_C, self.values, self.name)


@dataclasses.dataclass(frozen=True)
class LibraryMaterial:
    """A material of the library: its constants, tables and sources (see the module docstring).

    ``material["density_kg_m3"]`` is the :class:`SourcedValue`, ``material.value(key)`` its number.
    """

    name: str
    kind: str
    grade: str
    summary: str
    aliases: tuple[str, ...]
    values: dict[str, SourcedValue]
    tables: dict[str, SourcedTable]
    sources: dict[str, str]
    state: str = ""
    file: str = ""

    def __getitem__(self, key: str) -> SourcedValue:
        if key not in self.values:
            raise ParameterError(
                f"{self.name} value", key, "one of " + ", ".join(sorted(self.values))
            )
        return self.values[key]

    def value(self, key: str) -> float:
        return self[key].value

    def estimates(self) -> list[SourcedValue]:
        """The values marked ``estimate = true``."""
        return [v for v in self.values.values() if v.estimate]

    @property
    def effusivity_W_s05_m2K(self) -> float:
        """b = sqrt(k rho c_p) at the library values, W s^0.5 / (m^2 K) (thesis eq. 2.2)."""
        return effusivity(self)

    def to_material(
        self,
        hysteresis: str | tuple[tuple[float, ...], tuple[float, ...]] | None = None,
        parameter: str = "material.name",
    ) -> Material:
        """The :class:`~gearfem.core.materials.Material` of these constants (the solvers'
        material). A polymer takes the library's H(T) table or ``hysteresis`` (``"peek450g"`` or
        [[T_C...], [H...]]); the library's PEEK 450G table is the thesis's, so it comes out as
        ``"peek450g"``: ``library_material("PEEK 450G").to_material() == Material()``. A steel is
        an elastic body without hysteresis (``NO_HYSTERESIS``) and without a glass transition;
        ``hysteresis`` may not be given for it.

        Raises ParameterError naming the table's ``hysteresis`` for a polymer without an H(T)
        table when none is given, and for an H(T) table given to a steel.
        """
        table = parameter.rpartition(".")[0] or "material"
        if self.kind == "steel":
            if hysteresis is not None and hysteresis != NO_HYSTERESIS:
                raise ParameterError(
                    f"{table}.hysteresis",
                    hysteresis,
                    f"none (or '{NO_HYSTERESIS}')",
                    f"{self.name} is modelled without hysteresis",
                )
            hysteresis, glass_transition_C = NO_HYSTERESIS, None
        else:
            glass_transition_C = self.value("glass_transition_C")
        if hysteresis is None:
            if "hysteresis" not in self.tables:
                raise ParameterError(
                    f"{table}.hysteresis",
                    None,
                    "an H(T) table [[T_C...], [H...]]",
                    f"the library has no loss data for {self.name}: give the table in "
                    f"[{table}] with its source",
                )
            t = self.tables["hysteresis"]
            hysteresis = (t.T_C, t.values)
            own, shipped = t.table(), peek450g_hysteresis()
            if (own.T_K, own.values) == (shipped.T_K, shipped.values):
                hysteresis = "peek450g"
        return Material(
            name=self.name,
            density_kg_m3=self.value("density_kg_m3"),
            youngs_modulus_Pa=self.value("youngs_modulus_Pa"),
            poissons_ratio=self.value("poissons_ratio"),
            thermal_conductivity_W_mK=self.value("thermal_conductivity_W_mK"),
            specific_heat_J_kgK=self.value("specific_heat_J_kgK"),
            emissivity=self.value("emissivity"),
            glass_transition_C=glass_transition_C,
            hysteresis=hysteresis,
        )


# ------------------------------------------------------------------------------------------------
# reading the files
# ------------------------------------------------------------------------------------------------


def _fail(where: str, value: Any, allowed: str, reason: str = "") -> None:
    raise ParameterError(where, value, allowed, reason)


def _normalise(name: str) -> str:
    return "".join(c for c in str(name).lower() if c not in " \t-_./")


def _number(where: str, x: Any) -> float:
    if isinstance(x, bool) or not isinstance(x, int | float) or not math.isfinite(x):
        _fail(where, x, "a finite number")
    return float(x)


def _value(file: str, key: str, d: dict[str, Any], sources: dict[str, str]) -> SourcedValue:
    where = f"{file}: values.{key}"
    if key not in VALUE_UNITS:
        _fail(where, key, "one of " + ", ".join(VALUE_UNITS), "unknown value key")
    unknown = set(d) - _VALUE_KEYS
    if unknown:
        _fail(where, sorted(unknown), "keys " + ", ".join(sorted(_VALUE_KEYS)))
    value = _number(f"{where}.value", d.get("value"))
    src = d.get("source")
    if src not in sources:
        _fail(f"{where}.source", src, "a key of [sources]: " + ", ".join(sources))
    also = tuple(d.get("also", ()))
    for a in also:
        if a not in sources:
            _fail(f"{where}.also", a, "keys of [sources]: " + ", ".join(sources))
    estimate = d.get("estimate", False)
    if not isinstance(estimate, bool):
        _fail(f"{where}.estimate", estimate, "true or false")
    reason = str(d.get("reason", "")).strip()
    if estimate and not reason:
        _fail(f"{where}.reason", reason, "a one-line reason", "an estimate says why it is used")
    given = [k for k in ("range", "uncertainty_rel", "uncertainty_abs") if k in d]
    if len(given) != 1:
        _fail(where, given, "exactly one of range, uncertainty_rel, uncertainty_abs")
    rng = rel = ab = None
    if "range" in d:
        r = d["range"]
        if not isinstance(r, list) or len(r) != 2:
            _fail(f"{where}.range", r, "[lo, hi]")
        lo, hi = (_number(f"{where}.range", x) for x in r)
        if not lo <= value <= hi or not lo < hi:
            _fail(f"{where}.range", r, f"lo <= {value:g} <= hi with lo < hi")
        rng = (lo, hi)
    elif "uncertainty_rel" in d:
        rel = _number(f"{where}.uncertainty_rel", d["uncertainty_rel"])
        if not 0 < rel < 1 or value == 0:
            _fail(f"{where}.uncertainty_rel", rel, "(0, 1) of a nonzero value")
    else:
        ab = _number(f"{where}.uncertainty_abs", d["uncertainty_abs"])
        if ab <= 0:
            _fail(f"{where}.uncertainty_abs", ab, "> 0")
    return SourcedValue(
        name=key,
        value=value,
        unit=VALUE_UNITS[key],
        source=sources[src],
        source_key=src,
        uncertainty_rel=rel,
        uncertainty_abs=ab,
        range=rng,
        also=also,
        estimate=estimate,
        reason=reason,
        note=str(d.get("note", "")).strip(),
    )


def _table(file: str, key: str, d: dict[str, Any], sources: dict[str, str]) -> SourcedTable:
    where = f"{file}: tables.{key}"
    if key not in TABLE_UNITS:
        _fail(where, key, "one of " + ", ".join(TABLE_UNITS), "unknown table")
    unknown = set(d) - _TABLE_KEYS
    if unknown:
        _fail(where, sorted(unknown), "keys " + ", ".join(sorted(_TABLE_KEYS)))
    if d.get("unit") != TABLE_UNITS[key]:
        _fail(f"{where}.unit", d.get("unit"), repr(TABLE_UNITS[key]))
    src = d.get("source")
    if src not in sources:
        _fail(f"{where}.source", src, "a key of [sources]: " + ", ".join(sources))
    T = tuple(_number(f"{where}.T_C", x) for x in d.get("T_C", ()))
    v = tuple(_number(f"{where}.values", x) for x in d.get("values", ()))
    if len(T) < 2 or len(T) != len(v) or any(b <= a for a, b in itertools.pairwise(T)):
        _fail(f"{where}.T_C", T, "at least 2 increasing temperatures, one value each")
    estimate = bool(d.get("estimate", False))
    reason = str(d.get("reason", "")).strip()
    if estimate and not reason:
        _fail(f"{where}.reason", reason, "a one-line reason", "an estimate says why it is used")
    return SourcedTable(
        name=key,
        quantity=str(d.get("quantity", "")),
        unit=TABLE_UNITS[key],
        T_C=T,
        values=v,
        source=sources[src],
        source_key=src,
        estimate=estimate,
        reason=reason,
        note=str(d.get("note", "")).strip(),
    )


def parse_material(text: str, file: str = "<text>") -> LibraryMaterial:
    """A :class:`LibraryMaterial` from the text of a library file, validated: known keys with
    units, a source per value and table, one uncertainty per value, a reason per estimate, every
    listed source used. Raises :class:`~gearfem.core.errors.ParameterError` naming the file and
    key."""
    d = tomllib.loads(text)
    unknown = set(d) - _TOP_KEYS
    if unknown:
        _fail(file, sorted(unknown), "top-level keys " + ", ".join(sorted(_TOP_KEYS)))
    for key in ("name", "kind", "grade", "summary"):
        if not isinstance(d.get(key), str) or not d[key].strip():
            _fail(f"{file}: {key}", d.get(key), "a non-empty string")
    if d["kind"] not in KINDS:
        _fail(f"{file}: kind", d["kind"], " or ".join(KINDS))
    sources = {str(k): str(v).strip() for k, v in d.get("sources", {}).items()}
    if not sources or not all(sources.values()):
        _fail(f"{file}: sources", sources, "a table of non-empty citations")
    values = {k: _value(file, k, v, sources) for k, v in d.get("values", {}).items()}
    required = REQUIRED_VALUES + (POLYMER_VALUES if d["kind"] == "polymer" else ())
    missing = [k for k in required if k not in values]
    if missing:
        _fail(f"{file}: values", missing, "present", f"a {d['kind']} needs {', '.join(required)}")
    tables = {k: _table(file, k, v, sources) for k, v in d.get("tables", {}).items()}
    used = {v.source_key for v in values.values()} | {t.source_key for t in tables.values()}
    used |= {a for v in values.values() for a in v.also}
    unused = sorted(set(sources) - used)
    if unused:
        _fail(f"{file}: sources", unused, "only sources that a value or table cites")
    return LibraryMaterial(
        name=d["name"],
        kind=d["kind"],
        grade=d["grade"],
        summary=d["summary"],
        aliases=tuple(str(a) for a in d.get("aliases", ())),
        values=values,
        tables=tables,
        sources=sources,
        state=str(d.get("state", "")),
        file=file,
    )


def _library_dir():
    return resources.files("gearfem").joinpath("data", "materials")


@cache
def _library() -> dict[str, LibraryMaterial]:
    """Every library material by its normalised name and aliases."""
    out: dict[str, LibraryMaterial] = {}
    files = sorted(
        (f for f in _library_dir().iterdir() if f.name.endswith(".toml")), key=lambda f: f.name
    )
    for f in files:
        mat = parse_material(f.read_text(encoding="utf-8"), f"data/materials/{f.name}")
        for label in (mat.name, *mat.aliases):
            key = _normalise(label)
            if key in out and out[key].name != mat.name:
                _fail(f"data/materials/{f.name}: aliases", label, "a name no other material uses")
            out[key] = mat
    return out


def library_names() -> tuple[str, ...]:
    """The names of the library's materials (``("PA66", "PEEK 450G", "POM", "steel")``)."""
    return tuple(sorted({m.name for m in _library().values()}, key=str.lower))


def library_material(name: str, parameter: str = "material.name") -> LibraryMaterial:
    """The library material called ``name`` (or one of its aliases; case, spaces, ``-``, ``_``,
    ``.`` and ``/`` ignored). ``parameter`` is how the caller's user wrote the name, for the error:
    an unknown name raises :class:`~gearfem.core.errors.ParameterError` naming ``parameter``, the
    name given and the library's names."""
    lib = _library()
    mat = lib.get(_normalise(name)) if isinstance(name, str) else None
    if mat is None:
        raise ParameterError(
            parameter,
            name,
            "one of " + ", ".join(repr(n) for n in library_names()) + " (or an alias of one)",
            "not a material of the library gearfem/data/materials/ (docs/materials.md)",
        )
    return mat


def _as_material(m: LibraryMaterial | str) -> LibraryMaterial:
    return m if isinstance(m, LibraryMaterial) else library_material(m)


# ------------------------------------------------------------------------------------------------
# numbers for the diagnosis and the heat partition
# ------------------------------------------------------------------------------------------------


def input_uncertainties(material: LibraryMaterial | str) -> dict[str, tuple[float, float]]:
    """Each value's input-uncertainty interval (lo, hi), keyed by the value's name (units in the
    key), for the diagnosis's input uncertainty (:meth:`SourcedValue.interval`)."""
    mat = _as_material(material)
    return {k: v.interval() for k, v in mat.values.items()}


def effusivity(material: LibraryMaterial | str) -> float:
    """Thermal effusivity b = sqrt(k rho c_p), W s^0.5 / (m^2 K) (thesis eq. 2.2), at the library
    values."""
    m = _as_material(material)
    return math.sqrt(
        m.value("thermal_conductivity_W_mK")
        * m.value("density_kg_m3")
        * m.value("specific_heat_J_kgK")
    )


def _partition(b1: float, b2: float, v1: float | None, v2: float | None) -> float:
    if (v1 is None) != (v2 is None):
        raise ParameterError("speed2_m_s" if v2 is None else "speed1_m_s", None, "both or none")
    if v1 is not None:
        for name, v in (("speed1_m_s", v1), ("speed2_m_s", v2)):
            if not isinstance(v, int | float) or not math.isfinite(v) or v <= 0:
                raise ParameterError(name, v, "> 0 m/s")
        b1, b2 = b1 * math.sqrt(v1), b2 * math.sqrt(v2)  # type: ignore[arg-type]
    return b1 / (b1 + b2)


def effusivity_partition(
    material1: LibraryMaterial | str,
    material2: LibraryMaterial | str,
    speed1_m_s: float | None = None,
    speed2_m_s: float | None = None,
) -> float:
    """Fraction of the contact's friction heat that flows into body 1 (Blok).

    Without speeds: f1 = b1 / (b1 + b2), b = sqrt(k rho c_p) the effusivity (thesis eq. 2.2):
    two semi-infinite bodies in perfect contact for the same time take heat in proportion to
    their effusivities, so that both surfaces reach the same temperature (Blok's postulate;
    gearfem's default split, :meth:`gearfem.coupling.options.SourceOptions.heat_fractions`). 1/2
    for equal materials.

    With the speeds at which the contact moves over each surface (rolling speeds, m/s), Blok's
    high-Peclet split of a moving band source: f1 = b1 sqrt(v1) / (b1 sqrt(v1) + b2 sqrt(v2)) (the
    partition behind :func:`gearfem.baselines.blok_flash_temperature_K`).
    """
    return _partition(effusivity(material1), effusivity(material2), speed1_m_s, speed2_m_s)


def effusivity_partition_range(
    material1: LibraryMaterial | str,
    material2: LibraryMaterial | str,
    speed1_m_s: float | None = None,
    speed2_m_s: float | None = None,
) -> tuple[float, float]:
    """The interval of :func:`effusivity_partition` over the input-uncertainty intervals of k,
    rho and c_p of both materials (f1 grows with b1 and falls with b2, and b with each of k, rho,
    c_p, so the ends are at the intervals' corners)."""
    m1, m2 = _as_material(material1), _as_material(material2)

    def b(m: LibraryMaterial, end: int) -> float:
        keys = ("thermal_conductivity_W_mK", "density_kg_m3", "specific_heat_J_kgK")
        return math.sqrt(math.prod(m[k].interval()[end] for k in keys))

    lo = _partition(b(m1, 0), b(m2, 1), speed1_m_s, speed2_m_s)
    hi = _partition(b(m1, 1), b(m2, 0), speed1_m_s, speed2_m_s)
    return lo, hi


__all__ = [
    "KINDS",
    "REQUIRED_VALUES",
    "TABLE_UNITS",
    "VALUE_UNITS",
    "LibraryMaterial",
    "SourcedTable",
    "SourcedValue",
    "effusivity",
    "effusivity_partition",
    "effusivity_partition_range",
    "input_uncertainties",
    "library_material",
    "library_names",
    "parse_material",
]
