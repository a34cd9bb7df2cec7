"""What a finished run keeps for its instruments: the temperature fields of the gears and the
cycle's torques, independent of how many ranks computed them (numpy; no DOLFINx).

Per gear (:class:`BodyField`): the thermal mesh gathered on one rank, its nodes sorted by their
coordinates (so the arrays are the same whatever the partition), the cells (10-node tetrahedra for
a quadratic mesh, 4-node for a linear one), the boundary faces oriented outwards with the kind of
surface each lies on (side_front, side_back, drive_flank, coast_flank, tip, root, bore, cut_start,
cut_end), and the nodal temperatures at the reported times (labels: the output times as
``"900"``, the end of the run ``"end"``, the steady state ``"steady"``). Coordinates are those of
the mesh as built, in the pair frame (pinion axis = z axis, wheel axis through (a, 0, 0), face
width z in [0, b]); the body's placement (centre, tooth-centre angles) comes with it, so that the
periodic sector can be completed to the whole gear by rotation.

The pair (:class:`FieldSnapshot`): the gears' fields, the reported times, the operating point and
the cycle's torque histories (:class:`CycleTorques`). Written next to ``summary.json`` as
``instruments/snapshot.npz`` by ``gearfem run``; ``gearfem observe`` evaluates instruments on it
without solving again.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
from pathlib import Path
from typing import Any

import numpy as np

from gearfem.core.errors import ParameterError
from gearfem.core.facets import triangle_shape

KINDS = (
    "side_front",
    "side_back",
    "drive_flank",
    "coast_flank",
    "tip",
    "root",
    "bore",
    "cut_start",
    "cut_end",
)
FORMAT_VERSION = 1
#: Lattice intervals per side on which :meth:`BodyField.hottest_point` samples each quadratic face
#: (91 points: a quadratic's maximum on a face of 0.2 mm is found to well below 1 mK).
FACE_LATTICE = 12


def face_lattice(n: int) -> np.ndarray:
    """Barycentric coordinates (λ0, λ1, λ2) of the points i/n, j/n of the triangle, (m, 3)."""
    return np.array(
        [(i / n, j / n, 1.0 - (i + j) / n) for i in range(n + 1) for j in range(n + 1 - i)]
    )


def face_trace_basis(lam: np.ndarray, nodes_per_face: int) -> np.ndarray:
    """The face's nodal basis at barycentric points ``lam`` (m, 3): linear (3 nodes) or quadratic
    (6 nodes: the vertices, then the edges (1,2), (0,2), (0,1), as :attr:`BodyField.faces`)."""
    degree = {3: 1, 6: 2}.get(nodes_per_face)
    if degree is None:
        raise ParameterError("nodes_per_face", nodes_per_face, "3 (linear) or 6 (quadratic)")
    lam = np.asarray(lam, dtype=float)
    return triangle_shape(lam[:, 1], lam[:, 2], degree)[0]


@dataclasses.dataclass(frozen=True, eq=False)
class BodyField:
    """One gear's thermal mesh and temperatures (see the module docstring).

    Attributes:
        body: ``"pinion"`` or ``"wheel"``.
        nodes_m: (n, 3) node coordinates, pair frame, sorted lexicographically.
        cells: (c, 10) or (c, 4) node indices of the tetrahedra (basix order: vertices, then the
            edges (2,3), (1,3), (1,2), (0,3), (0,2), (0,1)).
        faces: (f, 6) or (f, 3) node indices of the boundary faces (vertices, then the edges
            (1,2), (0,2), (0,1)), counter-clockwise seen from outside.
        face_kind: (f,) index into :data:`KINDS` of each face.
        temperature_K: (labels, n) nodal temperatures at the snapshot's labels.
        center_m: Centre of the body (on its axis at z = 0), pair frame.
        tooth_angles_rad: Centre-line angles of the modelled teeth about the centre.
        teeth: Teeth of the whole gear.
        rotation_sense: +1 counter-clockwise about +z (the pinion), -1 clockwise (the wheel).
        speed_rpm: The body's speed.
        emissivity: The thermal model's radiation emissivity of the surfaces.
        temperatures_C: The thermal model's reported temperatures at each label (max_surface,
            mean_bulk, flank_mean, ...).
        heat_W: The whole gear's heat sources at each label: ``friction_W`` (its share of the
            friction heat of the active friction law, at that state) and ``hysteresis_W`` (empty
            for a snapshot written before they were kept).
    """

    body: str
    nodes_m: np.ndarray
    cells: np.ndarray
    faces: np.ndarray
    face_kind: np.ndarray
    temperature_K: np.ndarray
    center_m: np.ndarray
    tooth_angles_rad: np.ndarray
    teeth: int
    rotation_sense: int
    speed_rpm: float
    emissivity: float
    temperatures_C: dict[str, dict[str, float]]
    heat_W: dict[str, dict[str, float]] = dataclasses.field(default_factory=dict)

    @property
    def pitch_rad(self) -> float:
        return 2.0 * math.pi / self.teeth

    @property
    def full(self) -> bool:
        """True when the mesh is the whole gear (no cut faces)."""
        return len(self.tooth_angles_rad) == self.teeth

    @property
    def central_tooth(self) -> int:
        """The tooth in the middle of the sector: furthest from the adiabatic cut faces."""
        return len(self.tooth_angles_rad) // 2

    def hottest_point(
        self, label: int, kinds: tuple[str, ...] | None = None, lattice: int = FACE_LATTICE
    ) -> tuple[float, np.ndarray]:
        """The largest temperature (K) of the finite-element field on the faces of ``kinds``
        (None: all but the cut faces) at snapshot label index ``label``, and where it is (pair
        frame, m). On a quadratic mesh the field on a face is the quadratic through its six
        nodes, whose maximum may lie between them: it is sampled on a lattice of ``lattice``
        intervals per side (the nodes are lattice points, so this is never below the hottest
        node)."""
        names = kinds or tuple(k for k in KINDS if not k.startswith("cut_"))
        sel = np.isin(self.face_kind, [KINDS.index(k) for k in names])
        if not np.any(sel):
            raise ParameterError("kinds", kinds, f"surface kinds present in the snapshot, {KINDS}")
        faces = self.faces[sel]
        basis = face_trace_basis(face_lattice(lattice), faces.shape[1])
        values = self.temperature_K[label][faces] @ basis.T  # (faces, lattice points)
        f, p = np.unravel_index(int(np.argmax(values)), values.shape)
        return float(values[f, p]), basis[p] @ self.nodes_m[faces[f]]


@dataclasses.dataclass(frozen=True, eq=False)
class CycleTorques:
    """The torques of the structural cycle (per position; per unit pinion speed where noted).

    ``pinion_torque_Nm``: the torque driving the pinion at each position; ``resisting_torque_Nm``
    the constant torque holding the wheel; ``speed_ratio`` = ω₂/ω₁ = z₁/z₂;
    ``friction_power_W_per_rad_s``: ∫ μ p v_s dA per unit ω₁ at each position.
    """

    pinion_torque_Nm: np.ndarray
    resisting_torque_Nm: float
    speed_ratio: float
    friction_power_W_per_rad_s: np.ndarray
    friction_coefficient: float

    @classmethod
    def of(cls, cycle) -> CycleTorques:
        """From a :class:`gearfem.cycle.result.CycleResult`."""
        return cls(
            pinion_torque_Nm=np.asarray(cycle.pinion_torque_Nm, dtype=float),
            resisting_torque_Nm=float(cycle.torque_Nm),
            speed_ratio=float(cycle.info["speed_ratio"]),
            friction_power_W_per_rad_s=np.asarray(cycle.friction_power_W_per_rad_s, dtype=float),
            friction_coefficient=float(cycle.friction_coefficient),
        )


@dataclasses.dataclass(frozen=True, eq=False)
class FieldSnapshot:
    """The fields and torques a run's instruments read (see the module docstring).

    Attributes:
        labels: The reported times' labels, in order; ``times_s`` their times (None: steady).
        bodies: The gears' fields by body name.
        pinion_speed_rpm: Operating speed of the pinion.
        face_width_m: Face width b.
        ambient_C: The thermal model's ambient (air and surroundings).
        torques: The cycle's torques (None: prescribed sources, no cycle).
        case: Name of the case.
    """

    labels: tuple[str, ...]
    times_s: tuple[float | None, ...]
    bodies: dict[str, BodyField]
    pinion_speed_rpm: float
    face_width_m: float
    ambient_C: float
    torques: CycleTorques | None = None
    case: str = ""

    def __post_init__(self) -> None:
        if len(self.labels) != len(self.times_s):
            raise ValueError("one time per label")
        for b in self.bodies.values():
            if b.temperature_K.shape != (len(self.labels), len(b.nodes_m)):
                raise ValueError(f"{b.body}: temperatures of shape (labels, nodes) expected")

    def label_index(self, label: str) -> int:
        if label not in self.labels:
            raise ParameterError("time label", label, "one of " + ", ".join(self.labels))
        return self.labels.index(label)

    def mesh_heat_W(self, label: str) -> tuple[float, float] | None:
        """The pair's friction and hysteresis heat (W, whole gears) at ``label``: the sum of both
        gears' shares, each from its own thermal model at that state (None unless both gears'
        fields with their heat are kept)."""
        parts = [b.heat_W.get(label) for b in self.bodies.values()]
        if len(parts) != 2 or any(p is None for p in parts):
            return None
        return (
            float(sum(p["friction_W"] for p in parts)),
            float(sum(p["hysteresis_W"] for p in parts)),
        )

    def label_of(self, time_s: float | None) -> str:
        """The label of a reported time: None is the end value (the steady state when the run
        computed one, else the end of the run); a time is the output time it equals."""
        if time_s is None:
            return "steady" if "steady" in self.labels else "end"
        for lab, t in zip(self.labels, self.times_s):
            if t is not None and abs(t - time_s) <= 1e-6 * max(1.0, abs(time_s)):
                return lab
        raise ParameterError(
            "time_s",
            time_s,
            "a reported time of the run: "
            + ", ".join(f"{t:g} s" for t in self.times_s if t is not None),
        )

    # --- storage ----------------------------------------------------------------------------------
    def save(self, path: str | Path) -> Path:
        """Write as one ``.npz`` (atomically: a temporary file, then a rename)."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        arrays: dict[str, np.ndarray] = {}
        meta: dict[str, Any] = {
            "format": FORMAT_VERSION,
            "labels": list(self.labels),
            "times_s": list(self.times_s),
            "pinion_speed_rpm": self.pinion_speed_rpm,
            "face_width_m": self.face_width_m,
            "ambient_C": self.ambient_C,
            "case": self.case,
            "bodies": {},
            "torques": None,
        }
        for name, b in self.bodies.items():
            for key in ("nodes_m", "cells", "faces", "face_kind", "temperature_K"):
                arrays[f"{name}.{key}"] = np.asarray(getattr(b, key))
            arrays[f"{name}.center_m"] = np.asarray(b.center_m, dtype=float)
            arrays[f"{name}.tooth_angles_rad"] = np.asarray(b.tooth_angles_rad, dtype=float)
            meta["bodies"][name] = {
                "teeth": b.teeth,
                "rotation_sense": b.rotation_sense,
                "speed_rpm": b.speed_rpm,
                "emissivity": b.emissivity,
                "temperatures_C": b.temperatures_C,
                "heat_W": b.heat_W,
            }
        if self.torques is not None:
            t = self.torques
            arrays["torques.pinion_torque_Nm"] = t.pinion_torque_Nm
            arrays["torques.friction_power_W_per_rad_s"] = t.friction_power_W_per_rad_s
            meta["torques"] = {
                "resisting_torque_Nm": t.resisting_torque_Nm,
                "speed_ratio": t.speed_ratio,
                "friction_coefficient": t.friction_coefficient,
            }
        arrays["meta"] = np.array(json.dumps(meta))
        tmp = path.with_name(f".{path.name}.tmp{os.getpid()}.npz")
        np.savez_compressed(tmp, **arrays)
        os.replace(tmp, path)
        return path

    @classmethod
    def load(cls, path: str | Path) -> FieldSnapshot:
        path = Path(path)
        if not path.is_file():
            raise ParameterError(
                "snapshot", str(path), "the instruments/snapshot.npz of a finished gearfem run"
            )
        with np.load(path, allow_pickle=False) as z:
            meta = json.loads(str(z["meta"]))
            if meta.get("format") != FORMAT_VERSION:
                raise ParameterError(
                    "snapshot format", meta.get("format"), str(FORMAT_VERSION), "re-run the case"
                )
            bodies = {}
            for name, m in meta["bodies"].items():
                bodies[name] = BodyField(
                    body=name,
                    nodes_m=z[f"{name}.nodes_m"],
                    cells=z[f"{name}.cells"],
                    faces=z[f"{name}.faces"],
                    face_kind=z[f"{name}.face_kind"],
                    temperature_K=z[f"{name}.temperature_K"],
                    center_m=z[f"{name}.center_m"],
                    tooth_angles_rad=z[f"{name}.tooth_angles_rad"],
                    teeth=int(m["teeth"]),
                    rotation_sense=int(m["rotation_sense"]),
                    speed_rpm=float(m["speed_rpm"]),
                    emissivity=float(m["emissivity"]),
                    temperatures_C=m["temperatures_C"],
                    heat_W=m.get("heat_W", {}),
                )
            torques = None
            if meta["torques"] is not None:
                t = meta["torques"]
                torques = CycleTorques(
                    pinion_torque_Nm=z["torques.pinion_torque_Nm"],
                    resisting_torque_Nm=float(t["resisting_torque_Nm"]),
                    speed_ratio=float(t["speed_ratio"]),
                    friction_power_W_per_rad_s=z["torques.friction_power_W_per_rad_s"],
                    friction_coefficient=float(t["friction_coefficient"]),
                )
        return cls(
            labels=tuple(meta["labels"]),
            times_s=tuple(meta["times_s"]),
            bodies=bodies,
            pinion_speed_rpm=float(meta["pinion_speed_rpm"]),
            face_width_m=float(meta["face_width_m"]),
            ambient_C=float(meta["ambient_C"]),
            torques=torques,
            case=str(meta["case"]),
        )
