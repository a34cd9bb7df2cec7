"""Materials: PEEK 450G and friends — elastic, thermal, hysteresis H(T), time-temperature shift.

SI units inside; temperatures in kelvin. The defaults are the values in the shipped
``gearfem/data/peek450g/`` files (from the project's reference data), each with its source there.
Temperature-dependent quantities are :class:`TemperatureTable` objects: piecewise linear in T,
constant beyond the table ends (documented, not silent: :meth:`TemperatureTable.covers` tells).
They evaluate on numpy arrays and build the same function as a UFL expression for the solvers.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import itertools
import math
import tomllib
from functools import cache
from importlib import resources
from typing import Any

import numpy as np

from gearfem.core.errors import ParameterError
from gearfem.core.params import interval, require_positive, require_range

ZERO_CELSIUS_K = 273.15
#: ``Material.hysteresis`` of a body without hysteresis (a steel gear): H(T) = 0.
NO_HYSTERESIS = "none"
GAS_CONSTANT_J_molK = 8.314462618
STEFAN_BOLTZMANN_W_m2K4 = 5.670374419e-8
#: The Young's moduli a material accepts (Pa): ``youngs_modulus_Pa``, each of ``modulus_table``.
MODULUS_RANGE_PA = (1e6, 1e12)


def celsius_to_kelvin(t_C: float | np.ndarray) -> float | np.ndarray:
    return np.asarray(t_C) + ZERO_CELSIUS_K if isinstance(t_C, np.ndarray) else t_C + ZERO_CELSIUS_K


def kelvin_to_celsius(t_K: float | np.ndarray) -> float | np.ndarray:
    return np.asarray(t_K) - ZERO_CELSIUS_K if isinstance(t_K, np.ndarray) else t_K - ZERO_CELSIUS_K


# ------------------------------------------------------------------------------------------------
# package data
# ------------------------------------------------------------------------------------------------


def data_text(*parts: str) -> str:
    """Text of a shipped data file, e.g. ``data_text("peek450g", "hysteresis.csv")``."""
    return resources.files("gearfem").joinpath("data", *parts).read_text(encoding="utf-8")


def read_csv(*parts: str) -> list[dict[str, str]]:
    """Rows of a shipped CSV file (lines starting with ``#`` are comments)."""
    lines = [
        ln
        for ln in data_text(*parts).splitlines()
        if ln.strip() and not ln.lstrip().startswith("#")
    ]
    return list(csv.DictReader(io.StringIO("\n".join(lines))))


@cache
def read_toml(*parts: str) -> dict[str, Any]:
    return tomllib.loads(data_text(*parts))


# ------------------------------------------------------------------------------------------------
# temperature tables
# ------------------------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class TemperatureTable:
    """Piecewise-linear function of temperature, constant outside ``[T_K[0], T_K[-1]]``.

    Args:
        T_K: Strictly increasing temperatures in kelvin.
        values: Function values (any unit, stated by the owner).
        name: What it is, for error messages.
    """

    T_K: tuple[float, ...]
    values: tuple[float, ...]
    name: str = "table"

    def __post_init__(self) -> None:
        if len(self.T_K) != len(self.values) or len(self.T_K) < 1:
            raise ParameterError(
                f"{self.name}.values",
                len(self.values),
                f"{len(self.T_K)} values, one per temperature",
            )
        if any(b <= a for a, b in zip(self.T_K, self.T_K[1:])):
            raise ParameterError(f"{self.name}.T_K", self.T_K, "strictly increasing temperatures")

    @classmethod
    def from_celsius(cls, T_C, values, name: str = "table") -> TemperatureTable:
        return cls(
            tuple(float(t) + ZERO_CELSIUS_K for t in T_C), tuple(float(v) for v in values), name
        )

    @classmethod
    def constant(cls, value: float, name: str = "constant") -> TemperatureTable:
        return cls((ZERO_CELSIUS_K,), (float(value),), name)

    def __call__(self, T_K: float | np.ndarray) -> float | np.ndarray:
        out = np.interp(T_K, self.T_K, self.values)
        return float(out) if np.ndim(out) == 0 else out

    def derivative(self, T_K: float | np.ndarray) -> float | np.ndarray:
        """dvalue/dT (per kelvin), zero outside the table; left-continuous at the nodes."""
        t = np.asarray(self.T_K)
        v = np.asarray(self.values)
        if len(t) == 1:
            return np.zeros_like(np.asarray(T_K, dtype=float)) if np.ndim(T_K) else 0.0
        slopes = np.diff(v) / np.diff(t)
        idx = np.clip(np.searchsorted(t, T_K, side="left") - 1, 0, len(slopes) - 1)
        out = np.where((np.asarray(T_K) > t[0]) & (np.asarray(T_K) <= t[-1]), slopes[idx], 0.0)
        return float(out) if np.ndim(out) == 0 else out

    def covers(self, T_K: float) -> bool:
        return self.T_K[0] <= T_K <= self.T_K[-1]

    @property
    def is_constant(self) -> bool:
        return len(set(self.values)) == 1


def peek450g_hysteresis() -> TemperatureTable:
    """H(T) = E''/|E*| of PEEK 450G at 100 Hz, 0.1 % strain (thesis appendix, Figure 49)."""
    rows = read_csv("peek450g", "hysteresis.csv")
    return TemperatureTable.from_celsius(
        [r["temperature_C"] for r in rows], [r["H"] for r in rows], "hysteresis H(T)"
    )


# ------------------------------------------------------------------------------------------------
# time-temperature superposition (thesis 3.1.2, gearfem/data/peek450g/viscoelastic.toml)
# ------------------------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class ShiftFactor:
    """WLF above ``switch_C`` and Arrhenius below: log10 a_T relative to ``T_ref_C`` of the WLF fit.

    WLF: log10 a_T = -C1 (T - Tref) / (C2 + T - Tref); Arrhenius (standard form, see the data file):
    log10 a_T = Ea / (ln(10) R) (1/T - 1/Tref_A). The Arrhenius branch is offset so the two join
    continuously at ``switch_C``.
    """

    wlf_C1: float = 24.476
    wlf_C2_K: float = 78.284
    wlf_T_ref_C: float = 150.0
    arrhenius_Ea_J_mol: float = 31984.0
    arrhenius_T_ref_C: float = 117.0
    switch_C: float = 140.0

    @classmethod
    def peek450g(cls) -> ShiftFactor:
        d = read_toml("peek450g", "viscoelastic.toml")
        return cls(
            wlf_C1=d["wlf"]["C1"],
            wlf_C2_K=d["wlf"]["C2_K"],
            wlf_T_ref_C=d["wlf"]["T_ref_C"],
            arrhenius_Ea_J_mol=d["arrhenius"]["activation_energy_J_per_mol"],
            arrhenius_T_ref_C=d["arrhenius"]["T_ref_C"],
            switch_C=d["wlf"]["valid_C"][0],
        )

    def _wlf(self, T_C):
        d = np.asarray(T_C, dtype=float) - self.wlf_T_ref_C
        return -self.wlf_C1 * d / (self.wlf_C2_K + d)

    def _arr(self, T_C):
        T = np.asarray(T_C, dtype=float) + ZERO_CELSIUS_K
        Tr = self.arrhenius_T_ref_C + ZERO_CELSIUS_K
        return (
            self.arrhenius_Ea_J_mol / (math.log(10.0) * GAS_CONSTANT_J_molK) * (1.0 / T - 1.0 / Tr)
        )

    def log10_aT(self, T_K: float | np.ndarray) -> float | np.ndarray:
        T_C = np.asarray(T_K, dtype=float) - ZERO_CELSIUS_K
        offset = self._wlf(self.switch_C) - self._arr(self.switch_C)
        out = np.where(
            self.switch_C <= T_C, self._wlf(np.maximum(T_C, self.switch_C)), self._arr(T_C) + offset
        )
        return float(out) if np.ndim(out) == 0 else out


# ------------------------------------------------------------------------------------------------
# the material
# ------------------------------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class Material:
    """Isotropic gear material: elastic, thermal and damping properties (SI).

    Defaults: PEEK 450G from ``data/peek450g/material.toml``. ``conductivity_table`` /
    ``specific_heat_table`` (pairs of lists ``[[T_C...], [value...]]``) switch on k(T) / cp(T);
    ``hysteresis`` names the H(T) table (``"peek450g"``; ``"none"``, :data:`NO_HYSTERESIS`, for a
    body without hysteresis such as a steel gear: H = 0 at every temperature) or gives one as
    ``[[T_C...], [H...]]``. ``glass_transition_C`` is None for a material without one (steel).
    ``modulus_table`` gives E(T) for ``[cycle] modulus = "thermal_state"`` (else the library's).

    Args:
        name: The material's name. One of the library's (``"PEEK 450G"``, ``"POM"``, ``"PA66"``,
            ``"steel"``) selects its constants, each with its source (docs/materials.md); the
            table's other keys override them.
        density_kg_m3: Density (kg/m^3).
        youngs_modulus_Pa: Young's modulus of the structural cycle (Pa), one value for every
            temperature.
        poissons_ratio: Poisson's ratio.
        thermal_conductivity_W_mK: Thermal conductivity (W/(m K)); ``conductivity_table`` makes it
            k(T).
        specific_heat_J_kgK: Specific heat capacity (J/(kg K)); ``specific_heat_table`` makes it
            c_p(T).
        emissivity: Emissivity of the gear's surfaces in radiation to the surroundings (``[thermal]
            emissivity`` overrides it).
        glass_transition_C: Glass transition temperature (C), None for a material without one: the
            glass-transition friction law steps there unless ``[friction] glass_transition_C`` is
            given.
        hysteresis: H(T) of the hysteresis heat H(T) U_max f: ``"peek450g"`` (the thesis's DMA
            table), ``"none"`` (no hysteresis: a steel gear) or a table ``[[T_C...], [H...]]``.
        conductivity_table, specific_heat_table: k(T) and c_p(T) as ``[[T_C...], [value...]]``,
            linear between the points (None: the constants).
        modulus_table: E(T) as ``[[T_C...], [E_Pa...]]`` (at least 2 points, temperatures
            strictly increasing, moduli in [1e6, 1e12] Pa), linear between the points, for
            ``[cycle] modulus = "thermal_state"``: the cycle scales ``youngs_modulus_Pa`` by
            E(T)/E(T_0), T_0 the table's first temperature. None: the materials library's E(T) of
            the material's ``name``. Not for a steel, which keeps its constant modulus.
    """

    name: str = "PEEK 450G"
    density_kg_m3: float = 1300.0
    youngs_modulus_Pa: float = 3.7e9
    poissons_ratio: float = 0.40
    thermal_conductivity_W_mK: float = 0.25
    specific_heat_J_kgK: float = 1340.0
    emissivity: float = 0.90
    glass_transition_C: float | None = 143.0
    hysteresis: str | tuple[tuple[float, ...], tuple[float, ...]] = "peek450g"
    conductivity_table: tuple[tuple[float, ...], tuple[float, ...]] | None = None
    specific_heat_table: tuple[tuple[float, ...], tuple[float, ...]] | None = None
    modulus_table: tuple[tuple[float, ...], tuple[float, ...]] | None = None

    def __post_init__(self) -> None:
        require_positive("material.density_kg_m3", self.density_kg_m3)
        require_range(
            "material.youngs_modulus_Pa",
            self.youngs_modulus_Pa,
            MODULUS_RANGE_PA[0],
            MODULUS_RANGE_PA[1],
            unit="Pa",
        )
        require_range("material.poissons_ratio", self.poissons_ratio, 0.0, 0.5, hi_open=True)
        require_positive("material.thermal_conductivity_W_mK", self.thermal_conductivity_W_mK)
        require_positive("material.specific_heat_J_kgK", self.specific_heat_J_kgK)
        require_range("material.emissivity", self.emissivity, 0.0, 1.0)
        if isinstance(self.hysteresis, str) and self.hysteresis not in ("peek450g", NO_HYSTERESIS):
            raise ParameterError(
                "material.hysteresis",
                self.hysteresis,
                f"'peek450g', '{NO_HYSTERESIS}' or [[T_C...], [H...]]",
            )
        if self.glass_transition_C is not None:
            require_range(
                "material.glass_transition_C", self.glass_transition_C, -150.0, 500.0, unit="C"
            )
        self.hysteresis_table()  # validates a user table
        self.conductivity()
        self.specific_heat()
        self.modulus_of_temperature()

    @classmethod
    def peek450g(cls) -> Material:
        d = read_toml("peek450g", "material.toml")
        return cls(
            density_kg_m3=d["density_kg_m3"],
            youngs_modulus_Pa=d["youngs_modulus_Pa"],
            poissons_ratio=d["poissons_ratio"],
            thermal_conductivity_W_mK=d["thermal_conductivity_W_mK"],
            specific_heat_J_kgK=d["specific_heat_J_kgK"],
            emissivity=d["emissivity"],
            glass_transition_C=d["glass_transition_C"],
        )

    # elastic ------------------------------------------------------------------------------
    @property
    def lame_mu_Pa(self) -> float:
        return self.youngs_modulus_Pa / (2.0 * (1.0 + self.poissons_ratio))

    @property
    def lame_lambda_Pa(self) -> float:
        E, nu = self.youngs_modulus_Pa, self.poissons_ratio
        return E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))

    @property
    def plane_strain_modulus_Pa(self) -> float:
        """E' = E / (1 - nu^2)."""
        return self.youngs_modulus_Pa / (1.0 - self.poissons_ratio**2)

    # thermal ------------------------------------------------------------------------------
    def hysteresis_table(self) -> TemperatureTable:
        if self.hysteresis == NO_HYSTERESIS:
            return TemperatureTable.constant(0.0, "material.hysteresis")
        if isinstance(self.hysteresis, str):
            return peek450g_hysteresis()
        T_C, H = self.hysteresis
        tab = TemperatureTable.from_celsius(T_C, H, "material.hysteresis")
        if min(tab.values) < 0 or max(tab.values) >= 1:
            raise ParameterError("material.hysteresis", H, "loss fractions H in [0, 1)")
        return tab

    def conductivity(self) -> TemperatureTable:
        if self.conductivity_table is None:
            return TemperatureTable.constant(
                self.thermal_conductivity_W_mK, "material.thermal_conductivity_W_mK"
            )
        tab = TemperatureTable.from_celsius(
            *self.conductivity_table, name="material.conductivity_table"
        )
        if min(tab.values) <= 0:
            raise ParameterError(
                "material.conductivity_table", self.conductivity_table, "positive conductivities"
            )
        return tab

    def specific_heat(self) -> TemperatureTable:
        if self.specific_heat_table is None:
            return TemperatureTable.constant(
                self.specific_heat_J_kgK, "material.specific_heat_J_kgK"
            )
        tab = TemperatureTable.from_celsius(
            *self.specific_heat_table, name="material.specific_heat_table"
        )
        if min(tab.values) <= 0:
            raise ParameterError(
                "material.specific_heat_table", self.specific_heat_table, "positive heat capacities"
            )
        return tab

    # elastic, E(T) ------------------------------------------------------------------------
    def modulus_of_temperature(self) -> TemperatureTable | None:
        """E(T) of ``modulus_table`` (Pa), None without one. A table that is not a pair of lists
        of equal length with at least 2 points, finite temperatures strictly increasing and every
        modulus in :data:`MODULUS_RANGE_PA` raises ParameterError naming
        ``material.modulus_table``, the table and the point at fault."""
        if self.modulus_table is None:
            return None
        name, table = "material.modulus_table", self.modulus_table
        lo, hi = MODULUS_RANGE_PA
        allowed = (
            "[[T_C...], [E_Pa...]] of at least 2 points, finite temperatures strictly increasing, "
            "moduli in " + interval(lo, hi, unit="Pa")
        )
        try:
            T_C, E = (tuple(float(v) for v in row) for row in table)
        except (TypeError, ValueError) as err:
            raise ParameterError(name, table, allowed, "not a pair of lists of numbers") from err
        if len(T_C) != len(E):
            raise ParameterError(
                name, table, allowed, f"lists of unequal length, {len(T_C)} and {len(E)}"
            )
        if len(T_C) < 2:
            raise ParameterError(
                name, table, allowed, "one point: a constant modulus is youngs_modulus_Pa"
            )
        for t in T_C:
            if not math.isfinite(t):
                raise ParameterError(name, table, allowed, f"temperature {t} C")
        for a, b in itertools.pairwise(T_C):
            if b <= a:
                raise ParameterError(name, table, allowed, f"{b:g} C after {a:g} C")
        for t, e in zip(T_C, E):
            if not (math.isfinite(e) and lo <= e <= hi):
                raise ParameterError(name, table, allowed, f"E = {e:g} Pa at {t:g} C")
        return TemperatureTable.from_celsius(T_C, E, name)

    @property
    def thermal_effusivity(self) -> float:
        """b = sqrt(k rho cp) at the reference values, W s^0.5 / (m^2 K) (thesis eq. 2.2)."""
        return math.sqrt(
            self.thermal_conductivity_W_mK * self.density_kg_m3 * self.specific_heat_J_kgK
        )

    @property
    def thermal_diffusivity_m2_s(self) -> float:
        return self.thermal_conductivity_W_mK / (self.density_kg_m3 * self.specific_heat_J_kgK)


def input_ranges() -> dict[str, tuple[float, float]]:
    """Spread between sources of each PEEK 450G constant (for validation input uncertainty)."""
    d = read_toml("peek450g", "material.toml")
    return {k[: -len("_range")]: tuple(v) for k, v in d.items() if k.endswith("_range")}
