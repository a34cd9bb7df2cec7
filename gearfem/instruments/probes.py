"""Temperature probes on one gear: a thermocouple at a point, a side-face spot on a circle, a
reported field value (numpy only; options: :class:`gearfem.instruments.options.ProbeOptions`).

* **Thermocouple**: the temperature field at a point, interpolated with the quadratic (or linear)
  shape functions of the tetrahedron that contains it (located by its vertices' barycentric
  coordinates). The point is given in the body's own polar frame: radius, angle from the centre
  line of the sector's central tooth (the one furthest from the sector's adiabatic cut faces) and
  axial position. A junction small against the elements and no lag: the gears warm up over
  minutes, a thermocouple responds within about a second.
* **Side face**: the mean over one tooth pitch of the side-face temperature on the circle of the
  given radius (points of the circle outside the body, in the gaps, are left out), as a probe
  rubbing on the turning face or a spot pyrometer aimed at it sees it.
* **Field**: one of the thermal model's reported temperatures (max_surface, mean_bulk, flank_mean,
  tip_max, ...), at the same times as the other instruments.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from gearfem.core.errors import ParameterError
from gearfem.core.materials import ZERO_CELSIUS_K
from gearfem.core.results import JsonRecord
from gearfem.instruments.options import ProbeOptions
from gearfem.instruments.snapshot import KINDS, BodyField

SIDE_SAMPLES = 1440

# basix edge order of a tetrahedron and of a triangle
_TET_EDGES = ((2, 3), (1, 3), (1, 2), (0, 3), (0, 2), (0, 1))
_TRI_EDGES = ((1, 2), (0, 2), (0, 1))


@dataclasses.dataclass(frozen=True)
class ProbeReading(JsonRecord):
    """One probe's reading at one label: ``value_C`` and where it was read (pair frame, mm)."""

    name: str
    kind: str
    body: str
    value_C: float
    point_mm: tuple[float, float, float] | None = None


def _shape(lam: np.ndarray, nodes: int) -> np.ndarray:
    """Lagrange shape functions at barycentric coordinates ``lam`` (..., d+1) for the simplex of
    ``nodes`` nodes (3, 6: triangle; 4, 10: tetrahedron), basix node order."""
    d1 = lam.shape[-1]
    if nodes == d1:
        return lam
    edges = _TRI_EDGES if d1 == 3 else _TET_EDGES
    out = [lam[..., i] * (2.0 * lam[..., i] - 1.0) for i in range(d1)]
    out += [4.0 * lam[..., a] * lam[..., b] for a, b in edges]
    return np.stack(out, axis=-1)


def locate_in_cells(field: BodyField, points: np.ndarray, tol: float = 1e-9):
    """(cell index, barycentric coordinates) of each point in the tetrahedra of ``field``
    (index -1 where no cell contains the point)."""
    v = field.nodes_m[field.cells[:, :4]]  # (c, 4, 3)
    A = np.transpose(v[:, 1:] - v[:, :1], (0, 2, 1))  # (c, 3, 3)
    Ainv = np.linalg.inv(A)
    out_c = np.full(len(points), -1, dtype=np.int64)
    out_l = np.zeros((len(points), 4))
    for i, p in enumerate(points):
        l123 = np.einsum("cij,cj->ci", Ainv, p - v[:, 0])
        lam = np.column_stack([1.0 - l123.sum(axis=1), l123])
        worst = lam.min(axis=1)
        c = int(np.argmax(worst))
        if worst[c] >= -tol:
            out_c[i], out_l[i] = c, lam[c]
    return out_c, out_l


