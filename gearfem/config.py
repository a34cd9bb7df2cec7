"""The case: one validated configuration for the whole chain, read from and written to TOML.

A case file has one table per stage, each a frozen dataclass of the module that owns it::

    name = "thesis bench 1000 rpm 8 Nm"
    [geometry]       # gearfem.geometry.involute.GearPairGeometry (mm, degrees)
    [mesh]           # gearfem.geometry.options.MeshOptions: the structural (contact) mesh
    [thermal_mesh]   # MeshOptions of the thermal model's own mesh (absent: the [mesh] table)
    [material]       # gearfem.core.materials.Material (both gears; [material_wheel] overrides
                     # the wheel). name = "POM" selects the library's constants
                     # (gearfem/data/materials, docs/materials.md), the table's other keys
                     # override them (modulus_table the library's E(T)); a name not in the
                     # library is an error (free text goes in the case's top-level name)
    [contact]        # gearfem.contact.options.ContactOptions (friction_coefficient = 0.5)
    [friction]       # gearfem.contact.friction.FrictionOptions: the friction law of the heat
                     # sources (default: the contact's constant mu)
    [cycle]          # gearfem.cycle.options.CycleOptions
    [operating]      # OperatingPoint: speed_rpm (pinion), torque_Nm (resisting torque, wheel)
    [sources]        # gearfem.coupling.options.SourceOptions
    [thermal]        # gearfem.thermal.options.ThermalOptions (duration_s, convection, ...)
    [baselines]      # gearfem.baselines.BaselineOptions
    [instruments]    # gearfem.instruments.options.InstrumentOptions: [instruments.camera] (default:
                     # the bench's FLIR E40), [instruments.probes.NAME], [instruments.torque]

Every table and key is optional; missing ones take the defaults, which are the thesis case
(Doll 2015: PEEK 450G 30/30 teeth, m = 2 mm, 30°, bench point 1000 rpm / 8 N·m). Unknown keys and
bad values raise :class:`~gearfem.core.errors.ParameterError` naming the key, value and allowed
range.
"""

from __future__ import annotations

import dataclasses
import tomllib
from pathlib import Path
from typing import Any

import tomli_w

from gearfem.baselines import BaselineOptions
from gearfem.contact.friction import FrictionOptions
from gearfem.contact.options import ContactOptions
from gearfem.core.errors import ParameterError
from gearfem.core.material_library import library_material
from gearfem.core.materials import Material, data_text
from gearfem.core.params import from_dict, require_nonnegative, require_positive, to_dict
from gearfem.coupling.options import REMOVED_KEYS, SourceOptions
from gearfem.cycle.options import CycleOptions
from gearfem.geometry.involute import GearPairGeometry
from gearfem.geometry.options import MeshOptions
from gearfem.instruments.options import InstrumentOptions
from gearfem.thermal.options import ThermalOptions


@dataclasses.dataclass(frozen=True)
class OperatingPoint:
    """``[operating]``: pinion speed and the resisting torque on the wheel.

    Args:
        speed_rpm: Speed of the pinion (rpm).
        torque_Nm: Resisting torque on the wheel (N m).
    """

    speed_rpm: float = 1000.0
    torque_Nm: float = 8.0

    def __post_init__(self) -> None:
        require_nonnegative("operating.speed_rpm", self.speed_rpm)
        require_positive("operating.torque_Nm", self.torque_Nm)


def _thesis_contact() -> ContactOptions:
    return ContactOptions(friction_coefficient=0.5)


