"""Young's modulus per cell from a thermal state: a structural cycle whose stiffness follows the
temperature of the teeth.

The cycle's modulus is each gear's constant ``youngs_modulus_Pa`` unless it is given a
:class:`ModulusField`. Then every cell c of a gear the field covers takes

    E_c = E * e(T_c),        e(T) = E_table(T) / E_table(T_0),

E the material's ``youngs_modulus_Pa``, E_table the material's modulus table (its
``modulus_table``, else the library's E(T), ``gearfem/data/materials``), T_0 the table's first
temperature and T_c the gear's temperature at the cell in a thermal state of its own thermal
model. A case that sets its own modulus keeps it at T_0 and softens with temperature as the
table does. Poisson's ratio stays the material's. Beyond the table's last temperature e keeps
its last value (:class:`~gearfem.core.materials.TemperatureTable` is constant outside its range),
which overestimates the modulus where a polymer runs past the table;
:attr:`BodyModulus.beyond_table` is the share of the thermal model's volume that does.

The thermal state of a rotating gear is rotation-averaged, the same on every tooth: a structural
cell's centroid is turned by whole pitches onto the thermal model's reference tooth (the modelled
tooth nearest the middle of its sector, the farthest from its cut faces) and takes the
temperature of the thermal cell whose centroid is nearest (the mean of that cell's vertex
temperatures). Where the two meshes' teeth coincide this is exact; otherwise it is
nearest-neighbour sampling, as the heat sources are carried the other way
(:mod:`gearfem.coupling.heat_sources`).

The stiffness is cell-wise; the cycle's regularisation is not: the contact penalty, the pressure
smoothing (a fraction of the nominal Hertz pressure) and the Hertz half-widths of the flash
temperature take each gear's modulus times :meth:`ModulusField.mean_relative`, the harmonic
volume mean of e, so that a uniform field reproduces the cycle of the scaled constant modulus.

Each e_c is rounded to a relative ``step`` (on a logarithmic grid), so that thermal states that
differ in round-off give the same field and the same cache keys (:meth:`ModulusField.digest`:
the cycle's and the compliances'). Numpy only: each rank evaluates its own cells.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib

import numpy as np
from scipy.spatial import cKDTree

from gearfem.core.errors import ParameterError
from gearfem.core.materials import TemperatureTable
from gearfem.geometry.options import BODIES
from gearfem.geometry.placement import tooth_local

#: Default rounding of the relative modulus e (relative step, 0.1 %).
MODULUS_STEP = 1e-3


@dataclasses.dataclass(frozen=True, eq=False)
class GearTemperature:
    """A thermal state of one gear's thermal model, as the field samples it.

    Attributes:
        nodes_m: (n, 3) node coordinates, pair frame.
        cells: (c, k) node indices of the tetrahedra, vertices first (k = 4 or 10).
        temperature_K: (n,) nodal temperatures.
        center_m: (3,) the gear's centre (on its axis at z = 0), pair frame.
        tooth_angles_rad: Centre-line angles of the thermal model's teeth about the centre.
    """

    nodes_m: np.ndarray
    cells: np.ndarray
    temperature_K: np.ndarray
    center_m: np.ndarray
    tooth_angles_rad: np.ndarray


@dataclasses.dataclass(frozen=True, eq=False)
class BodyModulus:
    """One gear's relative modulus e(T) on its thermal cells.

    Attributes:
        center_m: The gear's centre, pair frame.
        reference_angle_rad: Centre-line angle of the thermal tooth the cells are sampled on.
        cell_points_m: (c, 3) thermal cell centroids relative to ``center_m``.
        relative: (c,) e(T_c), rounded to the field's step.
        temperature_K: (c,) the cells' temperatures (mean of their vertices').
        volume_m3: (c,) the cells' volumes (straight-sided).
        table_end_K: The table's last temperature.
    """

    center_m: np.ndarray
    reference_angle_rad: float
    cell_points_m: np.ndarray
    relative: np.ndarray
    temperature_K: np.ndarray
    volume_m3: np.ndarray
    table_end_K: float

    @property
    def beyond_table(self) -> float:
        """Share of the thermal model's volume above the table's last temperature."""
        hot = self.temperature_K > self.table_end_K
        return float(self.volume_m3[hot].sum() / self.volume_m3.sum())

    @functools.cached_property
    def _tree(self) -> cKDTree:
        return cKDTree(self.cell_points_m)


def _round_relative(e: np.ndarray, step: float) -> np.ndarray:
    return np.exp(np.round(np.log(e) / step) * step)


@dataclasses.dataclass(frozen=True, eq=False)
class ModulusField:
    """The relative modulus of each covered gear (see the module docstring); a gear the field
    does not hold (no table: a steel gear) keeps its constant modulus."""

    bodies: dict[str, BodyModulus]
    step: float = MODULUS_STEP

    @classmethod
    def from_temperatures(
        cls,
        states: dict[str, GearTemperature],
        tables: dict[str, TemperatureTable],
        step: float = MODULUS_STEP,
    ) -> ModulusField:
        """The field of the gears in ``tables`` (E(T) in Pa, or any unit: only ratios are
        used) at the thermal ``states`` of those gears."""
        if not 0.0 < step < 0.1:
            raise ParameterError("modulus_field.step", step, "0 < step < 0.1")
        bodies = {}
        for b, table in tables.items():
            if b not in BODIES:
                raise ParameterError("modulus_field.body", b, f"one of {BODIES}")
            if b not in states:
                raise ParameterError(
                    "modulus_field.states", sorted(states), f"a thermal state of the {b}"
                )
            s = states[b]
            x = np.asarray(s.nodes_m)[np.asarray(s.cells)[:, :4]]  # (c, 4, 3) vertices
            vol = np.abs(np.einsum("ij,ij->i", np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]),
                                   x[:, 3] - x[:, 0])) / 6.0  # fmt: skip
            T = np.asarray(s.temperature_K)[np.asarray(s.cells)[:, :4]].mean(axis=1)
            e0 = float(table.values[0])
            if e0 <= 0.0 or min(table.values) <= 0.0:
                raise ParameterError(f"{table.name}.values", table.values, "positive moduli")
            e = np.asarray(table(T), dtype=float) / e0
            angles = np.asarray(s.tooth_angles_rad, dtype=float)
            bodies[b] = BodyModulus(
                center_m=np.asarray(s.center_m, dtype=float),
                reference_angle_rad=float(angles[(len(angles) - 1) // 2]),
                cell_points_m=x.mean(axis=1) - np.asarray(s.center_m),
                relative=_round_relative(e, step),
                temperature_K=T,
                volume_m3=vol,
                table_end_K=float(table.T_K[-1]),
            )
        return cls(bodies, float(step))

    def relative_at(
        self, body: str, points_m: np.ndarray, center_m: np.ndarray, tooth_angles_rad: np.ndarray
    ) -> np.ndarray:
        """e at ``points_m`` (pair frame) of a structural gear centred at ``center_m`` whose
        modelled teeth have the centre-line angles ``tooth_angles_rad``; 1 for a gear the field
        does not hold."""
        points_m = np.asarray(points_m, dtype=float).reshape(-1, 3)
        bm = self.bodies.get(body)
        if bm is None or len(points_m) == 0:
            return np.ones(len(points_m))
        local, _ = tooth_local(points_m, center_m, tooth_angles_rad, 0.0, bm.reference_angle_rad)
        _, j = bm._tree.query(local)
        return bm.relative[j]

    def mean_relative(self, body: str) -> float:
        """The harmonic volume mean of e over the gear's thermal cells (1 for a gear the field
        does not hold): the uniform relative modulus of the same mean compliance, which the
        cycle's regularisation takes (the contact penalty, the pressure smoothing by the nominal
        Hertz pressure, the Hertz half-widths of the flash temperature), so that a uniform field
        gives the cycle of the constant modulus scaled by its e."""
        bm = self.bodies.get(body)
        if bm is None:
            return 1.0
        return float(bm.volume_m3.sum() / np.sum(bm.volume_m3 / bm.relative))

    def change_from(self, previous: ModulusField | None) -> tuple[float, float]:
        """How far this field moved from ``previous`` (None: the constant modulus, e = 1): the
        largest relative change of a gear's :meth:`mean_relative`, and the largest of a cell's
        e (the two fields of one thermal model's cells)."""
        mean = cell = 0.0
        for b, bm in self.bodies.items():
            before = previous.bodies.get(b) if previous is not None else None
            old = before.relative if before is not None else np.ones_like(bm.relative)
            if old.shape != bm.relative.shape:
                raise ParameterError(
                    "modulus_field.previous", old.shape, f"a field on the same cells as {b}'s"
                )
            old_mean = previous.mean_relative(b) if before is not None else 1.0
            mean = max(mean, abs(self.mean_relative(b) / old_mean - 1.0))
            cell = max(cell, float(np.max(np.abs(bm.relative / old - 1.0))))
        return mean, cell

    def digest(self) -> str:
        """Hash of what the field gives a cycle (the cycle's and the compliances' cache keys)."""
        h = hashlib.sha256(f"step={self.step!r}".encode())
        for b in sorted(self.bodies):
            bm = self.bodies[b]
            h.update(b.encode())
            h.update(np.round(bm.center_m, 9).tobytes())
            h.update(np.float64(round(bm.reference_angle_rad, 12)).tobytes())
            h.update(np.round(bm.cell_points_m, 9).tobytes())
            h.update(np.round(np.log(bm.relative) / self.step).astype(np.int64).tobytes())
        return h.hexdigest()[:16]


__all__ = ["MODULUS_STEP", "BodyModulus", "GearTemperature", "ModulusField"]