def locate_in_faces(field: BodyField, kind: str, xy: np.ndarray, tol: float = 1e-9):
    """(face index, barycentric coordinates) of points (n, 2) in the faces of ``kind`` projected
    on the xy plane (a side face is planar at z = 0 or b); -1 where none contains the point."""
    sel = np.flatnonzero(field.face_kind == KINDS.index(kind))
    p = field.nodes_m[field.faces[sel, :3]][..., :2]  # (f, 3, 2)
    e1, e2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    out_f = np.full(len(xy), -1, dtype=np.int64)
    out_l = np.zeros((len(xy), 3))
    for i, q in enumerate(xy):
        d = q - p[:, 0]
        l1 = (d[:, 0] * e2[:, 1] - d[:, 1] * e2[:, 0]) / det
        l2 = (e1[:, 0] * d[:, 1] - e1[:, 1] * d[:, 0]) / det
        lam = np.column_stack([1.0 - l1 - l2, l1, l2])
        worst = lam.min(axis=1)
        f = int(np.argmax(worst))
        if worst[f] >= -tol:
            out_f[i], out_l[i] = sel[f], lam[f]
    return out_f, out_l


def _polar_point(field: BodyField, radius_m: float, angle_rad: float, z_m: float) -> np.ndarray:
    theta = float(field.tooth_angles_rad[field.central_tooth]) + angle_rad
    c = field.center_m
    return np.array([c[0] + radius_m * math.cos(theta), c[1] + radius_m * math.sin(theta), z_m])


def read_probe(
    name: str,
    probe: ProbeOptions,
    field: BodyField,
    rows: list[int],
    labels: list[str],
    face_width_m: float,
) -> list[ProbeReading]:
    """The probe's reading at each snapshot row (``rows``, labelled ``labels``)."""
    where = f"instruments.probes.{name}"
    if probe.kind == "field":
        out = []
        for lab in labels:
            vals = field.temperatures_C.get(lab, {})
            if probe.quantity not in vals:
                raise ParameterError(
                    f"{where}.quantity",
                    probe.quantity,
                    "a quantity the thermal model reported: " + ", ".join(sorted(vals)),
                )
            out.append(ProbeReading(name, probe.kind, probe.body, float(vals[probe.quantity])))
        return out
    r = probe.radius_mm * 1e-3
    if probe.kind == "thermocouple":
        z = 0.5 * face_width_m if probe.z_mm is None else probe.z_mm * 1e-3
        x = _polar_point(field, r, math.radians(probe.angle_deg), z)
        cell, lam = locate_in_cells(field, x[None, :])
        if cell[0] < 0:
            raise ParameterError(
                f"{where}.radius_mm",
                probe.radius_mm,
                f"a point inside the {probe.body} (with angle_deg = {probe.angle_deg:g}, z_mm = "
                f"{z * 1e3:g})",
            )
        nodes = field.cells[cell[0]]
        w = _shape(lam[0], len(nodes))
        T = field.temperature_K[rows][:, nodes] @ w
        pt = tuple(float(v) * 1e3 for v in x)
        return [
            ProbeReading(name, probe.kind, probe.body, float(t - ZERO_CELSIUS_K), pt) for t in T
        ]
    # side face
    kind = "side_front" if probe.side == "front" else "side_back"
    pitch = field.pitch_rad
    ang = (np.arange(SIDE_SAMPLES) + 0.5) / SIDE_SAMPLES * pitch - 0.5 * pitch
    theta = float(field.tooth_angles_rad[field.central_tooth]) + ang
    xy = np.column_stack(
        [field.center_m[0] + r * np.cos(theta), field.center_m[1] + r * np.sin(theta)]
    )
    face, lam = locate_in_faces(field, kind, xy)
    ok = face >= 0
    if not np.any(ok):
        raise ParameterError(
            f"{where}.radius_mm",
            probe.radius_mm,
            f"a radius at which the {probe.body} has material",
        )
    nodes = field.faces[face[ok]]  # (m, 3|6)
    w = _shape(lam[ok], nodes.shape[1])
    T = np.einsum("lmk,mk->lm", field.temperature_K[rows][:, nodes], w).mean(axis=1)
    z = 0.0 if probe.side == "front" else face_width_m
    pt = tuple(float(v) * 1e3 for v in _polar_point(field, r, 0.0, z))
    return [ProbeReading(name, probe.kind, probe.body, float(t - ZERO_CELSIUS_K), pt) for t in T]