@dataclasses.dataclass(frozen=True)
class Case:
    """Everything one gearfem run needs (see the module docstring).

    Args:
        name: The case's name, free text (written into the results).
    """

    name: str = "thesis"
    geometry: GearPairGeometry = dataclasses.field(default_factory=GearPairGeometry)
    mesh: MeshOptions = dataclasses.field(default_factory=MeshOptions)
    thermal_mesh: MeshOptions | None = None
    material: Material = dataclasses.field(default_factory=Material)
    material_wheel: Material | None = None
    contact: ContactOptions = dataclasses.field(default_factory=_thesis_contact)
    friction: FrictionOptions = dataclasses.field(default_factory=FrictionOptions)
    cycle: CycleOptions = dataclasses.field(default_factory=CycleOptions)
    operating: OperatingPoint = dataclasses.field(default_factory=OperatingPoint)
    sources: SourceOptions = dataclasses.field(default_factory=SourceOptions)
    thermal: ThermalOptions = dataclasses.field(default_factory=ThermalOptions)
    baselines: BaselineOptions = dataclasses.field(default_factory=BaselineOptions)
    instruments: InstrumentOptions = dataclasses.field(default_factory=InstrumentOptions)

    def __post_init__(self) -> None:
        f = self.friction
        if f.law == "glass_transition" and f.glass_transition_C is None:
            # the step sits at the gears' polymer's T_g (PEEK 450G: the DMA's 143 C)
            tg = self._polymer_glass_transition_C()
            object.__setattr__(self, "friction", dataclasses.replace(f, glass_transition_C=tg))
        if f.cycle_mu != "constant":
            if self.sources.mode != "cycle" or not self.sources.friction:
                raise ParameterError(
                    "friction.cycle_mu",
                    f.cycle_mu,
                    "'constant' unless [sources] mode = 'cycle' with friction heat",
                    "the law's mu is put into the structural cycle's friction",
                )
            if not self.instruments.torque.enabled:
                raise ParameterError(
                    "friction.cycle_mu",
                    f.cycle_mu,
                    "'constant' unless [instruments.torque] is enabled",
                    "the law's effective mu is what the torque meters read of both gears' heat",
                )
        # a gear's own E(T) is read by the cycle with modulus = "thermal_state" only
        for key, mat in (("material", self.material), ("material_wheel", self.material_wheel)):
            if (
                mat is not None
                and mat.modulus_table is not None
                and self.cycle.modulus != ("thermal_state")
            ):
                raise ParameterError(
                    f"{key}.modulus_table",
                    mat.modulus_table,
                    "none unless [cycle] modulus = 'thermal_state'",
                    f"with modulus = {self.cycle.modulus!r} the cycle runs at the constant "
                    "youngs_modulus_Pa and would leave the table unread",
                )
        # the friction law resolved against the cycle's mu (mu within [0, 2] everywhere)
        self.friction_law()

    def _polymer_glass_transition_C(self) -> float:
        """The glass transition of the pair's polymer (the gears' T_g where they have one);
        ParameterError naming ``friction.glass_transition_C`` when the gears have none or
        differ."""
        tgs = {m.glass_transition_C for m in self.materials.values()} - {None}
        if len(tgs) != 1:
            raise ParameterError(
                "friction.glass_transition_C",
                None,
                "a temperature in C for law 'glass_transition'",
                "the gears' materials give "
                + (
                    "no glass transition"
                    if not tgs
                    else "several: " + ", ".join(f"{t:g} C" for t in sorted(tgs))
                )
                + " to take it from",
            )
        return float(tgs.pop())

    def friction_law(self):
        """The ``[friction]`` law with the contact's friction coefficient as its default mu."""
        return self.friction.law_for(self.contact.friction_coefficient)

    @property
    def thermal_mesh_options(self) -> MeshOptions:
        """The thermal model's mesh: ``[thermal_mesh]`` if given, else the structural ``[mesh]``.
        The heat sources are carried from the structural mesh conservatively whatever the pair."""
        return self.thermal_mesh if self.thermal_mesh is not None else self.mesh

    @property
    def materials(self) -> dict[str, Material]:
        return {"pinion": self.material, "wheel": self.material_wheel or self.material}

    def with_operating(
        self, speed_rpm: float | None = None, torque_Nm: float | None = None
    ) -> Case:
        op = dataclasses.replace(
            self.operating,
            **{
                k: v
                for k, v in (("speed_rpm", speed_rpm), ("torque_Nm", torque_Nm))
                if v is not None
            },
        )
        return dataclasses.replace(self, operating=op)


#: The case tables that hold a :class:`Material`.
MATERIAL_TABLES = ("material", "material_wheel")


def _library_materials(data: dict[str, Any]) -> dict[str, Any]:
    """``data`` with each material table that names a material started from the library's
    constants (canonical name; the table's own keys override them). An unknown name raises
    ParameterError naming the table's ``name``, the value and the library's names; a polymer
    without an H(T) table when the table gives none, or a steel given one, raises on the table's
    ``hysteresis``; a steel given an E(T) raises on its ``modulus_table`` (a steel gear keeps its
    constant modulus)."""
    out = dict(data)
    for key in MATERIAL_TABLES:
        table = data.get(key)
        if not isinstance(table, dict) or "name" not in table:
            continue
        try:
            lib = library_material(table["name"], f"{key}.name")
        except ParameterError as err:
            raise ParameterError(
                err.name,
                err.value,
                err.allowed,
                f"{err.reason}; free text describing the case goes in its top-level name",
            ) from err
        if lib.kind == "steel" and table.get("modulus_table") is not None:
            raise ParameterError(
                f"{key}.modulus_table",
                table["modulus_table"],
                "none",
                f"{lib.name} keeps its constant youngs_modulus_Pa",
            )
        hysteresis = table.get("hysteresis")
        if isinstance(hysteresis, list):
            hysteresis = tuple(tuple(row) for row in hysteresis)
        mat = lib.to_material(hysteresis=hysteresis, parameter=f"{key}.name")
        # every field, None included (to_dict drops it): a steel's glass_transition_C is None,
        # not the default's 143 C
        base = {f.name: getattr(mat, f.name) for f in dataclasses.fields(mat)}
        out[key] = base | {k: v for k, v in table.items() if k != "name"}
    return out


def case_from_dict(data: dict[str, Any]) -> Case:
    data = _library_materials(data)
    for key, replacement in REMOVED_KEYS.items():
        if isinstance(data.get("sources"), dict) and key in data["sources"]:
            raise ParameterError(
                f"sources.{key}",
                data["sources"][key],
                f"removed: use {replacement}",
                "mu(T) is a friction law now (docs/friction.md)",
            )
    return from_dict(Case, data)


def load_case(path: str | Path | None = None) -> Case:
    """Read a case TOML (``None``: the built-in thesis case)."""
    if path is None:
        return case_from_dict(tomllib.loads(data_text("thesis_case.toml")))
    return case_from_dict(read_toml(path, "case file"))


def read_toml(path: str | Path, what: str) -> dict[str, Any]:
    """The table of a TOML file; a missing or malformed file raises ParameterError naming
    ``what``."""
    path = Path(path)
    if not path.is_file():
        raise ParameterError(what, str(path), "an existing TOML file")
    try:
        return tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as err:
        raise ParameterError(what, str(path), "valid TOML", str(err)) from err


def case_to_dict(case: Case) -> dict[str, Any]:
    return to_dict(case)


def write_case(case: Case, path: str | Path) -> Path:
    """Write the resolved case (every value, defaults included) as TOML."""
    path = Path(path)
    path.write_text(tomli_w.dumps(case_to_dict(case)))
    return path
